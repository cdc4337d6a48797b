"""Rates kept on a clock that ticks unevenly: which calls an event at a given rate happens on."""

from __future__ import annotations

import math

__all__ = ["RateSchedule"]


class RateSchedule:
    """Events at ``rate_hz`` on average, from calls that come every ``tick_s`` or so.

    Calls fall on the caller's own ticks (a 30 Hz camera on a 100 Hz physics step comes 0.03
    or 0.04 s apart; a real control loop jitters), so each call is taken when it is within
    half a tick of the schedule, and the schedule advances by whole periods: no drift, and
    never two events for one period. The first call is always taken.

    Parameters
    ----------
    rate_hz : float
        Events per second, > 0 (at most one per call).
    tick_s : float
        The caller's nominal period, s, > 0.
    """

    def __init__(self, rate_hz: float, tick_s: float) -> None:
        if not (rate_hz > 0 and tick_s > 0):
            raise ValueError(f"rate_hz and tick_s must be > 0, got {rate_hz!r}, {tick_s!r}")
        self.tick_s = tick_s
        self.period_s = max(1.0 / rate_hz, tick_s)
        self._due = -math.inf

    def due(self, t_s: float) -> bool:
        """Whether the call at ``t_s`` is an event (and if so, schedule the next one).

        Parameters
        ----------
        t_s : float
            The call's time, s, not decreasing from call to call.
        """
        if t_s < self._due - self.tick_s / 2:
            return False
        self._due = self._due + self.period_s if t_s - self._due < self.period_s else t_s + self.period_s
        return True
