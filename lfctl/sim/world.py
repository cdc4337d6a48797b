"""World state: the truth every subsystem reads (pose and velocity of each vehicle)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["VehicleState", "WorldState"]


@dataclass(frozen=True)
class VehicleState:
    """Truth of one vehicle at one instant, SI units, NED frame."""

    name: str  # the vehicle
    t_s: float  # simulation time
    north_m: float  # reference point, local NED
    east_m: float  # reference point, local NED
    yaw_rad: float  # heading from north
    speed_mps: float  # forward speed
    yaw_rate_radps: float  # positive right


@dataclass(frozen=True)
class WorldState:
    """Truth of every vehicle at one instant; arrays indexed like ``names``."""

    t_s: float  # simulation time
    names: tuple[str, ...]  # the vehicles, leader first (as in the scenario)
    pos_ned_m: np.ndarray  # (N, 2): north, east
    yaw_rad: np.ndarray  # (N,)
    speed_mps: np.ndarray  # (N,)
    yaw_rate_radps: np.ndarray  # (N,)

    def vehicle(self, i: int) -> VehicleState:
        """One vehicle's state.

        Parameters
        ----------
        i : int
            Its index in :attr:`names` (0: the leader).
        """
        return VehicleState(
            self.names[i],
            self.t_s,
            float(self.pos_ned_m[i, 0]),
            float(self.pos_ned_m[i, 1]),
            float(self.yaw_rad[i]),
            float(self.speed_mps[i]),
            float(self.yaw_rate_radps[i]),
        )
