"""Formation figures of a run, one definition for the run summary (`lfctl sim`, from the
follower's trace) and for `lfctl audit` (from the recorded ``/<follower>/controller`` topic).

Errors count after a settling time (the formation forms from its starting positions first);
the time in each track state, the control effort and the chattering count over the whole run.
Pure: arrays in, figures out.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from lfctl.vision.track_state import TrackStatus

__all__ = [
    "CHATTER_DEADBAND_RADPS",
    "SETTLE_S",
    "FormationMetrics",
    "TrackEpisode",
    "formation_metrics",
    "sign_changes",
    "track_episodes",
    "variation_per_s",
]

#: errors count from this simulation time on, s
SETTLE_S = 5.0
#: a yaw-rate command swinging across +-this counts as one chattering sign change, rad/s
CHATTER_DEADBAND_RADPS = 0.02


@dataclass(frozen=True)
class FormationMetrics:
    """How well one follower held its slot.

    Parameters
    ----------
    name, target : str
        The follower and what it follows.
    range_cmd_m, bearing_cmd_rad : float
        Its slot: range (m) and bearing (rad, clockwise positive).
    range_err_rms_m, range_err_max_m : float or None
        RMS and largest absolute range error after the settling time, m; None when the run
        was shorter than that.
    bearing_err_rms_rad, bearing_err_max_rad : float or None
        The same for the bearing error, rad.
    min_separation_m : float or None
        Closest approach to any other vehicle over the run, m; None without samples.
    time_in_state_s : dict of str to float
        Seconds in each track state (``tracking``, ``occluded``, ``lost``).
    control_effort_rad : float
        The absolute yaw-rate command integrated over the run, rad.
    chattering_per_s : float
        Sign changes of the yaw-rate command (outside ``CHATTER_DEADBAND_RADPS``) per second.
    """

    name: str
    target: str
    range_cmd_m: float
    bearing_cmd_rad: float
    range_err_rms_m: float | None
    range_err_max_m: float | None
    bearing_err_rms_rad: float | None
    bearing_err_max_rad: float | None
    min_separation_m: float | None
    time_in_state_s: dict[str, float]
    control_effort_rad: float
    chattering_per_s: float


@dataclass(frozen=True)
class TrackEpisode:
    """A stretch without tracking."""

    start_s: float  # when it began, s
    duration_s: float  # how long it lasted, s
    recovered: bool  # whether tracking came back before the run ended
    worst: str  # the worst state in it: "occluded" or "lost"


def sign_changes(values: np.ndarray, deadband: float) -> int:
    """Swings from above ``+deadband`` to below ``-deadband`` or back (noise inside is ignored).

    Parameters
    ----------
    values : np.ndarray
        A signal.
    deadband : float
        Half-width of the band around zero that does not count, >= 0.
    """
    outside = np.sign(values[np.abs(values) > deadband])
    return int(np.count_nonzero(outside[1:] != outside[:-1])) if outside.size > 1 else 0


def variation_per_s(values: Sequence[float], step_s: float) -> float:
    """How much a command moves per second: the sum of its absolute step-to-step changes over
    the run's duration (a chattering law's command moves a lot while going nowhere). For a
    speed command in m/s, m/s^2.

    Parameters
    ----------
    values : sequence of float
        The command, sampled every ``step_s``.
    step_s : float
        The sample period, s.
    """
    a = np.asarray(values, float)
    return float(np.sum(np.abs(np.diff(a))) / (a.size * step_s)) if a.size > 1 else 0.0


def _rms(a: np.ndarray) -> float | None:
    return float(np.sqrt(np.mean(a**2))) if a.size else None


def _max_abs(a: np.ndarray) -> float | None:
    return float(np.max(np.abs(a))) if a.size else None


def formation_metrics(
    name: str,
    target: str,
    range_cmd_m: float,
    bearing_cmd_rad: float,
    t_s: Sequence[float],
    range_err_m: Sequence[float],
    bearing_err_rad: Sequence[float],
    separation_m: Sequence[float],
    status: Sequence[str],
    yaw_rate_cmd_radps: Sequence[float],
    step_s: float,
    settle_s: float = SETTLE_S,
) -> FormationMetrics:
    """The figures of one follower from its samples at the guidance rate.

    Parameters
    ----------
    name, target : str
        The follower and what it follows.
    range_cmd_m, bearing_cmd_rad : float
        Its slot (reported with the figures).
    t_s : sequence of float
        Sample times, s.
    range_err_m, bearing_err_rad : sequence of float
        True range error (m) and bearing error (rad, wrapped) at each sample.
    separation_m : sequence of float
        Distance to the nearest other vehicle at each sample, m.
    status : sequence of str
        Track state at each sample (``TrackStatus`` values).
    yaw_rate_cmd_radps : sequence of float
        The yaw-rate command at each sample, rad/s.
    step_s : float
        The sample period (the guidance period), s.
    settle_s : float
        Errors count from this time on, s.
    """
    t = np.asarray(t_s, float)
    keep = t >= settle_s
    r_err = np.asarray(range_err_m, float)[keep]
    b_err = np.asarray(bearing_err_rad, float)[keep]
    yaw_cmd = np.asarray(yaw_rate_cmd_radps, float)
    duration = len(t) * step_s
    states = {s.value: 0 for s in TrackStatus}
    for s in status:
        states[s] += 1
    return FormationMetrics(
        name=name,
        target=target,
        range_cmd_m=range_cmd_m,
        bearing_cmd_rad=bearing_cmd_rad,
        range_err_rms_m=_rms(r_err),
        range_err_max_m=_max_abs(r_err),
        bearing_err_rms_rad=_rms(b_err),
        bearing_err_max_rad=_max_abs(b_err),
        min_separation_m=float(np.min(separation_m)) if len(separation_m) else None,
        time_in_state_s={k: n * step_s for k, n in states.items()},
        control_effort_rad=float(np.sum(np.abs(yaw_cmd)) * step_s),
        chattering_per_s=sign_changes(yaw_cmd, CHATTER_DEADBAND_RADPS) / duration if duration > 0 else 0.0,
    )


def track_episodes(
    t_s: Sequence[float], status: Sequence[str], step_s: float, after_s: float = 0.5
) -> list[TrackEpisode]:
    """The stretches without tracking that begin after ``after_s`` (the start-up is not one).

    Parameters
    ----------
    t_s : sequence of float
        Sample times, s.
    status : sequence of str
        Track state at each sample.
    step_s : float
        The sample period, s.
    after_s : float
        Ignore stretches that begin before this time, s.
    """
    episodes = []
    i, n = 0, len(status)
    while i < n:
        if status[i] != TrackStatus.TRACKING.value and t_s[i] > after_s:
            j = i
            while j < n and status[j] != TrackStatus.TRACKING.value:
                j += 1
            worst = TrackStatus.LOST.value if TrackStatus.LOST.value in status[i:j] else TrackStatus.OCCLUDED.value
            episodes.append(TrackEpisode(float(t_s[i]), (j - i) * step_s, j < n, worst))
            i = j
        else:
            i += 1
    return episodes
