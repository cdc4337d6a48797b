"""Sliding-mode range and bearing/heading control (paper eq. 17-26, corrected forms).

Frames: x north, y east, heading psi from north, clockwise positive; bearings of a target
from a vehicle's heading, clockwise positive (target to the right is positive). ``sgn`` is
replaced by a saturation with a boundary layer ``Phi`` (no chattering).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from lfctl.frames import wrap_pi

__all__ = [
    "BearingGains",
    "RangeGains",
    "SlidingModeController",
    "clamp",
    "range_rate_mps",
    "sat",
    "smc_speed_mps",
    "smc_yaw_rate_radps",
]


#: the bearing law's error rate is a difference over at least this long, s: over a step
#: shorter (a paced loop's hiccup) a 0.1 rad change would read as a rate of thousands
MIN_RATE_DT_S = 1e-3


def sat(x: float) -> float:
    """Unit saturation: ``x`` clipped to [-1, 1] (the boundary-layer ``sgn``).

    Parameters
    ----------
    x : float
        The sliding variable over its boundary-layer width.
    """
    return 1.0 if x > 1.0 else (-1.0 if x < -1.0 else x)


def clamp(x: float, lo: float, hi: float) -> float:
    """``x`` clipped to [lo, hi].

    Parameters
    ----------
    x : float
        The value.
    lo, hi : float
        The limits, lo <= hi.
    """
    return lo if x < lo else (hi if x > hi else x)


@dataclass(frozen=True)
class RangeGains:
    """Gains and limits of the sliding-mode range (speed) law.

    Parameters
    ----------
    eta_mps : float
        Reaching rate of the range error outside the boundary layer, m/s (> 0).
    phi_m : float
        Boundary-layer half-width on the range error, m (> 0).
    min_speed_mps, max_speed_mps : float
        Speed command limits, m/s (min <= max).
    min_cos_bearing : float
        Smallest |cos(bearing)| used in the denominator: guards the broadside singularity.

    Every value is finite (a ValueError names one that is not).
    """

    eta_mps: float = 0.25
    phi_m: float = 0.25
    min_speed_mps: float = 0.0
    max_speed_mps: float = 0.5
    min_cos_bearing: float = 0.2

    def __post_init__(self) -> None:
        # (an infinite gain or limit is no number either: inf * sat(0) made the command NaN)
        for name in ("eta_mps", "phi_m", "min_cos_bearing"):
            if not 0 < getattr(self, name) < math.inf:
                raise ValueError(f"{name} must be > 0 and finite, got {getattr(self, name)!r}")
        for name in ("min_speed_mps", "max_speed_mps"):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f"{name} must be a finite number, got {getattr(self, name)!r}")
        if not self.min_speed_mps <= self.max_speed_mps:
            raise ValueError(f"min_speed_mps {self.min_speed_mps!r} must be <= max_speed_mps {self.max_speed_mps!r}")


@dataclass(frozen=True)
class BearingGains:
    """Gains and limits of the sliding-mode bearing / heading (yaw-rate) law.

    Parameters
    ----------
    eta_radps : float
        Yaw-rate magnitude outside the boundary layer, rad/s (> 0).
    lam_s : float
        Weight of the error rate in the sliding variable, s (>= 0).
    phi_rad : float
        Boundary-layer half-width on the sliding variable, rad (> 0).
    max_yaw_rate_radps : float
        Yaw-rate command limit, rad/s.

    Every value is finite (a ValueError names one that is not).
    """

    eta_radps: float = 1.2
    lam_s: float = 0.1
    phi_rad: float = 0.25
    max_yaw_rate_radps: float = 1.5

    def __post_init__(self) -> None:
        for name in ("eta_radps", "phi_rad", "max_yaw_rate_radps"):
            if not 0 < getattr(self, name) < math.inf:
                raise ValueError(f"{name} must be > 0 and finite, got {getattr(self, name)!r}")
        if not 0 <= self.lam_s < math.inf:
            raise ValueError(f"lam_s must be >= 0 and finite, got {self.lam_s!r}")


def range_rate_mps(
    dx_m: float, dy_m: float, leader_vx_mps: float, leader_vy_mps: float, speed_mps: float, heading_rad: float
) -> float:
    """Eq. 20 (corrected): rate of change of the range ``S`` to the leader.

    ``dS/dt = ((x0 - x)(x0' - U cos psi) + (y0 - y)(y0' - U sin psi)) / S`` with ``dx = x0 - x``,
    ``dy = y0 - y`` (leader minus follower, north and east), the leader's velocity
    ``(x0', y0')`` and the follower moving at ``U`` along ``psi``. The printed eq. 20-22 use
    ``sin`` for the north component and ``z`` for ``S``. 0 when the two coincide.

    Parameters
    ----------
    dx_m, dy_m : float
        Leader minus follower position, north and east, m.
    leader_vx_mps, leader_vy_mps : float
        Leader velocity, north and east, m/s.
    speed_mps : float
        Follower speed ``U``, m/s.
    heading_rad : float
        Follower heading ``psi``, rad.
    """
    s = math.hypot(dx_m, dy_m)
    if s == 0.0:
        return 0.0
    return (
        dx_m * (leader_vx_mps - speed_mps * math.cos(heading_rad))
        + dy_m * (leader_vy_mps - speed_mps * math.sin(heading_rad))
    ) / s


def smc_speed_mps(
    dx_m: float,
    dy_m: float,
    leader_vx_mps: float,
    leader_vy_mps: float,
    heading_rad: float,
    range_cmd_m: float,
    gains: RangeGains,
) -> float:
    """Eq. 17-23 (corrected): follower speed that drives the range error to zero.

    With ``s = S - S_com`` (eq. 17) and the reaching law ``ds/dt = -eta sat(s / Phi)``
    (eq. 18, ``sgn`` smoothed), solving eq. 20 for ``U`` gives::

        U = (eta S sat(s/Phi) + (x0 - x) x0' + (y0 - y) y0') / ((x0 - x) cos psi + (y0 - y) sin psi)

    The printed eq. 23 has the signs and sin/cos mixed. The denominator is ``S cos(beta)``
    (beta: bearing of the leader); it vanishes when the follower is broadside to the leader,
    so ``|cos beta|`` is floored at ``gains.min_cos_bearing`` (keeping its sign) and ``U`` is
    saturated to the speed limits.

    Parameters
    ----------
    dx_m, dy_m : float
        Leader minus follower position, north and east, m.
    leader_vx_mps, leader_vy_mps : float
        Leader velocity, north and east, m/s (estimated, not telemetry).
    heading_rad : float
        Follower heading, rad.
    range_cmd_m : float
        Commanded range ``S_com``, m.
    gains : RangeGains
        Reaching rate, boundary layer, speed limits and the ``|cos beta|`` floor.
    """
    s_range = math.hypot(dx_m, dy_m)
    if s_range == 0.0:
        return clamp(0.0, gains.min_speed_mps, gains.max_speed_mps)
    sigma = s_range - range_cmd_m
    numerator = gains.eta_mps * s_range * sat(sigma / gains.phi_m) + dx_m * leader_vx_mps + dy_m * leader_vy_mps
    cos_b = (dx_m * math.cos(heading_rad) + dy_m * math.sin(heading_rad)) / s_range
    if abs(cos_b) < gains.min_cos_bearing:
        cos_b = math.copysign(gains.min_cos_bearing, cos_b if cos_b != 0.0 else 1.0)
    return clamp(numerator / (s_range * cos_b), gains.min_speed_mps, gains.max_speed_mps)


def smc_yaw_rate_radps(
    err_rad: float, err_rate_radps: float, gains: BearingGains, feedforward_radps: float = 0.0
) -> float:
    """Eq. 24-26 (corrected): yaw-rate command from a bearing or heading error.

    ``s = e + lambda de/dt`` (eq. 25) and ``r = r_eq + eta sat(s / Phi)`` (eq. 26, ``sgn``
    smoothed), clipped to the yaw-rate limit. ``r_eq`` (``feedforward_radps``) is the
    equivalent control the paper leaves out: the turn rate of the world line of sight to the
    target (bearing control) or of the commanded heading (heading control); with it the error
    obeys the reaching law exactly instead of only outside a bias.

    Sign: with ``e = beta - beta_com`` and bearings clockwise positive, turning right
    (``r > 0``) moves the target left in view (``d beta/dt = -r + ...``), so ``r = +eta sat``
    makes ``ds/dt = -eta sat(s/Phi)``. The printed ``-eta sgn`` holds for counter-clockwise
    bearings. For heading control use ``e = psi_cmd - psi`` (positive: turn right).

    Parameters
    ----------
    err_rad : float
        The error ``e``: bearing minus commanded bearing, or commanded heading minus heading,
        rad.
    err_rate_radps : float
        Its rate of change ``de/dt``, rad/s.
    gains : BearingGains
        ``eta``, ``lambda``, ``Phi`` and the yaw-rate limit.
    feedforward_radps : float
        The equivalent control ``r_eq``, rad/s (0: none).
    """
    sigma = err_rad + gains.lam_s * err_rate_radps
    r = feedforward_radps + gains.eta_radps * sat(sigma / gains.phi_rad)
    return clamp(r, -gains.max_yaw_rate_radps, gains.max_yaw_rate_radps)


class SlidingModeController:
    """Keeps the previous error between steps and calls :func:`smc_yaw_rate_radps`.

    Parameters
    ----------
    gains : BearingGains
        The sliding-mode gains and yaw-rate limit.
    """

    def __init__(self, gains: BearingGains) -> None:
        self.gains = gains
        self._prev_err: float | None = None

    def reset(self) -> None:
        """Forget the previous error (after a gap in measurements)."""
        self._prev_err = None

    def step(self, err_rad: float, dt_s: float, feedforward_radps: float = 0.0) -> float:
        """Yaw-rate command for this error, rad/s; the error rate is a backward difference
        (0 on the first step after a reset).

        Parameters
        ----------
        err_rad : float
            The error now (see :func:`smc_yaw_rate_radps`), rad.
        dt_s : float
            Time since the previous step, s (under :data:`MIN_RATE_DT_S`, 0 among them: the
            rate is taken as 0, not a difference over no time).
        feedforward_radps : float
            The equivalent control, rad/s.

        Raises
        ------
        ValueError
            An error or equivalent control that is not a number, named: it would be the
            command, and (kept as the previous error) the next step's too.
        """
        for name, value in (("error", err_rad), ("feed-forward", feedforward_radps)):
            if not math.isfinite(value):
                raise ValueError(f"the bearing law's {name} is {value!r}: a yaw-rate command needs a number")
        rate = 0.0 if self._prev_err is None or not dt_s >= MIN_RATE_DT_S else wrap_pi(err_rad - self._prev_err) / dt_s
        self._prev_err = err_rad
        return smc_yaw_rate_radps(err_rad, rate, self.gains, feedforward_radps)
