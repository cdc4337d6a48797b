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
    "PathHistory",
    "TrackEpisode",
    "distance_to_path",
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
    time_in_state_s : dict of str to float or None
        Seconds in each track state (``tracking``, ``occluded``, ``lost``); None where the
        state was not known (a follower whose companion ran outside the simulator).
    control_effort_rad : float
        The absolute yaw-rate command integrated over the run, rad.
    chattering_per_s : float
        Sign changes of the yaw-rate command (outside ``CHATTER_DEADBAND_RADPS``) per second.
    path_err_rms_m, path_err_max_m : float or None
        RMS and largest absolute path error after the settling time, m: the follower's distance
        from the path its target drove, less its slot's sideways offset (``range_cmd_m`` x
        ``|sin(bearing_cmd_rad)|``); how far it cuts a corner. None without samples (a log
        written before the figure existed).
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
    time_in_state_s: dict[str, float | None]
    control_effort_rad: float
    chattering_per_s: float
    path_err_rms_m: float | None = None
    path_err_max_m: float | None = None


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
    status: Sequence[str | None],
    yaw_rate_cmd_radps: Sequence[float],
    step_s: float,
    settle_s: float = SETTLE_S,
    path_err_m: Sequence[float] | None = None,
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
    status : sequence of str or None
        Track state at each sample (``TrackStatus`` values); None where it is not known
        (then no time in any state is given).
    yaw_rate_cmd_radps : sequence of float
        The yaw-rate command at each sample, rad/s.
    step_s : float
        The sample period (the guidance period), s.
    settle_s : float
        Errors count from this time on, s.
    path_err_m : sequence of float, optional
        The path error at each sample (see :class:`PathHistory`), m.
    """
    t = np.asarray(t_s, float)
    keep = t >= settle_s
    p_err = np.asarray(path_err_m, float)[keep] if path_err_m is not None and len(path_err_m) == len(t) else None
    r_err = np.asarray(range_err_m, float)[keep]
    b_err = np.asarray(bearing_err_rad, float)[keep]
    yaw_cmd = np.asarray(yaw_rate_cmd_radps, float)
    duration = len(t) * step_s
    states = {s.value: 0 for s in TrackStatus}
    for s in status:
        if s is not None:
            states[s] += 1
    known = all(s is not None for s in status)
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
        time_in_state_s={k: n * step_s if known else None for k, n in states.items()},
        control_effort_rad=float(np.sum(np.abs(yaw_cmd)) * step_s),
        chattering_per_s=sign_changes(yaw_cmd, CHATTER_DEADBAND_RADPS) / duration if duration > 0 else 0.0,
        path_err_rms_m=_rms(p_err) if p_err is not None else None,
        path_err_max_m=_max_abs(p_err) if p_err is not None else None,
    )


def distance_to_path(path: np.ndarray, north_m: float, east_m: float) -> float:
    """Distance from a point to a polyline, m.

    Parameters
    ----------
    path : np.ndarray
        (K, 2) north, east of the polyline's points, K >= 1, m.
    north_m, east_m : float
        The point, m.
    """
    p = np.array([north_m, east_m])
    if len(path) == 1:
        return float(np.hypot(*(path[0] - p)))
    a, ab = path[:-1], np.diff(path, axis=0)
    length2 = np.einsum("ij,ij->i", ab, ab)
    u = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.maximum(length2, 1e-12), 0.0, 1.0)
    d = a + ab * u[:, None] - p
    return float(np.sqrt(np.min(np.einsum("ij,ij->i", d, d))))


class PathHistory:
    """The path a vehicle drove, for the path error of whoever follows it: a point each
    ``spacing_m`` it moves, the last ``keep`` of them, and before its first position a
    straight ``lead_in_m`` back along its first heading (the road it came on: a follower
    starting behind it is on its path). The error is unsigned (a follower its offset away on
    the wrong side scores 0) and taken from the kept stretch only (``keep`` x ``spacing_m``:
    the last 20 m by default; a follower further behind on the path than that is measured
    from its oldest kept point).

    Parameters
    ----------
    north_m, east_m, yaw_rad : float
        Where the vehicle starts, and its heading.
    spacing_m, keep, lead_in_m : float, int, float
        Point spacing (m), points kept, and the lead-in's length (m).
    """

    def __init__(
        self,
        north_m: float,
        east_m: float,
        yaw_rad: float,
        spacing_m: float = 0.05,
        keep: int = 400,
        lead_in_m: float = 10.0,
    ) -> None:
        self.spacing_m = spacing_m
        self.keep = keep
        self._buf = np.empty((2 * keep, 2))  # a point per row; the newest at row _n - 1
        self._buf[0] = north_m - lead_in_m * np.cos(yaw_rad), east_m - lead_in_m * np.sin(yaw_rad)
        self._buf[1] = north_m, east_m
        self._n = 2

    @property
    def points(self) -> np.ndarray:
        """The kept points, oldest first, (K, 2) north and east, m (a view)."""
        return self._buf[max(0, self._n - self.keep) : self._n]

    def add(self, north_m: float, east_m: float) -> None:
        """The vehicle is here now (a point is kept once it is ``spacing_m`` from the last).

        Parameters
        ----------
        north_m, east_m : float
            Its position, m.
        """
        ln, le = self._buf[self._n - 1]
        if (north_m - ln) ** 2 + (east_m - le) ** 2 < self.spacing_m**2:
            return
        if self._n == len(self._buf):  # full: the newest keep points to the front
            self._buf[: self.keep] = self._buf[self._n - self.keep : self._n]
            self._n = self.keep
        self._buf[self._n] = north_m, east_m
        self._n += 1

    def error(self, north_m: float, east_m: float, offset_m: float = 0.0) -> float:
        """A follower's path error: its distance from the kept path, less ``offset_m`` (its
        slot's sideways offset), m.

        Parameters
        ----------
        north_m, east_m : float
            The follower's position, m.
        offset_m : float
            Its slot's sideways offset from the path, m.
        """
        return distance_to_path(self.points, north_m, east_m) - offset_m


def track_episodes(
    t_s: Sequence[float], status: Sequence[str | None], step_s: float, after_s: float = 0.5
) -> list[TrackEpisode]:
    """The stretches without tracking that begin after ``after_s`` (the start-up is not one,
    however long: a target never found gives none, its time is in the time in each state);
    none where a state is not known (None).

    Parameters
    ----------
    t_s : sequence of float
        Sample times, s.
    status : sequence of str or None
        Track state at each sample.
    step_s : float
        The sample period, s.
    after_s : float
        Ignore stretches that begin before this time, s.
    """
    episodes: list[TrackEpisode] = []
    if any(s is None for s in status):
        return episodes
    i, n = 0, len(status)
    while i < n:
        if status[i] != TrackStatus.TRACKING.value:
            j = i
            while j < n and status[j] != TrackStatus.TRACKING.value:
                j += 1
            if t_s[i] > after_s:  # (a stretch from before then is the start-up, all of it)
                worst = TrackStatus.LOST.value if TrackStatus.LOST.value in status[i:j] else TrackStatus.OCCLUDED.value
                episodes.append(TrackEpisode(float(t_s[i]), (j - i) * step_s, j < n, worst))
            i = j
        else:
            i += 1
    return episodes
