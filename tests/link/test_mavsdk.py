"""MAVSDK-Python 4.x (native, no server) against `lfctl sim --realtime`: the client a user's
own ground software would use must work without changes."""

from __future__ import annotations

import asyncio
import dataclasses
import math
import socket
import threading
from pathlib import Path

import pytest

from lfctl.config import load_config
from lfctl.link.mission import local_mission
from lfctl.sim.runner import run_scenario

mavsdk = pytest.importorskip("mavsdk")
pytestmark = [pytest.mark.integration, pytest.mark.slow, pytest.mark.fmu]
EXAMPLES = Path(__file__).parents[2] / "examples"


def free_port_pair() -> int:
    for _ in range(50):
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as a:
            a.bind(("127.0.0.1", 0))
            base = a.getsockname()[1]
            if base > 65000:
                continue
            try:
                with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as b:
                    b.bind(("127.0.0.1", base + 1))
            except OSError:
                continue
        return base
    raise RuntimeError("no two free consecutive UDP ports")


async def session(port: int, home: tuple[float, float, float]) -> dict:
    from mavsdk.asyncio import ComponentType, Configuration, Mavsdk
    from mavsdk.asyncio.plugins.action.action import ActionAsync
    from mavsdk.asyncio.plugins.mission_raw.mission_raw import MissionRawAsync
    from mavsdk.asyncio.plugins.telemetry.telemetry import TelemetryAsync
    from mavsdk.plugins.mission_raw import MissionItem
    from mavsdk.plugins.telemetry import FlightMode

    sdk = Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))
    out: dict = {}
    try:
        await sdk.add_any_connection(f"udpout://127.0.0.1:{port}")
        system = await sdk.first_autopilot(timeout_s=15.0)
        assert system is not None, "MAVSDK found no autopilot"
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
        out["armed"] = await telemetry.armed()
        home_pos = await telemetry.home()
        out["home"] = (home_pos.latitude_deg, home_pos.longitude_deg)
        await mission.pause_mission()
        await asyncio.sleep(0.5)
        out["mode_after_pause"] = await telemetry.flight_mode()
        await action.disarm()
        await asyncio.sleep(0.5)
        out["armed_after"] = await telemetry.armed()
    finally:
        sdk.destroy()
    return out


def test_mavsdk_uploads_starts_watches_pauses_and_disarms() -> None:
    from mavsdk.plugins.telemetry import FlightMode

    base = free_port_pair()
    cfg = load_config(EXAMPLES / "convoy.toml")
    cfg = dataclasses.replace(
        cfg,
        sim=dataclasses.replace(cfg.sim, sensing="truth", duration_s=40.0),
        link=dataclasses.replace(cfg.link, udp_base_port=base, gcs_udpout=""),
    )
    done = threading.Event()
    errors: list[BaseException] = []

    def run() -> None:
        try:
            run_scenario(
                cfg,
                realtime=True,
                progress=lambda t, w: None if not done.is_set() else (_ for _ in ()).throw(KeyboardInterrupt()),
            )
        except KeyboardInterrupt:
            pass
        except BaseException as exc:
            errors.append(exc)

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    try:
        out = asyncio.run(
            asyncio.wait_for(
                session(base, (cfg.link.home_lat_deg, cfg.link.home_lon_deg, cfg.link.home_alt_m)), timeout=45
            )
        )
    finally:
        done.set()
        thread.join(timeout=10)
    assert not errors, errors
    assert out["downloaded"] == out["uploaded"]
    assert out["mode"] == FlightMode.MISSION and out["armed"]
    assert out["moved_m"] > 0.3
    assert out["home"] == pytest.approx((cfg.link.home_lat_deg, cfg.link.home_lon_deg), abs=1e-6)
    assert out["mode_after_pause"] == FlightMode.HOLD
    assert out["armed_after"] is False
