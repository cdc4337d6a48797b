"""The truth sensor (``--sensing truth``): range and bearing to the target from the world
truth, with noise, delay, a field of view, a range limit and scripted dropouts (occluders).
Deterministic for a seed."""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from lfctl.config import SensingConfig
from lfctl.frames import range_bearing
from lfctl.sim.world import WorldState
from lfctl.vision.track_state import RelativeMeasurement, TrackStatus

__all__ = ["TruthSensor"]


class TruthSensor:
    """One follower's simulated sensor on one target.

    Parameters
    ----------
    cfg : SensingConfig
        Noise, delay, field of view, range limit and dropouts.
    rng : np.random.Generator
        The noise's random stream (one per follower: runs repeat for a seed).
    """

    def __init__(self, cfg: SensingConfig, rng: np.random.Generator) -> None:
        self.cfg = cfg
        self.rng = rng
        self._queue: deque[RelativeMeasurement] = deque()
        self._latest: RelativeMeasurement | None = None

    def _capture(self, t_s: float, world: WorldState, me: int, target: int) -> RelativeMeasurement:
        c = self.cfg
        rng_m, brg = range_bearing(
            world.pos_ned_m[me, 0],
            world.pos_ned_m[me, 1],
            float(world.yaw_rad[me]),
            world.pos_ned_m[target, 0],
            world.pos_ned_m[target, 1],
        )
        hidden = any(a <= t_s < b for a, b in c.dropouts) or abs(brg) > c.fov_rad / 2 or rng_m > c.max_range_m
        noise_r = self.rng.normal(0.0, c.range_noise_m) if c.range_noise_m > 0 else 0.0
        noise_b = self.rng.normal(0.0, c.bearing_noise_rad) if c.bearing_noise_rad > 0 else 0.0
        if hidden:
            return RelativeMeasurement(t_s, TrackStatus.OCCLUDED)
        return RelativeMeasurement(
            t_s, TrackStatus.TRACKING, max(0.0, rng_m + noise_r), math.remainder(brg + noise_b, 2 * math.pi), 1.0
        )

    def measure(self, t_s: float, world: WorldState, me: int, target: int) -> RelativeMeasurement | None:
        """Take a measurement now; return the newest one at least ``delay_s`` old (None
        before the first one). Hidden targets give OCCLUDED measurements.

        Parameters
        ----------
        t_s : float
            Simulation time, s.
        world : WorldState
            The truth now.
        me, target : int
            Indices of this follower and its target in ``world``.
        """
        self._queue.append(self._capture(t_s, world, me, target))
        while self._queue and self._queue[0].t_s <= t_s - self.cfg.delay_s + 1e-9:
            self._latest = self._queue.popleft()
        return self._latest
