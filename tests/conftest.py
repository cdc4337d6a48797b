"""Shared fixtures: the built-in FMUs, built once per session into the normal cache; free
UDP ports on loopback; a video of the leader's banner; a run in a background thread; a
standing rover (a vehicle endpoint on loopback UDP) for `lfctl follow`."""

from __future__ import annotations

import contextlib
import signal
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from support import free_udp_ports as _free_udp_ports

from lfctl.fmu.build import BuiltModel, build_model

#: where the standing rover stands (its local origin): lat deg, lon deg, alt m
ROVER_HOME = (12.96, 77.67, 900.0)


def pytest_configure(config: pytest.Config) -> None:
    """Ctrl-C is taken as an interactive pytest takes it, however pytest was started: a
    process started in the background by a non-interactive shell (`pytest &`, as CI may run
    it) has SIGINT ignored, and the programs the tests start would inherit that (an ignored
    signal stays ignored across exec): an `lfctl follow` a test interrupts would not stop,
    and a test that interrupts its own thread would get no KeyboardInterrupt. Each
    pytest-xdist worker runs this too."""
    if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)


@pytest.fixture(scope="session")
def rover() -> BuiltModel:
    return build_model("SkidSteerRover")


@pytest.fixture(scope="session")
def unicycle() -> BuiltModel:
    return build_model("KinematicUnicycle")


@pytest.fixture
def free_udp_ports() -> Callable[[int], int]:
    """``free_udp_ports(n)``: a base port with ``n`` free consecutive UDP ports after it."""
    return _free_udp_ports


def _truth_convoy(duration_s: float) -> Any:
    import dataclasses

    from lfctl.config import load_config
    from lfctl.data import examples_dir

    cfg = load_config(examples_dir() / "convoy.toml")
    base = _free_udp_ports(2)
    return dataclasses.replace(
        cfg,
        sim=dataclasses.replace(cfg.sim, sensing="truth", duration_s=duration_s),
        link=dataclasses.replace(cfg.link, udp_base_port=base, gcs_udpout=""),
    )


@pytest.fixture
def truth_convoy() -> Callable[[float], Any]:
    """``truth_convoy(duration_s)``: the shipped convoy with truth sensing, its vehicles on
    free loopback ports (``cfg.link.udp_base_port`` on), no ground-station output: what a
    client test runs with ``background_run(cfg, realtime=True)``."""
    return _truth_convoy


@pytest.fixture
def banner_video(tmp_path: Path) -> Callable[[int], Path]:
    """``banner_video(frames)``: an MJPG file of the rendered leader's banner, 640x480, 30 fps."""
    import cv2

    from lfctl.render.sequences import make_sequence

    def write(frames: int) -> Path:
        path = tmp_path / f"leader-{frames}.avi"
        writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 30.0, (640, 480))
        for _t, frame, _truth in make_sequence("clear", 1, frames).frames():
            writer.write(frame)
        writer.release()
        return path

    return write


@contextlib.contextmanager
def _worker(work: Callable[[threading.Event], None]) -> Iterator[None]:
    """``work(stop)`` in a thread while the block runs; ``stop`` is set when it ends."""
    stop = threading.Event()
    thread = threading.Thread(target=work, args=(stop,), daemon=True)
    thread.start()
    try:
        yield
    finally:
        stop.set()
        thread.join(timeout=30)


@contextlib.contextmanager
def _background(cfg: Any, **kwargs: Any) -> Iterator[list[BaseException]]:
    from lfctl.sim.runner import run_scenario

    errors: list[BaseException] = []

    def run(stop: threading.Event) -> None:
        try:
            run_scenario(cfg, stop=stop.is_set, **kwargs)
        except KeyboardInterrupt:  # how a stopped run ends
            pass
        except BaseException as exc:
            errors.append(exc)

    with _worker(run):
        yield errors


@pytest.fixture
def background_run() -> Callable[..., contextlib.AbstractContextManager[list[BaseException]]]:
    """``with background_run(cfg, **run_scenario_args) as errors:``: the run goes on in a
    thread while the block runs, is stopped when it ends, and leaves its exceptions in
    ``errors``."""
    return _background


@contextlib.contextmanager
def _standing_rover(
    signing_key: bytes | None = None,
    on_tick: Callable[[Any], None] | None = None,
    home: tuple[float, float, float] = ROVER_HOME,
) -> Iterator[Any]:
    from lfctl.link.endpoint import VehicleEndpoint
    from lfctl.link.transport import UdpLink

    udp = UdpLink(("127.0.0.1", 0))
    rover = VehicleEndpoint("rover", 1, udp, home, signing_key=signing_key)
    still = {"north_m": 0.0, "east_m": 0.0, "yaw_rad": 0.0, "speed_mps": 0.0, "yaw_rate_radps": 0.0}
    t0 = time.monotonic()

    def run(stop: threading.Event) -> None:
        while not stop.is_set():
            rover.tick(time.monotonic() - t0, still)
            if on_tick is not None:
                on_tick(rover)
            stop.wait(0.005)

    try:
        with _worker(run):
            yield rover
    finally:
        udp.close()


@pytest.fixture
def standing_rover() -> Callable[..., contextlib.AbstractContextManager[Any]]:
    """``with standing_rover(signing_key=None, on_tick=None, home=ROVER_HOME) as rover:``: a
    rover (system 1) standing still at home (its local origin, lat deg, lon deg, alt m; at
    0, 0 its GLOBAL_POSITION_INT says what an ArduPilot rover without a global position
    does), ticking on the wall clock on a loopback UDP port (``rover.link.port``) while the
    block runs; ``on_tick(rover)`` after each tick."""
    return _standing_rover
