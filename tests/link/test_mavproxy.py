"""MAVProxy against `lfctl sim --realtime`, as a user types it: a mission, a fence and rally
points loaded from files, GUIDED with `guided LAT LON`, and `mode RTL`.

MAVProxy is installed (without its GUI dependencies, which these commands do not use) into
a virtual environment the test makes; where it cannot be installed the test says so and skips.
"""

from __future__ import annotations

import contextlib
import os
import queue
import re
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mav

from lfctl.frames import ned_to_geodetic
from lfctl.link.endpoint import MODES
from lfctl.sim.driver import speed_max
from lfctl.sim.links import Links

pytestmark = [pytest.mark.integration, pytest.mark.slow, pytest.mark.fmu]


@pytest.fixture(scope="module")
def mavproxy(tmp_path_factory: pytest.TempPathFactory) -> Path:
    venv = tmp_path_factory.mktemp("mavproxy") / "venv"
    made = subprocess.run([sys.executable, "-m", "venv", "--system-site-packages", str(venv)], capture_output=True)
    try:
        pip = subprocess.run(
            # --ignore-installed: a MAVProxy already in the system's site-packages would be
            # "already satisfied" and leave the venv without its script (the test then skipped)
            [
                str(venv / "bin" / "pip"),
                "install",
                "-q",
                "--no-deps",
                "--ignore-installed",
                "MAVProxy==1.8.75",
                "pyserial",
            ],
            capture_output=True,
            text=True,
            timeout=300,
        )
    except subprocess.TimeoutExpired:
        pytest.skip("MAVProxy does not install here: pip took over 300 s (no package index?)")
    exe = venv / "bin" / "mavproxy.py"
    if made.returncode or pip.returncode or not exe.exists():
        pytest.skip(f"MAVProxy does not install here: {pip.stderr.strip()[-300:]}")
    return exe


def start(mavproxy: Path, port: int, cmds: str, cwd: Path) -> subprocess.Popen[str]:
    """MAVProxy on ``udpout`` to ``port``, running ``cmds`` (its --cmd), its output piped."""
    env = {k: v for k, v in os.environ.items() if k != "MAVLINK20"}
    return subprocess.Popen(
        [str(mavproxy), f"--master=udpout:127.0.0.1:{port}", "--target-system=1", "--target-component=1",
         "--non-interactive", f"--cmd={cmds}"],
        cwd=cwd, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env,
    )  # fmt: skip


def place(cfg: object, north_m: float, east_m: float) -> tuple[float, float]:
    """Latitude and longitude of a point ``north_m``, ``east_m`` from the scenario's home."""
    link = cfg.link  # type: ignore[attr-defined]
    lat, lon, _ = ned_to_geodetic(north_m, east_m, 0.0, link.home_lat_deg, link.home_lon_deg, link.home_alt_m)
    return lat, lon


def start_interactive(
    mavproxy: Path, port: int, component: int, first: str, cwd: Path
) -> tuple[subprocess.Popen[str], Any]:
    """MAVProxy on ``udpout`` to ``port`` for ``component``, running ``first`` (its --cmd) and
    then what is written to its stdin, as a user types; with a queue of its output lines."""
    import threading

    env = {k: v for k, v in os.environ.items() if k != "MAVLINK20"}
    proc = subprocess.Popen(
        [str(mavproxy), f"--master=udpout:127.0.0.1:{port}", "--target-system=1", f"--target-component={component}",
         f"--cmd={first}"],
        cwd=cwd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env,
    )  # fmt: skip
    lines: queue.Queue[str] = queue.Queue()
    assert proc.stdout is not None
    threading.Thread(target=lambda: [lines.put(x) for x in proc.stdout], daemon=True).start()  # type: ignore[union-attr]
    return proc, lines


class Said:
    """What an interactive MAVProxy has printed, read as it comes."""

    def __init__(self, lines: Any) -> None:
        self.lines = lines
        self.said: list[str] = []

    def wait_for(self, pattern: str, timeout_s: float = 20.0) -> bool:
        """Whether a line matching ``pattern`` was printed already or comes within ``timeout_s``
        (MAVProxy's order of what it prints varies with the timing)."""
        if any(re.search(pattern, x) for x in self.said):
            return True
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            try:
                self.said.append(self.lines.get(timeout=0.2))
            except queue.Empty:
                continue
            if re.search(pattern, self.said[-1]):
                return True
        return False

    @property
    def out(self) -> str:
        return "".join(self.said)


@contextlib.contextmanager
def interactive_against(
    mavproxy: Path, port: int, component: int, first: str, cwd: Path, step: Callable[[float], None]
) -> Iterator[tuple[subprocess.Popen[str], Said]]:
    """An interactive MAVProxy (:func:`start_interactive`) against a peer that ``step(t)``
    runs in a thread (t: seconds since it started) until MAVProxy has been stopped."""
    import threading

    stop = threading.Event()

    def serve() -> None:
        t0 = time.monotonic()
        while not stop.is_set():
            step(time.monotonic() - t0)

    server = threading.Thread(target=serve, daemon=True)
    server.start()
    proc, lines = start_interactive(mavproxy, port, component, first, cwd)
    try:
        yield proc, Said(lines)
    finally:
        proc.kill()
        proc.wait(timeout=10)
        stop.set()
        server.join(timeout=5)


def wpl(path: Path, rows: list[tuple[int, float, float, float, float]]) -> Path:
    """A QGC WPL 110 file: (command, param1, param2, lat, lon) per row."""
    lines = ["QGC WPL 110"]
    for k, (cmd, p1, p2, lat, lon) in enumerate(rows):
        lines.append(f"{k}\t0\t{mav.MAV_FRAME_GLOBAL}\t{cmd}\t{p1}\t{p2}\t0\t0\t{lat:.7f}\t{lon:.7f}\t0\t1")
    path.write_text("\n".join(lines) + "\n")
    return path


def test_mavproxy_loads_mission_fence_and_rally_then_guided_and_rtl(
    mavproxy: Path, tmp_path: Path, truth_convoy, background_run
) -> None:
    cfg = truth_convoy(120.0)
    base = cfg.link.udp_base_port

    def at(n: float, e: float) -> tuple[float, float]:
        return place(cfg, n, e)

    mission = wpl(
        tmp_path / "mission.txt",
        # as a Rover takes it: a speed, a camera trigger (nothing fitted to it) and RTL at the end
        [(16, 0, 0, *at(0, 0)), (16, 0, 0, *at(3, 0)), (178, 1, 0.4, 0, 0), (16, 0, 0, *at(3, 3)),
         (206, 2, 0, 0, 0), (20, 0, 0, 0, 0)],
    )  # fmt: skip
    square = [at(15, 15), at(15, -15), at(-15, -15), at(-15, 15)]
    fence = wpl(tmp_path / "fence.txt", [(5001, 4, 0, lat, lon) for lat, lon in square])
    rally = wpl(tmp_path / "rally.txt", [(5100, 0, 0, *at(-2, 1))])
    goal = at(-3.0, 2.0)

    links: list[Links] = []
    cmds = "; ".join(
        [
            f"wp load {mission}",
            f"fence load {fence}",
            f"rally load {rally}",
            "mode GUIDED",
            "arm throttle",
            f"guided {goal[0]:.7f} {goal[1]:.7f} 0",
        ]
    )
    with background_run(cfg, realtime=True, on_links=links.append) as errors:
        while not links:
            time.sleep(0.05)
        proc = start(mavproxy, base, cmds, tmp_path)
        ep = links[0].endpoints[0]
        deadline = time.monotonic() + 40

        def loaded() -> bool:
            lists = ep.missions.lists
            return len(lists[0]) == 6 and len(lists[1]) == 4 and len(lists[2]) == 1

        while time.monotonic() < deadline and not (loaded() and ep.guided is not None and ep.guided.kind == "location"):
            time.sleep(0.1)
        guided_target = ep.guided
        proc.send_signal(signal.SIGINT)
        out, _ = proc.communicate(timeout=20)
        second = start(mavproxy, base, "mode RTL", tmp_path)
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline and ep.mode != MODES["RTL"]:
            time.sleep(0.1)
        mode_after = ep.mode
        second.send_signal(signal.SIGINT)
        out2, _ = second.communicate(timeout=20)
    assert not errors, errors
    lists = ep.missions.lists
    assert [it.command for it in lists[0]] == [16, 16, 178, 16, 206, 20], out  # the mission, every item kept
    assert [it.command for it in lists[1]] == [5001] * 4, out  # the fence, apart from the mission
    assert [it.command for it in lists[2]] == [5100], out  # the rally point
    assert guided_target is not None and guided_target.kind == "location", out
    assert abs(guided_target.north_m + 3.0) < 0.05 and abs(guided_target.east_m - 2.0) < 0.05
    assert mode_after == MODES["RTL"], out2
    assert "fence breach" not in out and "ACCEPTED" in out and "Flight plan received" in out


def test_mavproxy_drives_the_leader_in_manual_with_rc_and_the_override_times_out(
    mavproxy: Path, tmp_path: Path, truth_convoy, background_run
) -> None:
    # `rc 3 1700` holds the throttle channel at 1700 us (MAVProxy resends it every second):
    # 100 x (1700 - 1530) / 370 = 45 % (a whole percent, as Rover's) of the full-throttle speed
    # Rover projects from CRUISE_SPEED at CRUISE_THROTTLE 50 %, up to the scenario's max_speed_mps
    cfg = truth_convoy(120.0)
    base = cfg.link.udp_base_port
    links: list[Links] = []
    with background_run(cfg, realtime=True, on_links=links.append) as errors:
        while not links:
            time.sleep(0.05)
        ep = links[0].endpoints[0]
        expected = min(cfg.guidance.max_speed_mps, 0.45 * speed_max(ep.param("CRUISE_SPEED"), 50))
        proc = start(mavproxy, base, "mode MANUAL; arm throttle; rc 3 1700", tmp_path)
        deadline = time.monotonic() + 40
        driven = []
        while time.monotonic() < deadline and len(driven) < 20:
            if ep.mode == MODES["MANUAL"] and ep.armed and abs(ep.state["speed_mps"] - expected) < 0.02:
                driven.append(ep.state["speed_mps"])
            time.sleep(0.1)
        quit_t = ep.t_s  # the vehicle's clock (simulated time), not the wall's
        proc.send_signal(signal.SIGINT)
        out, _ = proc.communicate(timeout=20)
        deadline = time.monotonic() + 15
        while time.monotonic() < deadline and abs(ep.state["speed_mps"]) > 0.01:
            time.sleep(0.1)
        stopped_after = ep.t_s - quit_t
        still_manual = ep.mode == MODES["MANUAL"]
    assert not errors, errors
    assert len(driven) == 20, out  # 2 s at the speed the stick asks for
    # RC_OVERRIDE_TIME (3 s, on the vehicle's clock) after the last override
    assert still_manual and 1.0 < stopped_after < 10.0, out
    # MAVProxy asks for the parameters over MAVLink FTP first, and gets @PARAM/param.pck
    assert re.search(r"Received \d+ parameters \(ftp\)", out) and "FTP: request timed out" not in out, out


def test_mavproxy_fetches_and_sets_the_rover_companions_lfc_parameters(mavproxy: Path, tmp_path: Path) -> None:
    # `lfctl follow`'s companion (component 191) as MAVProxy reaches it on a rover: its own
    # heartbeat, its parameter file over MAVLink FTP, then the sets
    from lfctl.link.companion import COMPANION_COMPID, Companion
    from lfctl.link.port import MavPort

    companion = Companion(MavPort.open("udpin:127.0.0.1:0", 1, COMPANION_COMPID), 1)
    port = companion.port.connection.port.getsockname()[1]

    def step(t: float) -> None:
        companion.poll(t, 0.05)
        companion.heartbeat(t)

    try:
        with interactive_against(mavproxy, port, COMPANION_COMPID, "param fetch", tmp_path, step) as (proc, console):
            assert proc.stdin is not None
            fetched = console.wait_for(r"Received 6 parameters \(ftp\)")  # @PARAM/param.pck
            proc.stdin.write("param set LFC_RANGE 2.5\nparam set LFC_LAW 2\n")
            proc.stdin.flush()
            deadline = time.monotonic() + 5.0
            while companion.param("LFC_LAW") != 2 and time.monotonic() < deadline:
                time.sleep(0.05)
            proc.stdin.write("param show LFC_*\n")
            proc.stdin.flush()
            shown = console.wait_for(r"LFC_RANGE\s+2\.5")
            # its heartbeat: MAVProxy says so when it has it (after the parameters, at times)
            detected = console.wait_for(r"Detected vehicle 1:191", 10.0)
    finally:
        companion.close()
    out = console.out
    assert fetched and detected, out[-2000:]
    assert "timed out" not in out
    assert shown, out[-2000:]  # its PARAM_VALUE answers reached MAVProxy's table
    assert (companion.param("LFC_RANGE"), companion.param("LFC_LAW")) == (2.5, 2)


def test_mavproxy_moves_the_lists_and_parameters_as_files_over_mavlink_ftp(mavproxy: Path, tmp_path: Path) -> None:
    # MAVProxy's `wp ftpload`, `fence ftpload`, `wp ftp` and `ftp list` against a vehicle
    # endpoint over UDP (no simulation needed): the files a Rover serves, in its formats
    from lfctl.link.endpoint import VehicleEndpoint
    from lfctl.link.transport import UdpLink

    home = (12.9602, 77.6690, 900.0)
    udp = UdpLink(("127.0.0.1", 0))
    ep = VehicleEndpoint("leader", 1, udp, home)
    state = {"north_m": 0.0, "east_m": 0.0, "yaw_rad": 0.0, "speed_mps": 0.0, "yaw_rate_radps": 0.0}

    def step(t: float) -> None:
        ep.tick(t, state)
        time.sleep(0.01)

    lat, lon = home[:2]
    mission = wpl(
        tmp_path / "m.txt", [(16, 0, 0, lat, lon), (16, 0, 0, lat + 1e-4, lon), (16, 2, 0, lat + 1e-4, lon + 1e-4)]
    )
    fence = wpl(tmp_path / "f.txt", [(5001, 3, 0, lat + a, lon + b) for a, b in ((1e-3, 0), (0, 1e-3), (-1e-3, -1e-3))])
    bad = wpl(tmp_path / "bad.txt", [(16, 0, 0, lat, lon), (16, 0, 0, 95.0, lon)])  # past the pole
    try:
        with interactive_against(mavproxy, udp.port, 1, f"wp ftpload {mission}", tmp_path, step) as (proc, console):

            def send(line: str) -> None:
                proc.stdin.write(line + "\n")  # type: ignore[union-attr]
                proc.stdin.flush()  # type: ignore[union-attr]

            got_params = console.wait_for(rf"Received {len(ep.params)} parameters \(ftp\)")  # @PARAM/param.pck
            sent = console.wait_for(r"Sent waypoint of length 3")
            send(f"fence ftpload {fence}")
            fenced = console.wait_for(r"Sent fence item of length 3")
            send("wp ftp")
            fetched = console.wait_for(r"Saved 3 waypoints")
            send("ftp list @MISSION")
            listed = console.wait_for(r"fence\.dat\s+124")  # 10 + 3 x 38 bytes
            send(f"wp ftpload {bad}")
            refused = console.wait_for(r"AP: FTP: @MISSION/mission\.dat refused: item 1: MAV_MISSION_INVALID_PARAM5_X")
    finally:
        udp.close()
    out = console.out
    assert got_params and sent and fenced and fetched and listed and refused, out[-3000:]
    assert [(i.x, i.y, i.param1) for i in ep.mission[1:]] == [
        (round((lat + 1e-4) * 1e7), round(lon * 1e7), 0.0),
        (round((lat + 1e-4) * 1e7), round((lon + 1e-4) * 1e7), 2.0),
    ]  # the refused file changed nothing
    assert len(ep.missions.lists[1]) == 3 and len(ep.fence.inclusion_polygons) == 1


def test_mavproxy_edits_an_uploaded_mission_in_place_with_wp_changealt(
    mavproxy: Path, tmp_path: Path, truth_convoy, background_run
) -> None:
    # `wp changealt` (and `wp move`, `wp update`) send MISSION_WRITE_PARTIAL_LIST: only the
    # items changed are uploaded again
    cfg = truth_convoy(120.0)
    rows = [(16, 0, 0, *place(cfg, n, e)) for n, e in ((0, 0), (3, 0), (3, 3))]
    mission = wpl(tmp_path / "mission.txt", rows)  # type: ignore[arg-type]
    links: list[Links] = []
    with background_run(cfg, realtime=True, on_links=links.append) as errors:
        while not links:
            time.sleep(0.05)
        ep = links[0].endpoints[0]
        proc, lines = start_interactive(mavproxy, cfg.link.udp_base_port, 1, f"wp load {mission}", tmp_path)
        assert proc.stdin is not None

        def wait(done: Callable[[], bool], timeout_s: float = 30.0) -> bool:
            deadline = time.monotonic() + timeout_s
            while time.monotonic() < deadline and not done():
                time.sleep(0.1)
            return done()

        try:
            loaded = wait(lambda: len(ep.mission) == 3)
            before = list(ep.mission)
            proc.stdin.write("wp changealt 2 7\n")
            proc.stdin.flush()
            # in force as it comes, as on Rover: MAVProxy then offers item 3, which it does not
            # have (its range ends one past the items it changed), and the update times out
            changed = wait(lambda: ep.mission[2].z == 7.0)
        finally:
            proc.kill()
            proc.wait(timeout=10)
        out = "".join(lines.queue)
    assert not errors, errors
    assert loaded and changed, out[-2000:]
    after = ep.mission
    assert after[2].z == 7.0 and (after[2].x, after[2].y) == (before[2].x, before[2].y), out[-2000:]
    assert [it.z for it in after[:2]] == [it.z for it in before[:2]]  # the rest as they were
