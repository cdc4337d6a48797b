"""lfctl bench link --fuzz: hostile datagrams and a soak against a recording --realtime run.

A `lfctl sim --realtime` process (leader + follower, truth sensing, recording on) is started
as a user starts it. Then:

1. fuzz: at least 100,000 datagrams (random bytes; MAVLink 1 and 2 frames of every message
   id with NaN, infinities, extremes and their enums' values; frames of the messages a
   vehicle handles, addressed to it; mutated, truncated, bad-CRC, unknown-id and
   forged-signature frames; see :mod:`lfctl.bench.fuzz`) are sent as fast as one sender can
   to both vehicles' ports, in ten parts with the leader put in GUIDED and armed before each
   (so that setpoints are acted on: the fuzz's own commands soon change its mode);
2. then a ground station must still upload a mission, change the mode and arm;
3. soak: two ground stations connect, talk for a few seconds and leave, again and again, while
   the process's resident memory is sampled;
4. the run is stopped with SIGINT and must end by itself with a finished log.

Printed: datagrams sent and handled (read by the endpoints, from the log's link statistics),
handled per second, crashes (a traceback, a handler error, an exit that is not the interrupt's,
an unfinished log: must be 0), memory before and after the flood, and over the soak.
"""

from __future__ import annotations

import contextlib
import re
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

from lfctl.bench.common import free_udp_ports, print_json, print_table
from lfctl.bench.fuzz import datagrams
from lfctl.errors import LinkTimeoutError
from lfctl.link.gcs import GroundStation
from lfctl.link.mission import local_mission

__all__ = ["main"]

HOME = (12.9602, 77.6690, 900.0)
SCENARIO = """
name = "fuzz"
[sim]
sensing = "truth"
[[vehicles]]
name = "leader"
role = "leader"
[[vehicles]]
name = "follower1"
role = "follower"
north_m = -1.5
[mission]
waypoints = [[4.0, 0.0], [4.0, 4.0], [0.0, 4.0], [0.0, 0.0]]
[link]
udp_base_port = {port}
gcs_udpout = ""
[recording]
dir = "{logs}"
"""


def rss_mb(pid: int) -> float:
    """Resident memory of a process, MB (Linux /proc)."""
    text = Path(f"/proc/{pid}/status").read_text()
    m = re.search(r"VmRSS:\s+(\d+) kB", text)
    return int(m.group(1)) / 1024 if m else float("nan")


def start_sim(tmp: Path) -> tuple[subprocess.Popen[str], int]:
    base = free_udp_ports(2)
    scenario = tmp / "fuzz.toml"
    scenario.write_text(SCENARIO.format(port=base, logs=tmp / "logs"))
    proc = subprocess.Popen(
        [sys.executable, "-m", "lfctl", "sim", str(scenario), "--realtime", "--duration", "100000", "-q"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=tmp,
    )
    assert proc.stdout is not None
    seen = 0
    while seen < 2:  # the two "mavlink ... udpin" lines: the ports are bound
        line = proc.stdout.readline()
        if not line:
            raise RuntimeError(f"lfctl sim ended before its ports were up: {proc.stderr.read() if proc.stderr else ''}")
        seen += "udpin" in line
    return proc, base


#: the flood goes in this many parts, the leader put back in GUIDED and armed before each
#: (the fuzz's own mode and arming commands take it out within a few thousand datagrams)
FLOOD_PARTS = 10


def flood(base: int, n: int) -> tuple[float, int]:
    """Send ``n`` fuzz datagrams to both vehicles, in :data:`FLOOD_PARTS` parts with the
    leader put in GUIDED and armed before each; returns the seconds the sending took and how
    many parts began with the leader GUIDED and armed."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind(("127.0.0.1", 0))
    sending, guided = 0.0, 0
    part = max(1, n // FLOOD_PARTS)
    t0 = time.perf_counter()
    for k, d in enumerate(datagrams(2026, n)):
        if k % part == 0:
            sending += time.perf_counter() - t0
            guided += guided_and_armed(base)
            t0 = time.perf_counter()
        with contextlib.suppress(OSError):  # the kernel's buffer was full: counted as not handled
            sock.sendto(d, ("127.0.0.1", base + k % 2))
        if k % 2000 == 1999:
            time.sleep(0.001)  # let the kernel hand datagrams over instead of dropping them all
    sock.close()
    return sending + time.perf_counter() - t0, guided


def guided_and_armed(base: int) -> bool:
    """Put the leader in GUIDED and arm it, so that the fuzz's setpoints (NaN, 1e38, a pole)
    reach the code that takes a GUIDED target, and the ones it takes are driven to; whether
    it took both (the fuzz may have changed what arming needs: a finding, not a crash)."""
    g = GroundStation(f"udpout:127.0.0.1:{base}", target_system=1, timeout_s=5.0)
    try:
        g.wait_heartbeat()
        return g.set_mode("GUIDED") == 0 and g.arm(True) == 0
    except LinkTimeoutError:
        return False
    finally:
        g.close()


def still_a_vehicle(base: int) -> dict[str, bool]:
    """Mission upload, mode change and arming work after the flood."""
    out = {"upload": False, "mode": False, "arm": False}
    g = GroundStation(f"udpout:127.0.0.1:{base}", target_system=1, timeout_s=5.0)
    try:
        g.wait_heartbeat()
        g.upload(local_mission([(2.0, 0.0), (2.0, 2.0)], HOME))
        out["upload"] = True
        out["mode"] = g.set_mode("AUTO") == 0
        out["arm"] = g.arm(True) == 0
    finally:
        g.close()
    return out


def soak(base: int, pid: int, seconds: float) -> list[float]:
    """Two ground stations connect, talk and leave, over and over; RSS sampled every 5 s."""
    stop = threading.Event()
    errors: list[str] = []

    def visitor(target: int) -> None:
        while not stop.is_set():
            try:
                g = GroundStation(f"udpout:127.0.0.1:{base + target - 1}", target_system=target, timeout_s=3.0)
                try:
                    g.wait_heartbeat()
                    g.param_get("WP_SPEED")
                    t_end = time.monotonic() + 3.0
                    while time.monotonic() < t_end and not stop.is_set():
                        g.heartbeat()
                        g.next_message(0.1)
                finally:
                    g.close()
            except Exception as exc:  # recorded: a vehicle that stops answering is a finding
                errors.append(f"{type(exc).__name__}: {exc}")
                time.sleep(0.5)

    threads = [threading.Thread(target=visitor, args=(t,), daemon=True) for t in (1, 2)]
    for t in threads:
        t.start()
    samples = []
    t_end = time.monotonic() + seconds
    while time.monotonic() < t_end:
        samples.append(rss_mb(pid))
        time.sleep(min(5.0, max(0.0, t_end - time.monotonic())))
    stop.set()
    for t in threads:
        t.join(timeout=10)
    if errors:
        print(f"soak: {len(errors)} ground-station sessions failed, first: {errors[0]}", file=sys.stderr)
    return samples


def link_stats(log: Path) -> dict[str, dict[str, int]]:
    """The link statistics a run wrote into its log's metadata."""
    from lfctl.record.audit import audit

    report = audit(log)
    return {
        name.removeprefix("link."): {k: int(v) for k, v in values.items()}
        for name, values in report.contents.metadata.items()
        if name.startswith("link.")
    }


def main(quick: bool = False, soak_s: float | None = None) -> None:
    """Run the fuzz and soak benchmark; print its table and JSON line.

    Parameters
    ----------
    quick : bool
        10,000 datagrams and a 30 s soak instead of 100,000 and 10 minutes.
    soak_s : float, optional
        The soak's length, s (overrides the default).
    """
    n = 10_000 if quick else 100_000
    soak_len = soak_s if soak_s is not None else (30.0 if quick else 600.0)
    with tempfile.TemporaryDirectory() as tmpdir:
        tmp = Path(tmpdir)
        proc, base = start_sim(tmp)
        crashes: list[str] = []
        try:
            time.sleep(1.0)
            rss_before = rss_mb(proc.pid)
            seconds, guided = flood(base, n)
            time.sleep(1.0)  # what is queued gets read
            rss_after = rss_mb(proc.pid)
            alive = proc.poll() is None
            works = still_a_vehicle(base) if alive else {"upload": False, "mode": False, "arm": False}
            samples = soak(base, proc.pid, soak_len) if proc.poll() is None else []
        finally:
            if proc.poll() is None:
                proc.send_signal(signal.SIGINT)
            try:
                _out, err = proc.communicate(timeout=30)
            except subprocess.TimeoutExpired:
                proc.kill()
                _out, err = proc.communicate()
                crashes.append("did not end within 30 s of SIGINT")
        if proc.returncode not in (0, 130):
            crashes.append(f"exit code {proc.returncode}")
        if "Traceback" in err:
            crashes.append("traceback: " + err.strip().splitlines()[-1])
        logs = sorted((tmp / "logs").glob("*.mcap"))
        stats = link_stats(logs[0]) if logs else {}
        if not logs:
            crashes.append("no log")
        for kind in ("handler_errors", "send_errors"):  # each a bug, logged and survived
            if errors := sum(s.get(kind, 0) for s in stats.values()):
                crashes.append(f"{errors} {kind.replace('_', ' ')}")
    handled = sum(s.get("remote", 0) for s in stats.values())
    warm = samples[1:] if len(samples) > 2 else samples
    growth = (max(warm) / warm[0] - 1.0) if warm else float("nan")
    rows = [
        ("datagrams sent", n),
        ("sent per second", round(n / seconds)),
        ("datagrams handled (read from UDP by the endpoints)", handled),
        ("handled per second of flood", round(handled / seconds)),
        ("bad / dropped", f"{sum(s.get('bad', 0) for s in stats.values())} / {sum(s.get('dropped', 0) for s in stats.values())}"),
        ("crashes", len(crashes)),
        ("parts of the flood begun with the leader GUIDED and armed", f"{guided} of {FLOOD_PARTS}"),
        ("after the flood: upload, mode, arm", ", ".join("ok" if works[k] else "FAILED" for k in ("upload", "mode", "arm"))),
        ("RSS before / after the flood, MB", f"{rss_before:.1f} / {rss_after:.1f}"),
        (f"soak {soak_len:.0f} s: RSS first / max / last, MB", f"{warm[0]:.1f} / {max(warm):.1f} / {warm[-1]:.1f}" if warm else "-"),
        ("soak RSS growth", f"{100 * growth:.1f} %"),
    ]  # fmt: skip
    print_table(("fuzz and soak against lfctl sim --realtime (recording)", "value"), rows)
    if crashes:
        print("crashes: " + "; ".join(crashes))
    print_json(
        "link_fuzz",
        {
            "datagrams_sent": n,
            "datagrams_handled": handled,
            "handled_per_s": handled / seconds,
            "crashes": crashes,
            "parts_guided_and_armed": [guided, FLOOD_PARTS],
            "after_flood": works,
            "rss_mb_before_after": [rss_before, rss_after],
            "soak_s": soak_len,
            "soak_rss_mb": samples,
            "soak_rss_growth": growth,
            "link_stats": stats,
        },
    )
