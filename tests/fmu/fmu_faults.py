"""What the tests tell FaultyRover (FaultyRover/config.h) to do, and a scenario that runs it."""

from __future__ import annotations

from pathlib import Path

from support import free_udp_ports

#: FaultyRover's `fault` parameter
NAN, INF, HUGE, HANG, FAR, SEGV, EXIT, ABORT, INIT_HANG = 1, 2, 3, 4, 5, 6, 7, 8, 9


def alive(pid: int) -> bool:
    """Process ``pid`` is running (one that ended but is not reaped yet, a zombie, is not)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (FileNotFoundError, ProcessLookupError):
        return False
    return state not in ("Z", "X")


def faulty_scenario(fmu: Path, fault: int, fault_at: float, log_dir: Path, duration_s: float = 3.0) -> str:
    """A leader and a follower, both FaultyRover; only the follower has the fault (on free
    loopback ports, no ground station)."""
    return f"""name = "faulty"
[sim]
duration_s = {duration_s}
sensing = "truth"
[recording]
dir = "{log_dir}"
[link]
udp_base_port = {free_udp_ports(2)}
gcs_udpout = ""
[[vehicles]]
name = "leader"
role = "leader"
fmu = "{fmu}"
[[vehicles]]
name = "f1"
role = "follower"
fmu = "{fmu}"
north_m = -1.5
target = "leader"
range_m = 1.5
[vehicles.parameters]
fault = {fault}
fault_at = {fault_at}
"""
