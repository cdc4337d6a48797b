"""What a follower's sensor hands to guidance: a relative measurement and a track status.

Shared by every sensor (truth + noise in the simulation, the camera tracker, a real camera),
so guidance never knows which one it is fed by.
"""

from __future__ import annotations

import enum
import math
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

    Raises
    ------
    TypeError
        ``status`` that is not a :class:`TrackStatus`.
    ValueError
        ``t_s``, ``origin_body_m`` or ``seen_back_m`` not a number, named (``range_m`` and
        ``bearing_rad`` may be: a sensor's garbage there is no sighting).
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
        # a NaN origin or offset put the bearing-only fix, the target's filter and every command
        # after it at NaN (while TRACKING); an infinite time made every later measurement stale
        for name, value in (
            ("t_s", self.t_s),
            ("origin_body_m", self.origin_body_m[0]),
            ("origin_body_m", self.origin_body_m[1]),
            ("seen_back_m", self.seen_back_m),
        ):
            if not math.isfinite(value):
                raise ValueError(f"a measurement's {name} must be a number, got {getattr(self, name)!r}")
