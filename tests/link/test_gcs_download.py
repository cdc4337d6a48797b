"""A mission, fence or rally download from a vehicle that sends what no Rover stores (NaN,
a place off the Earth, a fence in a local frame) or items meant for another
ground station: refused with the item and its values named, and nothing saved."""

from __future__ import annotations

import math
import os
import threading
from pathlib import Path

import pytest
from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mav

from lfctl.errors import LinkTimeoutError, MissionProtocolError
from lfctl.link.endpoint import GCS_COMPID
from lfctl.link.gcs import GCS_SYSID, GroundStation, downloaded_problem
from lfctl.link.mission import MissionItem
from lfctl.link.mission_server import FENCE, MISSION, RALLY

pytestmark = pytest.mark.integration

GLOBAL = mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
HOME = MissionItem(0, GLOBAL, mav.MAV_CMD_NAV_WAYPOINT, 0, 0, 0, 0, 130000000, 776000000, 0)


def _vehicle(count: int, item: MissionItem, to: tuple[int, int]) -> tuple[str, threading.Event]:
    """A vehicle on a loopback port that answers a download with ``count`` and every item
    as ``item`` (at its seq), addressed to ``to``; runs until the event is set."""
    v = mavutil.mavlink_connection("udpin:127.0.0.1:0", source_system=1, source_component=1)
    port = v.port.getsockname()[1]
    done = threading.Event()

    def serve() -> None:
        try:
            while not done.is_set():
                m = v.recv_match(type=["MISSION_REQUEST_LIST", "MISSION_REQUEST_INT"], blocking=True, timeout=0.1)
                if m is None:
                    continue
                if m.get_type() == "MISSION_REQUEST_LIST":
                    v.mav.mission_count_send(*to, count, m.mission_type)
                else:
                    it = item
                    v.mav.mission_item_int_send(
                        *to, m.seq, it.frame, it.command, 0, 1, it.param1, it.param2, it.param3, it.param4,
                        it.x, it.y, it.z, m.mission_type,
                    )  # fmt: skip
        finally:
            v.close()

    threading.Thread(target=serve, daemon=True).start()
    return f"udpout:127.0.0.1:{port}", done


@pytest.mark.parametrize(
    ("count", "item", "to", "error", "why"),
    [
        (
            2,
            MissionItem(0, GLOBAL, mav.MAV_CMD_NAV_WAYPOINT, math.nan, math.inf, 0, 0, 2147483647, 0, 0),
            (GCS_SYSID, GCS_COMPID),
            MissionProtocolError,
            r"item 0 \(NAV_WAYPOINT: params nan, inf, 0, 0, at 214.7483647, 0.0000000, 0\) refused by an upload",
        ),
        (2, HOME, (7, 7), LinkTimeoutError, "MISSION_COUNT"),  # all meant for another station
        (2, HOME, (0, 0), None, ""),  # (a broadcast is ours too)
    ],
)
def test_a_download_keeps_only_what_a_rover_would_store(
    count: int, item: MissionItem, to: tuple[int, int], error: type[Exception] | None, why: str
) -> None:
    connect, done = _vehicle(count, item, to)
    gcs = GroundStation(connect, timeout_s=1.0)
    try:
        if error is None:
            assert len(gcs.download()) == count
        else:
            with pytest.raises(error, match=why):
                gcs.download()
    finally:
        done.set()
        gcs.port.close()


def test_what_is_unfit_in_a_fence_or_rally_list_is_named() -> None:
    vertex = MissionItem(0, GLOBAL, mav.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION, 3, 0, 0, 0, 130000000, 776000000, 0)
    fence = [vertex, vertex, vertex]
    assert downloaded_problem(fence, FENCE) is None
    local = MissionItem(0, mav.MAV_FRAME_LOCAL_NED, mav.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION, 5, 0, 0, 0, 1, 2, 0)
    assert downloaded_problem([local], FENCE) == "item 0 (NAV_FENCE_CIRCLE_INCLUSION) is in frame 1, not a global one"
    assert downloaded_problem(fence[:2], FENCE) == "item 1: Incorrect item count"
    rally = MissionItem(0, GLOBAL, mav.MAV_CMD_NAV_RALLY_POINT, 0, 0, 0, 0, 130000000, 776000000, math.inf)
    assert downloaded_problem([rally], RALLY) == "item 0: no place on the Earth (13.0, 77.6, inf)"
    assert downloaded_problem([HOME], MISSION) is None


def test_a_mission_is_saved_as_a_user_expects_and_never_blocks(tmp_path: Path) -> None:
    from lfctl.data import resolve_mission
    from lfctl.errors import ConfigError
    from lfctl.link.mission import load_mission_file, save_mission

    fifo = tmp_path / "m.waypoints"
    os.mkfifo(fifo)
    with pytest.raises(ConfigError, match="a named pipe no one reads"):
        save_mission([HOME], fifo)  # (the write would block for ever)
    with pytest.raises(ConfigError, match="not a regular file"):
        load_mission_file(resolve_mission(str(fifo)))
    save_mission([HOME], os.devnull)  # a device is written as it is
    if os.path.exists("/dev/full"):  # a device that fails the write: named (it was a bare "[Errno 28]")
        with pytest.raises(ConfigError, match="cannot write /dev/full: No space left on device"):
            save_mission([HOME] * 5000, "/dev/full")
    (tmp_path / "real.waypoints").write_text("old\n")
    (tmp_path / "link.waypoints").symlink_to("real.waypoints")
    save_mission([HOME], tmp_path / "link.waypoints")  # through the link, which stays one
    assert (tmp_path / "link.waypoints").is_symlink()
    assert len(load_mission_file(tmp_path / "real.waypoints").mission) == 1
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []  # no temporary left
