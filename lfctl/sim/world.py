"""World state: the truth every subsystem reads (pose and velocity of each vehicle)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class VehicleState:
    """Truth of one vehicle at ``t_s``, SI units, NED frame."""

    name: str
    t_s: float
    north_m: float
    east_m: float
    yaw_rad: float
    speed_mps: float
    yaw_rate_radps: float


@dataclass(frozen=True)
class WorldState:
    """Truth of every vehicle at one instant; arrays indexed like ``names``."""

    t_s: float
    names: tuple[str, ...]
    pos_ned_m: np.ndarray  # (N, 2): north, east
    yaw_rad: np.ndarray  # (N,)
    speed_mps: np.ndarray  # (N,)
    yaw_rate_radps: np.ndarray  # (N,)

    def vehicle(self, i: int) -> VehicleState:
        """One vehicle's state."""
        return VehicleState(
            self.names[i],
            self.t_s,
            float(self.pos_ned_m[i, 0]),
            float(self.pos_ned_m[i, 1]),
            float(self.yaw_rad[i]),
            float(self.speed_mps[i]),
            float(self.yaw_rate_radps[i]),
        )
