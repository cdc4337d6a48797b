"""What a follower's sensor hands to guidance: a relative measurement and a track status.

Shared by every sensor (truth + noise in the simulation, the camera tracker, a real camera),
so guidance never knows which one it is fed by.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

__all__ = ["RelativeMeasurement", "TrackStatus"]


class TrackStatus(enum.Enum):
    """State of a follower's track on its target."""

    TRACKING = "tracking"  # a fresh measurement this cycle
    OCCLUDED = "occluded"  # the target is hidden (or the sensor doubts it): coast
    LOST = "lost"  # gone for longer than the coast allows: stop (and, if set, look round)


@dataclass(frozen=True)
class RelativeMeasurement:
    """The target as a follower's sensor sees it, in the follower's body frame.

    Parameters
    ----------
    t_s : float
        Time the measurement describes (image time, not arrival time), s.
    status : TrackStatus
        TRACKING when ``range_m`` and ``bearing_rad`` are valid.
    range_m : float or None
        Horizontal distance to the target, m; None for a bearing-only measurement.
    bearing_rad : float or None
        Bearing of the target from the follower's heading, clockwise positive, rad; None
        when the target was not seen.
    quality : float
        0..1 confidence (1 for truth sensing).
    origin_body_m : tuple of float
        For a bearing-only measurement: where its ray starts, forward and right of the
        follower's reference point, m (a camera's mount). A measurement with a range is
        between the two reference points already, and leaves it at (0, 0).
    seen_back_m : float
        For a bearing-only measurement: how far behind the target's reference point, along
        the target's heading, the point the ray was taken to lies, m (a banner on its back).
    """

    t_s: float
    status: TrackStatus
    range_m: float | None = None
    bearing_rad: float | None = None
    quality: float = 0.0
    origin_body_m: tuple[float, float] = (0.0, 0.0)
    seen_back_m: float = 0.0

    def __post_init__(self) -> None:
        if not isinstance(self.status, TrackStatus):  # a string here read as "not seen"
            raise TypeError(f"status must be a TrackStatus (TrackStatus.TRACKING, ...), got {self.status!r}")
