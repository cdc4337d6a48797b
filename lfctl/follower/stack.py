"""One follower's stack, the same in `lfctl sim` and `lfctl follow`:

    measurement (perception: camera or truth sensor) + odometry
      -> target estimator (Kalman filter) -> formation law (sliding mode, or the P baseline)
      -> companion: GUIDED setpoint every step, formation status at the status rate,
         STATUSTEXT when the target is lost or found again

Only where the measurement and the odometry come from, and what the companion's port is
connected to, differ between the simulation and a rover (docs/architecture.md).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

from lfctl.config import CameraConfig, Config
from lfctl.frames import wrap_pi
from lfctl.guidance.formation import CONTROLLERS, FormationController, FormationOutput, FormationSettings, Odometry
from lfctl.guidance.smc import BearingGains, RangeGains
from lfctl.schedule import RateSchedule
from lfctl.vision.camera_model import CameraModel
from lfctl.vision.track_state import RelativeMeasurement, TrackStatus

__all__ = ["CompanionPort", "Follower", "FollowerEvent", "formation_param_values", "formation_settings"]


class CompanionPort(Protocol):
    """What the stack says to its vehicle and ground station (see :class:`lfctl.link.companion.Companion`)."""

    def setpoint(self, t_s: float, speed_mps: float, yaw_rate_radps: float) -> None:
        """A GUIDED setpoint.

        Parameters
        ----------
        t_s : float
            Now, s.
        speed_mps : float
            Forward speed, m/s.
        yaw_rate_radps : float
            Yaw rate, rad/s, positive right.
        """

    def report(
        self, t_s: float, range_err_m: float | None, bearing_err_deg: float | None, track_quality: float
    ) -> None:
        """The formation status.

        Parameters
        ----------
        t_s : float
            Now, s.
        range_err_m : float or None
            Estimated range minus commanded range, m; None without an estimate.
        bearing_err_deg : float or None
            Estimated minus commanded bearing, degrees (the ground station's unit); None
            without an estimate.
        track_quality : float
            1 while tracking, else 0.
        """

    def statustext(self, text: str) -> None:
        """A line of text for the ground station.

        Parameters
        ----------
        text : str
            The line (a STATUSTEXT carries 50 characters).
        """


@dataclass(frozen=True)
class FollowerEvent:
    """The target lost or found again."""

    t_s: float  # when, s
    kind: str  # "lost" or "reacquired"
    text: str  # the STATUSTEXT sent for it


def view_half_fov_rad(cfg: Config, camera: CameraConfig | None) -> float:
    """How far off the heading the follower's sensor sees, rad: half the camera's horizontal
    field of view (to the nearer edge of the picture), or half the truth sensor's ``fov``.

    Parameters
    ----------
    cfg : Config
        The scenario (``[sensing]``).
    camera : CameraConfig or None
        The follower's camera; None: the truth sensor.
    """
    if camera is None:
        return min(math.pi, cfg.sensing.fov_rad / 2)
    K = CameraModel.from_config(camera).K
    fx, cx = float(K[0, 0]), float(K[0, 2])
    return math.atan2(min(cx, camera.width_px - cx), fx)


def formation_settings(
    cfg: Config,
    range_cmd_m: float,
    bearing_cmd_rad: float,
    controller: str,
    camera: CameraConfig | None = None,
) -> FormationSettings:
    """The formation controller settings a scenario asks for.

    Parameters
    ----------
    cfg : Config
        The scenario (``[guidance]`` gains, ``[sensing]`` noise).
    range_cmd_m, bearing_cmd_rad : float
        The slot: range (m) and bearing (rad, clockwise positive) to the target.
    controller : "smc", "p" or "trail"
        The control law.
    camera : CameraConfig, optional
        The follower's camera, when a camera finds its target (its field of view bounds the
        trail law's heading); None: the truth sensor (``[sensing] fov_deg``).
    """
    g = cfg.guidance
    return FormationSettings(
        range_cmd_m=range_cmd_m,
        bearing_cmd_rad=bearing_cmd_rad,
        controller=controller,  # type: ignore[arg-type]
        range=RangeGains(
            eta_mps=g.range_eta_mps,
            phi_m=g.range_phi_m,
            min_speed_mps=-g.reverse_speed_mps,
            max_speed_mps=g.max_speed_mps,
            min_cos_bearing=g.min_cos_bearing,
        ),
        bearing=BearingGains(
            eta_radps=g.bearing_eta_radps,
            lam_s=g.bearing_lambda_s,
            phi_rad=g.bearing_phi_rad,
            max_yaw_rate_radps=g.max_yaw_rate_radps,
        ),
        p_gain_per_s=g.p_gain,
        trail_lookahead_m=g.trail_lookahead_m,
        view_half_fov_rad=view_half_fov_rad(cfg, camera),
        # a point for the truth sensor
        banner_half_m=cfg.banner.panel_size_m / 2 if camera is not None else 0.0,
        coast_s=g.coast_s,
        slowdown_s=g.slowdown_s,
        search_yaw_rate_radps=g.search_yaw_rate_radps,
        meas_sigma_m=max(0.02, cfg.sensing.range_noise_m * 2),
    )


def formation_param_values(settings: FormationSettings) -> dict[str, float]:
    """The ``LFC_*`` parameters that give ``settings``' slot, coast, search rate and law, in
    the parameters' units (deg, deg/s; the law by its number: 0 smc, 1 p, 2 trail).

    Parameters
    ----------
    settings : FormationSettings
        The settings.
    """
    return {
        "LFC_RANGE": settings.range_cmd_m,
        "LFC_BEARING": math.degrees(settings.bearing_cmd_rad),
        "LFC_COAST": settings.coast_s,
        "LFC_SEARCH": math.degrees(settings.search_yaw_rate_radps),
        "LFC_LAW": float(CONTROLLERS.index(settings.controller)),
        "LFC_LOOKAHEAD": settings.trail_lookahead_m,
    }


class Follower:
    """A follower's stack: formation controller, companion, events and status reports.

    Parameters
    ----------
    name : str
        The follower's name (in its STATUSTEXT lines).
    settings : FormationSettings
        Its slot and control law.
    companion : CompanionPort
        Where its setpoints, reports and text go.
    step_rate_hz : float
        How often :meth:`step` is called, Hz (the guidance rate).
    status_rate_hz : float
        How often the formation status goes to the ground station, Hz.
    """

    def __init__(
        self,
        name: str,
        settings: FormationSettings,
        companion: CompanionPort,
        *,
        step_rate_hz: float,
        status_rate_hz: float,
    ) -> None:
        self.name = name
        self.controller = FormationController(settings)
        self.companion = companion
        self.events: list[FollowerEvent] = []
        self._status = RateSchedule(status_rate_hz, 1.0 / step_rate_hz)
        self._last: TrackStatus | None = None

    @property
    def settings(self) -> FormationSettings:
        """The controller's settings now (the slot may change while running)."""
        return self.controller.settings

    def set_slot(self, range_m: float, bearing_rad: float) -> None:
        """Move to another slot (a ground station changed it), keeping everything else.

        Parameters
        ----------
        range_m, bearing_rad : float
            The new range (m) and bearing (rad) to the target.
        """
        self.tune(range_cmd_m=range_m, bearing_cmd_rad=bearing_rad)

    def tune_from_params(self, value: Callable[[str], float]) -> None:
        """Take the ``LFC_*`` parameters' values now (a ground station may have set them):
        the slot, the coast, the search rate and the law (see :func:`formation_param_values`).

        Parameters
        ----------
        value : callable
            A parameter's value by name.
        """
        self.tune(
            range_cmd_m=value("LFC_RANGE"),
            bearing_cmd_rad=math.radians(value("LFC_BEARING")),
            coast_s=value("LFC_COAST"),
            search_yaw_rate_radps=math.radians(value("LFC_SEARCH")),
            controller=CONTROLLERS[int(value("LFC_LAW"))],
            trail_lookahead_m=value("LFC_LOOKAHEAD"),
        )

    def tune(self, **fields: float | str) -> None:
        """Change some of the controller's settings while running (a ground station set
        ``LFC_*`` parameters), keeping the rest and the controller's state.

        Parameters
        ----------
        **fields : float or str
            :class:`FormationSettings` fields by name, e.g. ``coast_s=1.0``, ``controller="trail"``.
        """
        st = self.controller.settings

        def changed(k: str, v: float | str) -> bool:
            old = getattr(st, k)
            return old != v if isinstance(v, str) else abs(v - old) > 1e-9

        if any(changed(k, v) for k, v in fields.items()):
            self.controller.settings = dataclasses.replace(st, **fields)

    def step(self, t_s: float, measurement: RelativeMeasurement | None, odometry: Odometry) -> FormationOutput:
        """One guidance step: the formation law on the newest measurement, the setpoint to
        the vehicle, the status report when one is due and an event when the track is lost
        or regained.

        Parameters
        ----------
        t_s : float
            Now, s.
        measurement : RelativeMeasurement or None
            The newest measurement of the target (None before the first).
        odometry : Odometry
            The follower's own pose and speed now.
        """
        out = self.controller.step(measurement, odometry)
        self.companion.setpoint(t_s, out.speed_mps, out.yaw_rate_radps)
        self._track_events(t_s, out.status)
        if self._status.due(t_s):
            st = self.controller.settings
            range_err = out.range_est_m - st.range_cmd_m if out.range_est_m is not None else None
            bearing_err = (
                math.degrees(wrap_pi(out.bearing_est_rad - st.bearing_cmd_rad))
                if out.bearing_est_rad is not None
                else None
            )
            self.companion.report(t_s, range_err, bearing_err, 1.0 if out.status is TrackStatus.TRACKING else 0.0)
        return out

    def command(self, t_s: float, speed_mps: float, yaw_rate_radps: float) -> None:
        """An open-loop setpoint instead of the formation law (scripted test runs): sent as
        :meth:`step` sends its own, reported as tracking, with no formation status.

        Parameters
        ----------
        t_s : float
            Now, s.
        speed_mps, yaw_rate_radps : float
            The setpoint.
        """
        self.companion.setpoint(t_s, speed_mps, yaw_rate_radps)
        self._track_events(t_s, TrackStatus.TRACKING)

    def _track_events(self, t_s: float, status: TrackStatus) -> None:
        last, self._last = self._last, status
        if last is None or status is last or TrackStatus.LOST not in (status, last):
            return
        kind = "lost" if status is TrackStatus.LOST else "reacquired"
        lost = "lost, looking round" if self.settings.search_yaw_rate_radps > 0 else "lost, stopping"
        text = f"{self.name}: leader {lost if kind == 'lost' else 'reacquired'}"
        self.events.append(FollowerEvent(t_s, kind, text))
        self.companion.statustext(text)
