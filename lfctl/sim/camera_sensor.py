"""The camera sensor (``--sensing camera``): render the follower's view, track the target's
banner, estimate its pose and hand guidance a relative measurement. The follower learns
nothing else about its target."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from lfctl.config import Config
from lfctl.sim.camera import BANNER_BACK_M, CameraModel, FrameTruth, Renderer, VehiclePose
from lfctl.sim.world import WorldState
from lfctl.vision.pose import MarkerPose, paper_pose, pnp_pose, to_vehicle_frame
from lfctl.vision.track_state import RelativeMeasurement, TrackStatus
from lfctl.vision.tracker import Tracker, TrackerSettings, TrackState


@dataclass(frozen=True)
class CameraSample:
    """One camera tick: what was seen, how it was tracked, the pose and the truth."""

    t_s: float
    frame: np.ndarray | None  # None when it came from a camera worker process (see camera_pool)
    track: TrackState | None
    pose: MarkerPose | None
    measurement: RelativeMeasurement
    truth: FrameTruth


class CameraSensor:
    """One follower's camera, tracker and pose estimator."""

    def __init__(self, cfg: Config, follower: str, seed: int) -> None:
        self.cfg = cfg
        self.follower = follower
        self.renderer = Renderer(cfg.camera, cfg.banner, cfg.scene, seed)
        self.cam = CameraModel.from_config(cfg.camera)
        self.tracker = Tracker(
            TrackerSettings(
                kind="full",
                marker_hue_deg=cfg.banner.marker_hue_deg,
                panel_over_side=cfg.banner.panel_size_m / cfg.banner.side_m,
            )
        )
        self.started = False
        self.expected_box = self._slot_box()
        self.latest: CameraSample | None = None
        self.render_s = 0.0  # seconds spent rendering, and tracking + pose (the cost split)
        self.vision_s = 0.0

    def _slot_box(self) -> tuple[int, int, int, int] | None:
        """Where the target's banner shows when the follower holds its slot (the target
        heading the same way): the tracker starts on the banner nearest it, not on another
        vehicle's banner that happens to be squarer."""
        slot = self.cfg.slots().get(self.follower)
        if slot is None:
            return None
        ban = self.cfg.banner
        body = np.array(
            [
                slot.range_m * math.cos(slot.bearing_rad) + BANNER_BACK_M,
                slot.range_m * math.sin(slot.bearing_rad),
                -ban.centre_height_m,
            ]
        )
        p = self.cam.R_body_from_cam.T @ (body - self.cam.mount_body_m)
        if p[2] <= 0.05:
            return None
        K = self.cam.K
        u, v = K[0, 0] * p[0] / p[2] + K[0, 2], K[1, 1] * p[1] / p[2] + K[1, 2]
        side = K[0, 0] * ban.panel_size_m / p[2]
        return int(round(u - side / 2)), int(round(v - side / 2)), max(1, int(round(side))), max(1, int(round(side)))

    def _window_measurement(self, t_s: float, track: TrackState) -> RelativeMeasurement:
        """Bearing only, from the tracked window's centre column (its size says too little)."""
        assert track.bbox is not None
        x, y, w, h = track.bbox
        K = self.cam.K
        ray_cam = np.array([(x + w / 2.0 - K[0, 2]) / K[0, 0], (y + h / 2.0 - K[1, 2]) / K[1, 1], 1.0])
        ray_body = self.cam.R_body_from_cam @ ray_cam
        return RelativeMeasurement(
            t_s, TrackStatus.TRACKING, math.nan, math.atan2(ray_body[1], ray_body[0]), 0.3 * track.quality
        )

    def capture(
        self,
        t_s: float,
        world: WorldState,
        me: int,
        target: int,
        on_render: Callable[[float, np.ndarray], None] | None = None,
    ) -> CameraSample:
        """Render, track and estimate at ``t_s``; ``on_render(t_s, frame)`` is called between
        rendering and tracking (the recorder starts encoding the frame there)."""
        others, index = [], -1
        for i in range(len(world.names)):
            if i == me:
                continue
            if i == target:
                index = len(others)
            others.append(
                VehiclePose(float(world.pos_ned_m[i, 0]), float(world.pos_ned_m[i, 1]), float(world.yaw_rad[i]))
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
        track: TrackState | None
        if not self.started:
            track = self.tracker.init_from_markers(frame, self.expected_box)
            self.started = track is not None
        else:
            track = self.tracker.update(frame)
        pose = None
        if track is not None and track.markers is not None:
            pose = pnp_pose(track.markers, self.cam.K, self.cam.dist, self.cfg.banner.side_m) or paper_pose(
                track.markers, self.cam.K, self.cfg.banner.side_m
            )
        if pose is not None and track is not None and track.status is TrackStatus.TRACKING:
            rng, brg, _ = to_vehicle_frame(pose, self.cam.mount_body_m, self.cam.R_body_from_cam, -BANNER_BACK_M)
            meas = RelativeMeasurement(t_s, TrackStatus.TRACKING, rng, brg, min(pose.quality, track.quality))
        elif track is not None and track.status is TrackStatus.TRACKING and track.bbox is not None:
            # markers hidden (banner turned edge-on, partly covered) but the histogram tracker
            # holds the window: a bearing-only measurement the formation filter can fuse
            meas = self._window_measurement(t_s, track)
        else:
            status = track.status if track is not None else TrackStatus.LOST
            meas = RelativeMeasurement(t_s, status if status is not TrackStatus.TRACKING else TrackStatus.OCCLUDED)
        self.latest = CameraSample(t_s, frame, track, pose, meas, truth)
        self.vision_s += time.perf_counter() - t1
        return self.latest

    @property
    def measurement(self) -> RelativeMeasurement | None:
        """The newest measurement (None before the first frame)."""
        return self.latest.measurement if self.latest else None
