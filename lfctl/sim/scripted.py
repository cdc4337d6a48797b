"""Open-loop inputs for runs without guidance: the leader drives a scripted profile."""

from __future__ import annotations

import math

from lfctl.config import ScriptConfig

__all__ = ["scripted_command"]


def scripted_command(script: ScriptConfig, t_s: float) -> tuple[float, float]:
    """(speed_mps, yaw_rate_radps) of the leader's script at ``t_s``; the profile repeats.

    Parameters
    ----------
    script : ScriptConfig
        Segments of ``(duration_s, speed_mps, yaw_rate_deg_s)``.
    t_s : float
        Simulation time, s, >= 0.
    """
    period = sum(seg[0] for seg in script.leader)
    t = math.fmod(t_s, period)
    for duration, speed, yaw_rate_deg in script.leader:
        if t < duration:
            return speed, math.radians(yaw_rate_deg)
        t -= duration
    duration, speed, yaw_rate_deg = script.leader[-1]
    return speed, math.radians(yaw_rate_deg)
