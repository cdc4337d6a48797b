"""MAVSDK-Python 4.x (native, no server) against `lfctl sim --realtime`: the client a user's
own ground software would use must work without changes."""

from __future__ import annotations

import asyncio
import contextlib
import math
import time
from collections.abc import AsyncIterator, Awaitable, Callable, Iterator
from typing import Any

import pytest

from lfctl.link.mission import local_mission

mavsdk = pytest.importorskip("mavsdk")
pytestmark = [pytest.mark.integration, pytest.mark.slow, pytest.mark.fmu]


async def settled(read: Callable[[], Awaitable[Any]], wanted: Any, timeout_s: float = 5.0) -> Any:
    """What ``read()`` gives once it gives ``wanted``, or after ``timeout_s`` (telemetry
    arrives at its stream rate, and the simulation shares this machine's cores)."""
    got = await read()
    for _ in range(int(timeout_s / 0.1)):
        if got == wanted:
            break
        await asyncio.sleep(0.1)
        got = await read()
    return got


@contextlib.asynccontextmanager
async def autopilot(port: int) -> AsyncIterator[Any]:
    """MAVSDK as a ground station on ``udpout`` to ``port``, and the autopilot it finds there."""
    from mavsdk.asyncio import ComponentType, Configuration, Mavsdk

    sdk = Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))
    try:
        await sdk.add_any_connection(f"udpout://127.0.0.1:{port}")
        system = await sdk.first_autopilot(timeout_s=15.0)
        assert system is not None, "MAVSDK found no autopilot"
        yield system
    finally:
        sdk.destroy()


async def session(port: int, home: tuple[float, float, float]) -> dict:
    from mavsdk.asyncio.plugins.action.action import ActionAsync
    from mavsdk.asyncio.plugins.mission_raw.mission_raw import MissionRawAsync
    from mavsdk.asyncio.plugins.telemetry.telemetry import TelemetryAsync
    from mavsdk.plugins.mission_raw import MissionItem
    from mavsdk.plugins.telemetry import FlightMode

    out: dict = {}
    async with autopilot(port) as system:
        mission = MissionRawAsync(system)
        telemetry = TelemetryAsync(system)
        action = ActionAsync(system)
        ours = local_mission([(3.0, 0.0), (3.0, 3.0), (0.0, 3.0)], home)
        items = [
            MissionItem(
                seq=i.seq,
                frame=i.frame,
                command=i.command,
                current=int(i.seq == 0),
                autocontinue=1,
                param1=i.param1,
                param2=0.0,
                param3=0.0,
                param4=0.0,
                x=i.x,
                y=i.y,
                z=i.z,
                mission_type=0,
            )
            for i in ours
        ]
        await mission.upload_mission(items)
        back = await mission.download_mission()
        out["downloaded"] = [(it.seq, it.command, it.x, it.y) for it in back]
        out["uploaded"] = [(i.seq, i.command, i.x, i.y) for i in ours]
        await mission.set_current_mission_item(1)
        await action.arm()
        await mission.start_mission()
        start = await telemetry.position()
        for _ in range(25):  # MAVSDK's position is NaN until its first GLOBAL_POSITION_INT (slow on a loaded machine)
            if math.isfinite(start.latitude_deg):
                break
            await asyncio.sleep(0.2)
            start = await telemetry.position()
        for _ in range(40):  # up to 8 s for the mode to show and the rover to move
            await asyncio.sleep(0.2)
            out["mode"] = await telemetry.flight_mode()
            pos = await telemetry.position()
            moved = math.hypot(
                (pos.latitude_deg - start.latitude_deg) * 111_319.5,
                (pos.longitude_deg - start.longitude_deg) * 108_500.0,
            )
            if out["mode"] == FlightMode.MISSION and moved > 0.3:
                break
        out["moved_m"] = moved
        # VFR_HUD, which MAVSDK reads as "fixed-wing metrics" and QGroundControl as its
        # ground speed and throttle: asked for faster, as a client does
        await telemetry.set_rate_fixedwing_metrics(5.0)
        hud = await telemetry.fixedwing_metrics()
        out["hud"] = (hud.groundspeed_m_s, hud.throttle_percentage, hud.heading_deg, hud.absolute_altitude_m)
        vel = await telemetry.velocity_ned()
        out["speed"] = math.hypot(vel.north_m_s, vel.east_m_s)
        out["armed"] = await telemetry.armed()
        home_pos = await telemetry.home()
        out["home"] = (home_pos.latitude_deg, home_pos.longitude_deg)
        await mission.pause_mission()
        out["mode_after_pause"] = await settled(telemetry.flight_mode, FlightMode.HOLD)
        await action.disarm()
        out["armed_after"] = await settled(telemetry.armed, False)
    return out


def test_mavsdk_uploads_starts_watches_pauses_and_disarms(truth_convoy, background_run) -> None:
    from mavsdk.plugins.telemetry import FlightMode

    cfg = truth_convoy(40.0)
    base = cfg.link.udp_base_port
    with background_run(cfg, realtime=True) as errors:
        out = asyncio.run(
            asyncio.wait_for(
                session(base, (cfg.link.home_lat_deg, cfg.link.home_lon_deg, cfg.link.home_alt_m)), timeout=120
            )
        )
    assert not errors, errors
    assert out["downloaded"] == out["uploaded"]
    assert out["mode"] == FlightMode.MISSION and out["armed"]
    assert out["moved_m"] > 0.3
    groundspeed, throttle, heading, alt = out["hud"]
    assert groundspeed > 0.1 and groundspeed == pytest.approx(out["speed"], abs=0.1)
    # MAVSDK gives VFR_HUD's percent / 100; at the mission's speed (the run's CRUISE_SPEED) it is
    # CRUISE_THROTTLE, 50 %
    assert throttle == pytest.approx(0.5, abs=0.1) and 0 <= heading < 360
    assert alt == pytest.approx(cfg.link.home_alt_m, abs=0.5)
    assert out["home"] == pytest.approx((cfg.link.home_lat_deg, cfg.link.home_lon_deg), abs=1e-6)
    assert out["mode_after_pause"] == FlightMode.HOLD
    assert out["armed_after"] is False


async def plan_ending_in_return(port: int, home: tuple[float, float, float], plan: str) -> dict:
    """A QGroundControl plan ending in Return, imported by MAVSDK, uploaded and flown until
    MAVSDK says the mission is finished."""
    from mavsdk.asyncio.plugins.action.action import ActionAsync
    from mavsdk.asyncio.plugins.mission_raw.mission_raw import MissionRawAsync
    from mavsdk.asyncio.plugins.telemetry.telemetry import TelemetryAsync

    out: dict = {}
    async with autopilot(port) as system:
        mission, telemetry, action = MissionRawAsync(system), TelemetryAsync(system), ActionAsync(system)
        imported = await mission.import_qgroundcontrol_mission_from_string(plan)
        items = list(imported.mission_items)
        out["commands"] = [it.command for it in items]
        await mission.upload_mission(items)
        await action.arm()
        await mission.start_mission()
        out["finished"] = False
        for _ in range(300):  # up to 60 s: 2 m out, a wait, and back home at 0.4 m/s
            await asyncio.sleep(0.2)
            if await mission.is_mission_finished():
                out["finished"] = True
                break
        pos = await telemetry.position()
        out["from_home_m"] = math.hypot(
            (pos.latitude_deg - home[0]) * 111_319.5,
            (pos.longitude_deg - home[1]) * 111_319.5 * math.cos(math.radians(home[0])),
        )
    return out


def test_mavsdk_flies_a_qgroundcontrol_plan_ending_in_return_to_its_end(truth_convoy, background_run, tmp_path) -> None:
    # the plan as QGroundControl writes it (lfctl's own .plan writer): a waypoint 2 m north, a
    # 1 s delay there, then Return; a Rover took the whole plan where lfctl used to refuse it
    from pymavlink.dialects.v20 import ardupilotmega as mav

    from lfctl.link.mission import MissionItem, save_mission

    cfg = truth_convoy(80.0)
    home = (cfg.link.home_lat_deg, cfg.link.home_lon_deg, cfg.link.home_alt_m)
    items = local_mission([(2.0, 0.0)], home)
    items += [
        MissionItem(2, mav.MAV_FRAME_MISSION, mav.MAV_CMD_NAV_DELAY, 1.0, -1.0, -1.0, -1.0),
        MissionItem(3, mav.MAV_FRAME_MISSION, mav.MAV_CMD_NAV_RETURN_TO_LAUNCH),
    ]
    save_mission(items, tmp_path / "return.plan")
    with background_run(cfg, realtime=True) as errors:
        out = asyncio.run(
            asyncio.wait_for(
                plan_ending_in_return(cfg.link.udp_base_port, home, (tmp_path / "return.plan").read_text()),
                timeout=120,
            )
        )
    assert not errors, errors
    assert out["commands"][-3:] == [16, 93, 20], out
    assert out["finished"], out  # MAVSDK's own test: the last item reached
    assert out["from_home_m"] < 0.6, out  # back where it armed


async def fence_rally_goto_rtl(port: int, home: tuple[float, float, float]) -> dict:
    from mavsdk.asyncio.plugins.action.action import ActionAsync
    from mavsdk.asyncio.plugins.mission_raw.mission_raw import MissionRawAsync
    from mavsdk.asyncio.plugins.param.param import ParamAsync
    from mavsdk.asyncio.plugins.telemetry.telemetry import TelemetryAsync
    from mavsdk.plugins.mission_raw import MissionItem
    from mavsdk.plugins.telemetry import FlightMode
    from pymavlink.dialects.v20 import ardupilotmega as mav

    from lfctl.frames import ned_to_geodetic

    def item(seq: int, command: int, n: float, e: float, p1: float, mission_type: int) -> MissionItem:
        lat, lon, _ = ned_to_geodetic(n, e, 0.0, *home)
        return MissionItem(
            seq=seq, frame=mav.MAV_FRAME_GLOBAL_INT, command=command, current=0, autocontinue=1, param1=p1, param2=0.0,
            param3=0.0, param4=0.0, x=int(round(lat * 1e7)), y=int(round(lon * 1e7)), z=0.0, mission_type=mission_type,
        )  # fmt: skip

    out: dict = {}
    async with autopilot(port) as system:
        mission, telemetry, action = MissionRawAsync(system), TelemetryAsync(system), ActionAsync(system)
        params = ParamAsync(system)
        # ArduPilot's AP_Int8 parameters are INT8 on the wire: get_param_int refused a REAL32
        out["fence_enable"] = await params.get_param_int("FENCE_ENABLE")
        await params.set_param_int("FENCE_ACTION", 2)
        out["fence_action"] = await params.get_param_int("FENCE_ACTION")
        out["wp_speed"] = await params.get_param_float("WP_SPEED")
        square = [(20, 20), (20, -20), (-20, -20), (-20, 20)]
        fence = [item(k, 5001, n, e, 4, 1) for k, (n, e) in enumerate(square)]
        await mission.upload_geofence(fence)
        rally = [item(0, 5100, 2.0, 2.0, 0, 2)]
        await mission.upload_rally_points(rally)
        out["fence"] = [(it.command, it.x, it.y) for it in await mission.download_geofence()]
        out["fence_sent"] = [(it.command, it.x, it.y) for it in fence]
        out["rally"] = [(it.command, it.x, it.y) for it in await mission.download_rallypoints()]
        out["mission"] = await mission.download_mission()  # untouched by the fence and rally uploads
        for _ in range(25):  # health needs a SYS_STATUS and a HOME_POSITION (streamed at 0.5 Hz)
            out["health_all_ok"] = await telemetry.health_all_ok()
            if out["health_all_ok"]:
                break
            await asyncio.sleep(0.2)
        await action.arm()
        lat, lon, _ = ned_to_geodetic(-4.0, 3.0, 0.0, *home)
        await action.goto_location(lat, lon, home[2], 0.0)
        for _ in range(100):  # the leader drives to (-4, 3)
            await asyncio.sleep(0.2)
            pos = await telemetry.position()
            out["goto_err_m"] = math.hypot((pos.latitude_deg - lat) * 111_319.5, (pos.longitude_deg - lon) * 108_500.0)
            if out["goto_err_m"] < 0.6:
                break
        out["mode_goto"] = await telemetry.flight_mode()
        await action.return_to_launch()
        out["mode_rtl"] = await settled(telemetry.flight_mode, FlightMode.RETURN_TO_LAUNCH)
        # MAVSDK's arm_force sends param1 0 with 21196: on Rover, and here, a forced disarm
        await action.arm_force()
        out["after_arm_force"] = await settled(telemetry.armed, False)
    return out


def test_mavsdk_fence_rally_goto_rtl_and_health(truth_convoy, background_run) -> None:
    from mavsdk.plugins.telemetry import FlightMode

    cfg = truth_convoy(60.0)
    base = cfg.link.udp_base_port
    with background_run(cfg, realtime=True) as errors:
        home = (cfg.link.home_lat_deg, cfg.link.home_lon_deg, cfg.link.home_alt_m)
        out = asyncio.run(asyncio.wait_for(fence_rally_goto_rtl(base, home), timeout=120))
    assert not errors, errors
    assert out["fence"] == out["fence_sent"] and len(out["rally"]) == 1 and out["rally"][0][0] == 5100
    assert (out["fence_enable"], out["fence_action"]) == (0, 2) and out["wp_speed"] > 0
    assert len(out["mission"]) == 5  # the stored convoy mission: home + 4 waypoints
    assert out["health_all_ok"] is True
    assert out["goto_err_m"] < 0.6, out  # goto_location drove the rover there
    assert out["mode_rtl"] == FlightMode.RETURN_TO_LAUNCH
    assert out["after_arm_force"] is False


async def manual_drive(port: int, endpoint: Any, max_speed_mps: float) -> dict:
    """MAVSDK's ManualControl (MANUAL_CONTROL from system 245) driving the leader in MANUAL."""
    import json

    from mavsdk.asyncio.plugins.action.action import ActionAsync
    from mavsdk.asyncio.plugins.manual_control.manual_control import ManualControlAsync
    from mavsdk.asyncio.plugins.mavlink_direct.mavlink_direct import MavlinkDirectAsync
    from mavsdk.asyncio.plugins.param.param import ParamAsync
    from mavsdk.asyncio.plugins.telemetry.telemetry import TelemetryAsync
    from mavsdk.plugins.mavlink_direct import MavlinkMessage

    from lfctl.sim.driver import speed_max

    out: dict = {}

    async def sticks(z: float, seconds: float) -> None:  # MAVSDK's z 0..1 is MANUAL_CONTROL's 0..1000
        for _ in range(int(seconds * 10)):
            await manual.set_manual_control_input(0.0, 0.0, z, 0.0)
            await asyncio.sleep(0.1)

    async with autopilot(port) as system:
        manual, params, action = ManualControlAsync(system), ParamAsync(system), ActionAsync(system)
        telemetry, direct = TelemetryAsync(system), MavlinkDirectAsync(system)
        # rates a script sets: the battery's is accepted (a Rover without a battery monitor),
        # the time and the attitude quaternion come
        await telemetry.set_rate_battery(1.0)
        await telemetry.set_rate_unix_epoch_time(2.0)
        await telemetry.set_rate_attitude_quaternion(5.0)
        for _ in range(50):
            out["epoch_us"] = await telemetry.unix_epoch_time()
            q = await telemetry.attitude_quaternion()
            out["q"] = (q.w, q.x, q.y, q.z)
            if out["epoch_us"] and any(out["q"]) and all(map(math.isfinite, out["q"])):  # not MAVSDK's NaN "unknown"
                break
            await asyncio.sleep(0.1)
        # MAVSDK has no call for Rover's MANUAL: the mode as a command, the way its users send one
        fields = {"target_system": 1, "target_component": 1, "command": 176, "confirmation": 0, "param1": 1.0,
                  "param2": 0.0, "param3": 0.0, "param4": 0.0, "param5": 0.0, "param6": 0.0, "param7": 0.0}  # fmt: skip
        await direct.send_message(MavlinkMessage("COMMAND_LONG", 245, 190, 1, 1, json.dumps(fields)))
        await action.arm()
        await sticks(0.5, 2.0)  # not SYSID_MYGCS (255): ignored, as Rover does
        out["speed_not_mine"] = endpoint.state["speed_mps"]
        out["texts"] = [t for _, t in endpoint.statustexts if "ignored" in t]
        await params.set_param_int("SYSID_MYGCS", 245)
        # z 500 -> 1700 us: 45 % of the full-throttle speed Rover projects from CRUISE_SPEED at 50 %
        out["expected"] = min(max_speed_mps, 0.45 * speed_max(endpoint.param("CRUISE_SPEED"), 50))
        for _ in range(10):  # up to 10 s for the sticks to bring it to that speed
            await sticks(0.5, 1.0)
            out["speed"] = endpoint.state["speed_mps"]
            if abs(out["speed"] - out["expected"]) < 0.02:
                break
        out["mode"] = await telemetry.flight_mode()
    return out


@contextlib.contextmanager
def realtime_endpoint(background_run, cfg) -> Iterator[tuple[Any, list]]:
    """A ``--realtime`` run of ``cfg`` in the background: its first vehicle's endpoint, once
    the links are up, and the run's error list."""
    links: list[Any] = []
    with background_run(cfg, realtime=True, on_links=links.append) as errors:
        while not links:
            asyncio.run(asyncio.sleep(0.05))
        yield links[0].endpoints[0], errors


def test_mavsdk_manual_control_drives_manual_once_sysid_mygcs_is_its_own(truth_convoy, background_run) -> None:
    from mavsdk.plugins.telemetry import FlightMode

    cfg = truth_convoy(60.0)
    with realtime_endpoint(background_run, cfg) as (ep, errors):
        out = asyncio.run(
            asyncio.wait_for(manual_drive(cfg.link.udp_base_port, ep, cfg.guidance.max_speed_mps), timeout=120)
        )
    assert not errors, errors
    assert out["texts"] == ["Manual control from 245 ignored: SYSID_MYGCS 255"]
    assert abs(out["speed_not_mine"]) < 0.02
    assert out["mode"] == FlightMode.MANUAL
    assert out["speed"] == pytest.approx(out["expected"], abs=0.02)
    assert out["epoch_us"] / 1e6 == pytest.approx(time.time(), abs=120)  # realtime: the run's start + its time
    w, x, y, z = out["q"]
    assert x == y == 0.0 and w * w + z * z == pytest.approx(1.0, abs=1e-5)  # level, turned about down


async def plugins_session(port: int, endpoint: Any, home: tuple[float, float, float]) -> dict:
    """MAVSDK's Geofence, Mission (not MissionRaw), Offboard and Info plugins, as a script uses them."""
    from mavsdk.asyncio.plugins.action.action import ActionAsync
    from mavsdk.asyncio.plugins.geofence.geofence import GeofenceAsync
    from mavsdk.asyncio.plugins.info.info import InfoAsync
    from mavsdk.asyncio.plugins.mission.mission import MissionAsync
    from mavsdk.asyncio.plugins.offboard.offboard import OffboardAsync
    from mavsdk.asyncio.plugins.telemetry.telemetry import TelemetryAsync
    from mavsdk.plugins.geofence import Circle, FenceType, GeofenceData, Point, Polygon
    from mavsdk.plugins.mission import MissionItem, MissionPlan
    from mavsdk.plugins.offboard import VelocityNedYaw
    from mavsdk.plugins.telemetry import FlightMode

    from lfctl.frames import ned_to_geodetic

    def place(n: float, e: float) -> tuple[float, float]:
        lat, lon, _ = ned_to_geodetic(n, e, 0.0, *home)
        return lat, lon

    def waypoint(n: float, e: float) -> MissionItem:
        return MissionItem(*place(n, e), relative_altitude_m=0.0, is_fly_through=True)

    out: dict = {}
    async with autopilot(port) as system:
        fence, mission, offboard = GeofenceAsync(system), MissionAsync(system), OffboardAsync(system)
        action, telemetry, info = ActionAsync(system), TelemetryAsync(system), InfoAsync(system)
        version = await info.get_version()
        out["version"] = (version.flight_sw_major, version.flight_sw_minor, version.flight_sw_patch)
        # the Geofence plugin: polygons and circles, inclusion and exclusion, as FENCE items
        square = Polygon(
            [Point(*place(n, e)) for n, e in ((20, 20), (20, -20), (-20, -20), (-20, 20))], FenceType.INCLUSION
        )
        hole = Polygon([Point(*place(n, e)) for n, e in ((3, 3), (3, 5), (5, 5), (5, 3))], FenceType.EXCLUSION)
        circles = [
            Circle(Point(*place(0, 0)), 30.0, FenceType.INCLUSION),
            Circle(Point(*place(-5, -5)), 1.0, FenceType.EXCLUSION),
        ]
        await fence.upload_geofence(GeofenceData([square, hole], circles))
        back = await fence.download_geofence()
        out["fence"] = (
            [(len(p.points), p.fence_type) for p in back.polygons],
            [(c.radius, c.fence_type) for c in back.circles],
        )
        await fence.clear_geofence()
        cleared = await fence.download_geofence()
        out["fence_cleared"] = (len(cleared.polygons), len(cleared.circles))
        # the Mission plugin sends no home item: on a Rover, as here, its first item is the home
        # slot and is never flown, so the plan starts with a placeholder
        await mission.upload_mission(MissionPlan([waypoint(0.0, 0.0), waypoint(1.0, 0.0), waypoint(1.0, 1.0)]))
        await action.arm()
        await mission.start_mission()
        for _ in range(100):  # on its way to the last item (item 2)
            await asyncio.sleep(0.2)
            if endpoint.mission_current == 2:
                break
        await mission.pause_mission()  # HOLD
        out["paused"] = await settled(telemetry.flight_mode, FlightMode.HOLD)
        await mission.start_mission()  # AUTO and MISSION_START: resumed, as Rover's AUTO resumes
        out["resumed_at"] = endpoint.mission_current
        out["finished"] = False
        for _ in range(150):  # up to 30 s for 2 m at WP_SPEED and a turn
            await asyncio.sleep(0.2)
            if await mission.is_mission_finished():
                out["finished"] = True
                break
        progress = await mission.mission_progress()
        out["progress"] = (progress.current, progress.total)
        out["at_end_m"] = math.hypot(endpoint.state["north_m"] - 1.0, endpoint.state["east_m"] - 1.0)
        # Offboard: MAVSDK sets GUIDED and streams SET_POSITION_TARGET_LOCAL_NED, here a
        # velocity with a heading (due east), which a Rover drives as a heading and a speed
        await offboard.set_velocity_ned(VelocityNedYaw(0.0, 0.2, 0.0, 90.0))
        await offboard.start()
        out["offboard_mode"] = await settled(telemetry.flight_mode, FlightMode.OFFBOARD)
        for _ in range(50):  # up to 10 s to turn and drive east
            await asyncio.sleep(0.2)
            # waited for as the test asserts it (a loaded machine's run may still be speeding up)
            if (
                abs(math.degrees(endpoint.state["yaw_rad"]) - 90.0) < 3.0
                and abs(endpoint.state["speed_mps"] - 0.2) < 0.03
            ):
                break
        out["offboard"] = (math.degrees(endpoint.state["yaw_rad"]), endpoint.state["speed_mps"])
        await offboard.stop()  # MAVSDK's HOLD
        out["after_stop"] = await settled(telemetry.flight_mode, FlightMode.HOLD)
        await mission.clear_mission()
        out["mission_cleared"] = len((await mission.download_mission()).mission_items)
        await action.disarm()
    return out


def test_mavsdk_geofence_mission_offboard_and_info_plugins(truth_convoy, background_run) -> None:
    from mavsdk.plugins.geofence import FenceType
    from mavsdk.plugins.telemetry import FlightMode

    cfg = truth_convoy(60.0)
    with realtime_endpoint(background_run, cfg) as (ep, errors):
        home = (cfg.link.home_lat_deg, cfg.link.home_lon_deg, cfg.link.home_alt_m)
        out = asyncio.run(asyncio.wait_for(plugins_session(cfg.link.udp_base_port, ep, home), timeout=120))
    assert not errors, errors
    assert out["version"] == (4, 6, 0)  # AUTOPILOT_VERSION's Rover release
    incl, excl = FenceType.INCLUSION, FenceType.EXCLUSION
    assert out["fence"] == ([(4, incl), (4, excl)], [(30.0, incl), (1.0, excl)])
    assert out["fence_cleared"] == (0, 0)
    assert out["paused"] == FlightMode.HOLD and out["resumed_at"] == 2, out
    assert out["finished"], out  # its MISSION_ITEM_REACHED of the last item
    assert out["progress"] == (3, 3) and out["at_end_m"] < 0.5, out
    assert out["offboard_mode"] == FlightMode.OFFBOARD  # MAVSDK's name for Rover's GUIDED
    heading, speed = out["offboard"]
    assert heading == pytest.approx(90.0, abs=3.0) and speed == pytest.approx(0.2, abs=0.03), out
    assert out["after_stop"] == FlightMode.HOLD
    assert out["mission_cleared"] == 0
