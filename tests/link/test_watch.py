"""`lfctl gcs watch`: a screen that redraws in place on a terminal, JSON lines on a pipe."""

from __future__ import annotations

import dataclasses
import io
import json
import time
from pathlib import Path
from typing import Any

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mav

from lfctl.cli import main
from lfctl.cli.gcs import fleet_rows, render_fleet, watch
from lfctl.config import load_config
from lfctl.link.gcs import FleetTable

EXAMPLES = Path(__file__).parents[2] / "examples"


def message(msg: object, sysid: int, compid: int = 1) -> object:
    """A message as received: packed and parsed by a sender with these ids."""
    sender = mav.MAVLink(None, srcSystem=sysid, srcComponent=compid)
    return mav.MAVLink(None).parse_buffer(msg.pack(sender))[0]


def heartbeat(custom_mode: int, armed: bool) -> object:
    return mav.MAVLink_heartbeat_message(
        mav.MAV_TYPE_GROUND_ROVER,
        mav.MAV_AUTOPILOT_ARDUPILOTMEGA,
        mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | (mav.MAV_MODE_FLAG_SAFETY_ARMED if armed else 0),
        custom_mode,
        mav.MAV_STATE_ACTIVE,
        3,
    )


def test_rows_wait_for_the_autopilot_and_go_stale_after_3_s() -> None:
    table = FleetTable()
    table.add(message(mav.MAVLink_named_value_float_message(0, b"rng_err", 0.2), 2, 191), 0.0)
    assert fleet_rows(table, 0.0) == []  # the companion alone: no row of unknowns
    table.add(message(heartbeat(15, True), 2), 0.5)
    table.add(message(mav.MAVLink_local_position_ned_message(0, 3.25, -1.5, 0, 0.3, 0.0, 0), 2), 0.5)
    table.add(message(mav.MAVLink_named_value_float_message(0, b"brg_err", -4.0), 2, 191), 0.5)
    table.add(message(mav.MAVLink_named_value_float_message(0, b"trk_q", 1.0), 2, 191), 0.5)
    table.add(message(mav.MAVLink_mission_current_message(2, 4), 2), 0.5)
    (row,) = fleet_rows(table, 1.0)
    assert row | {"text": ""} == {
        "sysid": 2, "mode": "GUIDED", "armed": True, "north_m": 3.25, "east_m": -1.5, "speed_mps": None,
        "link_age_s": 0.5, "stale": False, "mission_seq": 2, "mission_total": 4, "range_err_m": 0.2,
        "bearing_err_deg": -4.0, "track": "tracking", "text": "",
    }  # fmt: skip
    line = render_fleet([row])[1]
    assert "GUIDED" in line and "3.25" in line and "2/4" in line and "tracking" in line
    (old,) = fleet_rows(table, 3.6)
    assert old["stale"] and "STALE" in render_fleet([old])[1]


@pytest.mark.parametrize(
    ("total", "state", "shown"),
    [(0, mav.MISSION_STATE_NO_MISSION, 0), (0xFFFF, mav.MISSION_STATE_UNKNOWN, 0), (0, mav.MISSION_STATE_UNKNOWN, None),
     (3, mav.MISSION_STATE_ACTIVE, 3)],
)  # fmt: skip
def test_a_vehicle_with_no_mission_is_told_apart_from_one_that_does_not_say(
    total: int, state: int, shown: object
) -> None:
    # Rover's send_mission_current: home alone is a total of 0 with the state NO_MISSION; the
    # message's definition says UINT16_MAX; a total of 0 with no state says nothing
    table = FleetTable()
    table.add(message(heartbeat(4, False), 2), 0.0)
    table.add(message(mav.MAVLink_mission_current_message(0, total, state), 2), 0.0)
    (row,) = fleet_rows(table, 0.5)
    assert row["mission_total"] == shown


def test_a_lost_followers_no_value_is_null_in_the_json_not_nan() -> None:
    """The companion reports an unknown error as NaN (MAVLink's "no value"); JSON has no NaN."""
    table = FleetTable()
    table.add(message(heartbeat(15, True), 2), 0.0)
    table.add(message(mav.MAVLink_local_position_ned_message(0, float("nan"), -1.5, 0, 0.3, 0.0, 0), 2), 0.0)
    for name in (b"rng_err", b"brg_err", b"trk_q"):
        table.add(message(mav.MAVLink_named_value_float_message(0, name, float("nan")), 2, 191), 0.0)
    (row,) = fleet_rows(table, 0.5)
    assert (row["range_err_m"], row["bearing_err_deg"], row["track"], row["north_m"]) == (None, None, "lost", None)
    json.loads(json.dumps(row, allow_nan=False))  # strict JSON
    assert "nan" not in render_fleet([row])[1].lower()


class FakeStation:
    """Gives the scripted messages, one per call, then nothing."""

    timeout_s = 5.0

    def __init__(self, msgs: list[object]) -> None:
        self.msgs = msgs

    def heartbeat(self) -> None:
        pass

    def next_message(self, timeout_s: float) -> object | None:
        return self.msgs.pop(0) if self.msgs else None


class Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_on_a_terminal_every_update_redraws_from_the_top() -> None:
    out = Terminal()
    watch(FakeStation([message(heartbeat(10, True), 1)]), 3, out)
    text = out.getvalue()
    # home, draw, clear below: no scrolling (3 updates, and the screens while the vehicles settle)
    assert text.count("\x1b[H") == text.count("\x1b[J") >= 3
    assert "AUTO" in text and text.endswith("\x1b[?25h")  # the cursor is given back


class LateStation(FakeStation):
    """Gives its messages only once ``after_s`` has passed: a vehicle heard a moment after
    watch starts, as on a link where it sends its heartbeat once a second."""

    def __init__(self, msgs: list[object], after_s: float) -> None:
        super().__init__(msgs)
        self.from_s = time.monotonic() + after_s

    def next_message(self, timeout_s: float) -> object | None:
        return super().next_message(timeout_s) if time.monotonic() >= self.from_s else None


def test_a_one_update_snapshot_on_a_terminal_shows_the_vehicle_not_the_wait_for_it() -> None:
    # `lfctl gcs watch --count 1` on a terminal drew its one screen before any heartbeat had
    # come ("0 vehicles", "waiting for a vehicle's heartbeat") and ended there
    out = Terminal()
    watch(LateStation([message(heartbeat(10, True), 1)], 0.3), 1, out)
    last = out.getvalue().rsplit("\x1b[H", 1)[1]
    assert "  1 vehicle  (Ctrl-C" in last and "AUTO" in last and "waiting" not in last  # (not "1 vehicles")
    assert "waiting for a vehicle's heartbeat" in out.getvalue()  # said while it waited


def test_on_a_pipe_each_update_is_one_json_object() -> None:
    out = io.StringIO()
    watch(FakeStation([message(heartbeat(4, False), 1)]), 2, out)
    lines = out.getvalue().splitlines()
    assert len(lines) == 2 and "\x1b" not in out.getvalue()
    assert json.loads(lines[-1])["vehicles"][0]["mode"] == "HOLD"


def _watched_convoy(free_udp_ports) -> tuple[Any, int, int]:
    """The convoy with truth sensing for 30 s, its vehicles sending to a free ground station
    port: (the scenario, that port, the leader's port; the follower's is the next)."""
    gcs_port = free_udp_ports(3)  # the ground station's, then the two vehicles'
    base = gcs_port + 1
    cfg = load_config(EXAMPLES / "convoy.toml")
    cfg = dataclasses.replace(
        cfg,
        sim=dataclasses.replace(cfg.sim, sensing="truth", duration_s=30.0),
        link=dataclasses.replace(cfg.link, udp_base_port=base, gcs_udpout=f"127.0.0.1:{gcs_port}"),
    )
    return cfg, gcs_port, base


@pytest.mark.integration
@pytest.mark.fmu
def test_watch_a_realtime_run_as_json(capsys: pytest.CaptureFixture[str], background_run, free_udp_ports) -> None:
    cfg, gcs_port, _base = _watched_convoy(free_udp_ports)
    with background_run(cfg, realtime=True) as errors:
        rc = main(["gcs", "--connect", f"udpin:127.0.0.1:{gcs_port}", "--timeout", "10", "watch", "--count", "6"])
    assert not errors, errors
    assert rc == 0
    updates = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert len(updates) == 6
    last = {v["sysid"]: v for v in updates[-1]["vehicles"]}
    assert set(last) == {1, 2}
    assert last[1]["mode"] == "HOLD" and last[1]["mission_total"] == 4  # stored, waiting for a ground station
    assert last[2]["mode"] == "GUIDED" and last[2]["armed"] and last[2]["north_m"] == pytest.approx(-1.5, abs=0.1)


def test_a_peers_escape_sequence_is_shown_not_obeyed() -> None:
    # a STATUSTEXT that would clear the screen and retitle the window
    table = FleetTable()
    table.add(message(heartbeat(15, True), 2), 0.0)
    table.add(message(mav.MAVLink_statustext_message(6, b"\x1b[2J\x1b]0;pwned\x07 ok"), 2), 0.0)
    (row,) = fleet_rows(table, 0.5)
    assert row["text"] == "\\x1b[2J\\x1b]0;pwned\\x07 ok"
    assert "\x1b" not in render_fleet([row])[1] and "\x07" not in render_fleet([row])[1]


@pytest.mark.integration
@pytest.mark.fmu
def test_a_one_update_snapshot_lists_the_vehicles_and_needs_no_target(
    capsys: pytest.CaptureFixture[str], background_run, free_udp_ports
) -> None:
    # `watch --count 1 | jq`: its one update was the moment before anything was heard (no
    # vehicles), and watch waited for system 1's heartbeat, so a follower's own link (system 2)
    # needed --target 2
    cfg, gcs_port, base = _watched_convoy(free_udp_ports)
    with background_run(cfg, realtime=True) as errors:
        rc = main(["gcs", "--connect", f"udpin:127.0.0.1:{gcs_port}", "--timeout", "10", "watch", "--count", "1"])
        follower = main(
            ["gcs", "--connect", f"udpout:127.0.0.1:{base + 1}", "--timeout", "10", "watch", "--count", "1"]
        )
    assert not errors, errors
    assert (rc, follower) == (0, 0)
    first, second = (json.loads(line) for line in capsys.readouterr().out.splitlines())
    assert {v["sysid"] for v in first["vehicles"]} == {1, 2}  # both, in the first and only update
    assert {v["sysid"] for v in second["vehicles"]} == {2}  # the follower's link: no --target needed


def test_a_snapshot_with_no_vehicle_waits_the_timeout_then_says_none(free_udp_ports) -> None:
    from lfctl.link.gcs import GroundStation

    port = free_udp_ports(1)
    out = io.StringIO()
    gcs = GroundStation(f"udpin:127.0.0.1:{port}", timeout_s=1.5)
    try:
        watch(gcs, 1, out)  # nobody on the link: one update after the timeout, with none
    finally:
        gcs.close()
    assert json.loads(out.getvalue())["vehicles"] == []


def test_a_refused_tcp_connection_leaves_stdout_to_the_json(capsys: pytest.CaptureFixture[str]) -> None:
    # pymavlink printed "[Errno 111] Connection refused sleeping" on stdout, in front of the
    # JSON a pipe reads; lfctl's one line goes to stderr
    import socket

    from lfctl.cli import main

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]  # (closed again: nothing listens there)
    assert main(["gcs", "--connect", f"tcp:127.0.0.1:{port}", "--timeout", "2", "watch", "--count", "1"]) == 1
    out, err = capsys.readouterr()
    assert out == ""
    assert "Connection refused" in err and err.count("\n") == 1, err
