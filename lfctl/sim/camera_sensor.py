"""The simulated camera (``--sensing camera``): render the follower's view, then perceive it
exactly as a real rover does (:mod:`lfctl.vision.perception`). The follower learns nothing
else about its target."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from lfctl.config import Config
from lfctl.render.renderer import FrameTruth, Renderer, VehiclePose
from lfctl.sim.world import WorldState
from lfctl.vision.perception import BannerPerception
from lfctl.vision.pose import MarkerPose
from lfctl.vision.track_state import RelativeMeasurement
from lfctl.vision.tracker import TrackState

__all__ = ["CameraSample", "CameraSensor"]


@dataclass(frozen=True)
class CameraSample:
    """One camera tick: what was seen, how it was tracked, the pose and the truth."""

    t_s: float  # simulation time of the frame, s
    frame: np.ndarray | None  # None when it came from a camera worker process (see camera_pool)
    track: TrackState | None  # the tracker's result (None before the target was found)
    pose: MarkerPose | None  # the banner's pose from its markers, when seen
    measurement: RelativeMeasurement | None  # what the follower's stack is fed (None: the camera only renders)
    truth: FrameTruth  # what the frame really shows (the renderer's ground truth)


class CameraSensor:
    """One follower's rendered camera and its perception.

    Parameters
    ----------
    cfg : Config
        The scenario (camera, banner, scene, the follower's slot).
    follower : str
        The follower's name.
    seed : int
        The renderer's seed (textures, noise).
    perceive : bool
        Track and estimate on each frame; False renders only (the frames of a follower
        whose companion, ``lfctl follow``, runs outside the simulator and tracks them itself).
    """

    def __init__(self, cfg: Config, follower: str, seed: int, perceive: bool = True) -> None:
        self.follower = follower
        self.renderer = Renderer(cfg.camera, cfg.banner, cfg.scene, seed)
        slot = cfg.slots().get(follower)
        self.tag_ids = cfg.tag_ids()
        # the target's banner: with ArUco tags, its own id is the one looked for
        self.perception = (
            BannerPerception.from_config(
                cfg.camera,
                cfg.banner_of(slot.target) if slot is not None else cfg.banner,
                (slot.range_m, slot.bearing_rad) if slot is not None else None,
                kind=cfg.camera.tracker,
            )
            if perceive
            else None
        )
        self.render_s = 0.0  # seconds spent rendering, and tracking + pose (the cost split)
        self.vision_s = 0.0

    def capture(
        self,
        t_s: float,
        world: WorldState,
        me: int,
        target: int,
        on_render: Callable[[float, np.ndarray], None] | None = None,
    ) -> CameraSample:
        """Render, track and estimate at ``t_s`` (render only, when the sensor does not
        perceive: no track, pose or measurement); ``on_render(t_s, frame)`` is called between
        rendering and tracking (the recorder starts encoding the frame there).

        Parameters
        ----------
        t_s : float
            Simulation time, s.
        world : WorldState
            The truth to render.
        me, target : int
            Indices of this follower and its target in ``world``.
        on_render : callable, optional
            Sees each frame before it is tracked.
        """
        others, index = [], -1
        for i in range(len(world.names)):
            if i == me:
                continue
            if i == target:
                index = len(others)
            tag = self.tag_ids.get(world.names[i])
            others.append(
                VehiclePose(
                    float(world.pos_ned_m[i, 0]), float(world.pos_ned_m[i, 1]), float(world.yaw_rad[i]), True, tag
                )
            )
        own = VehiclePose(
            float(world.pos_ned_m[me, 0]), float(world.pos_ned_m[me, 1]), float(world.yaw_rad[me]), banner=False
        )
        t0 = time.perf_counter()
        frame, truth = self.renderer.render(t_s, own, others, index, self.follower, float(world.yaw_rate_radps[me]))
        t1 = time.perf_counter()
        self.render_s += t1 - t0
        if on_render is not None:
            on_render(t_s, frame)
            t1 = time.perf_counter()
        if self.perception is None:
            return CameraSample(t_s, frame, None, None, None, truth)
        seen = self.perception.step(t_s, frame)
        self.vision_s += time.perf_counter() - t1
        return CameraSample(t_s, frame, seen.track, seen.pose, seen.measurement, truth)
