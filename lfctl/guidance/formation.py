"""The follower's formation controller: holds a commanded range and bearing to its target
from its own sensor and odometry only (never the target's telemetry).

A constant-velocity Kalman filter (filterpy) on the target's position in the local frame,
fed by the relative measurement placed with the follower's own odometry, supplies the target
velocity the sliding-mode range law needs (paper eq. 20-23) and coasts through occlusions.
Behaviour by track state: TRACKING -> full control; no measurement -> coast on the filter for
``coast_s``, then slow to a stop over ``slowdown_s`` (OCCLUDED); beyond that, or when the
sensor says LOST -> stop (LOST) until the target is seen again. With
``search_yaw_rate_radps`` set, once the coast and the slow-down are over the follower looks
for it: one full turn in place towards the side the filter last put it on, then hold; by
default (0) it holds at once, as ArduPilot's FOLLOW mode does without a target. A camera
sees only ahead: a target that turned away, showing its side, or went past the edge of the
picture is seen again only by looking round.

Three control laws share everything else: ``"smc"`` (the paper's, corrected), ``"p"``, a
proportional controller on the position offset like ArduPilot's AP_Follow (FOLL_POS_P), the
baseline the benchmark compares against, and ``"trail"``: both of those aim at the target and
so cut its corners; a trail follower drives the path the filter says the target drove
(:mod:`lfctl.guidance.trail`), the slot's range taken along it and its sideways offset kept
beside it.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from filterpy.common import Q_discrete_white_noise
from filterpy.kalman import KalmanFilter

from lfctl.errors import ConfigError
from lfctl.frames import body_to_ned, wrap_pi
from lfctl.guidance.smc import BearingGains, RangeGains, SlidingModeController, clamp, smc_speed_mps
from lfctl.guidance.trail import Trail, trail_speed_mps
from lfctl.vision.track_state import RelativeMeasurement, TrackStatus

__all__ = ["CONTROLLERS", "FormationController", "FormationOutput", "FormationSettings", "Odometry", "TargetEstimator"]

#: the follower's control laws (``guidance.controller``)
CONTROLLERS = ("smc", "p", "trail")
#: nearer a target ahead of it than this share of the slot's range in a straight line, the
#: trail law backs away as the range law would (round a right-angle corner an in-line
#: follower comes to 1/sqrt(2) of it along the trail, one beside the path on the inside nearer)
TRAIL_MIN_RANGE = 0.6
#: the trail law holds slots up to this bearing; a wider one is held by the sliding-mode law
#: (from 35 deg to the side, on the inside of a right-angle corner, a follower reaches the
#: corner as its target turns it and turns the long way round)
TRAIL_MAX_BEARING_RAD = math.radians(30.0)  # lfctl.config.TRAIL_MAX_BEARING_DEG, which a test keeps equal
#: a target estimated faster than this moves the way its velocity points (a bearing-only
#: sighting then places the banner's offset along it), m/s
MOVING_MPS = 0.1
#: the sliding-mode law holds slots below this bearing; one at or past it (the follower abeam
#: of its target or ahead) is held by the P law (lfctl.config.SMC_MAX_BEARING_DEG, which a
#: test keeps equal)
SMC_MAX_BEARING_RAD = math.radians(90.0)
#: the trail law keeps the target this far inside the picture's edge besides the banner's own
#: half-width, rad: the tracker's window and search region need the room
VIEW_MARGIN_RAD = math.radians(5.0)


@dataclass(frozen=True)
class Odometry:
    """The follower's own pose and speed (its odometry / local position), SI, NED."""

    t_s: float  # when it was taken, s (the clock measurements are stamped with)
    north_m: float  # position in the local NED frame
    east_m: float  # position in the local NED frame
    yaw_rad: float  # heading from north, clockwise positive
    speed_mps: float  # forward speed


@dataclass(frozen=True)
class FormationSettings:
    """Formation controller settings.

    Parameters
    ----------
    range_cmd_m, bearing_cmd_rad : float
        Commanded range (m) and bearing (rad, clockwise positive) to the target.
    controller : "smc", "p" or "trail"
        The paper's sliding-mode laws, the AP_Follow-style proportional baseline, or the
        target's trail driven with the same gains (the range law along the trail, the
        bearing law on the heading to a point ``trail_lookahead_m`` ahead along it).
    range, bearing : RangeGains, BearingGains
        Sliding-mode gains.
    trail_lookahead_m : float
        The trail follower's lookahead distance, m (> 0).
    view_half_fov_rad, banner_half_m : float
        The sensor sees this far either side of the heading, rad (half a camera's horizontal
        field of view; pi: all round), and half the target's banner, m: the trail law keeps
        its heading within that, less the banner's half-width at the slot's range and
        ``VIEW_MARGIN_RAD`` (never less than the slot's own bearing), of the target, and so
        turns ahead of a corner it cannot see round.
    p_gain_per_s, p_heading_gain_per_s : float
        Baseline position gain (FOLL_POS_P) and heading gain (yaw rate per rad of heading
        error), 1/s.
    coast_s, slowdown_s : float
        Coast on the filter this long after the last measurement, then slow to a stop over
        ``slowdown_s``; after both the track is LOST.
    search_yaw_rate_radps : float
        Once LOST and the coast and slow-down are over, turn in place one full turn at this
        rate (rad/s, at most ``bearing.max_yaw_rate_radps``) towards the side the target was
        last estimated on, then hold; 0 (the default): hold still. A LOST from the sensor
        within the coast does not start the turn (a tracker's moment of doubt with the target
        still ahead).
    meas_sigma_m : float
        Position noise of a measurement placed in the world, m (filter R).
    accel_sigma_mps2 : float
        Target acceleration noise, m/s^2 (filter Q).

    The defaults are the controller's own (no reversing: ``range.min_speed_mps`` 0); the
    settings a scenario gives its follower, with its gains, reverse speed, coast and camera
    view, are :func:`lfctl.follower.stack.formation_settings`'s. A value out of its range
    (not a number, a range of 0 or less, an unknown law) is a ConfigError (a ValueError) naming it.
    """

    range_cmd_m: float = 1.5
    bearing_cmd_rad: float = 0.0
    controller: Literal["smc", "p", "trail"] = "smc"
    range: RangeGains = field(default_factory=RangeGains)
    bearing: BearingGains = field(default_factory=BearingGains)
    trail_lookahead_m: float = 0.3
    view_half_fov_rad: float = math.pi
    banner_half_m: float = 0.0
    p_gain_per_s: float = 0.8
    p_heading_gain_per_s: float = 2.0
    coast_s: float = 2.0
    slowdown_s: float = 1.0
    search_yaw_rate_radps: float = 0.0
    meas_sigma_m: float = 0.03
    accel_sigma_mps2: float = 0.3

    def __post_init__(self) -> None:
        if self.controller not in CONTROLLERS:
            raise ConfigError(f"controller must be one of {', '.join(CONTROLLERS)}, got {self.controller!r}")
        if not abs(self.bearing_cmd_rad) <= math.pi:  # NaN too
            raise ConfigError(f"bearing_cmd_rad must be within -pi..pi, got {self.bearing_cmd_rad!r}")
        if not 0.0 < self.view_half_fov_rad <= math.pi:
            raise ConfigError(f"view_half_fov_rad must be within (0, pi], got {self.view_half_fov_rad!r}")
        positive = ("range_cmd_m", "trail_lookahead_m", "slowdown_s", "meas_sigma_m", "accel_sigma_mps2")
        at_least_0 = ("banner_half_m", "p_gain_per_s", "p_heading_gain_per_s", "coast_s", "search_yaw_rate_radps")
        for name in positive + at_least_0:
            value = getattr(self, name)
            if not (0.0 < value < math.inf if name in positive else 0.0 <= value < math.inf):
                raise ConfigError(
                    f"{name} must be a number {'above' if name in positive else 'of at least'} 0, got {value!r}"
                )


@dataclass(frozen=True)
class FormationOutput:
    """One step of the formation controller."""

    speed_mps: float  # forward speed command
    yaw_rate_radps: float  # yaw-rate command, positive right
    status: TrackStatus  # the controller's track state (see the module docstring)
    range_est_m: float | None  # filter estimate of the range to the target now (None: no estimate yet, or LOST)
    bearing_est_rad: float | None  # and of its bearing, clockwise positive (None: no estimate yet, or LOST)
    target_vel_ned_mps: tuple[float, float]  # the target's estimated velocity, north and east
    since_measurement_s: float  # since the last measurement was fused (inf before the first)
    #: the law the command came from: the settings' controller, but "smc" while a slot is too
    #: wide for the trail law (see TRAIL_MAX_BEARING_RAD)
    law: str = ""


def _value(x: float | None) -> float | None:
    """A measured value, or None where there is none (or it is not a number)."""
    return x if x is not None and math.isfinite(x) else None


#: most (step, noise) models a TargetEstimator keeps (a run with a fixed guidance rate uses ~10)
_MAX_MODELS = 64


class TargetEstimator:
    """Constant-velocity Kalman filter on the target's local NED position (filterpy).

    Parameters
    ----------
    meas_sigma_m : float
        Position noise of a fix, m (R).
    accel_sigma_mps2 : float
        The target's acceleration noise, m/s^2 (Q).
    """

    def __init__(self, meas_sigma_m: float, accel_sigma_mps2: float) -> None:
        # state x = [north, east, v_north, v_east] (m, m/s); measurement z = [north, east]
        self.kf = KalmanFilter(dim_x=4, dim_z=2)
        # H = [I, 0]
        self.kf.H = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]])
        # R = meas_sigma^2 I
        self.kf.R = np.eye(2) * meas_sigma_m**2
        self.accel_var = accel_sigma_mps2**2
        self.initialised = False
        # (dt_s, accel_var) -> F, Q: the guidance steps' few distinct lengths (t - t_prev in
        # floating point takes about ten values for one period); read-only, shared by steps
        self._models: dict[tuple[float, float], tuple[np.ndarray, np.ndarray]] = {}

    def init(self, north_m: float, east_m: float) -> None:
        """Start at a first fix, velocity unknown (0 with a wide variance).

        Parameters
        ----------
        north_m, east_m : float
            The target's position, local NED, m.
        """
        self.kf.x = np.array([north_m, east_m, 0.0, 0.0])
        # P0 = diag(R, 0.5^2): the position as measured, the velocity within about 0.5 m/s
        self.kf.P = np.diag([self.kf.R[0, 0], self.kf.R[1, 1], 0.5**2, 0.5**2])
        self.initialised = True

    def predict(self, dt_s: float) -> None:
        """Advance the estimate by ``dt_s``.

        Parameters
        ----------
        dt_s : float
            Time step, s; nothing happens for <= 0.
        """
        if dt_s <= 0:
            return
        # F and Q made once per step length and noise: Q_discrete_white_noise cost more than
        # the prediction itself, every step
        key = (dt_s, self.accel_var)
        model = self._models.get(key)
        if model is None:
            if len(self._models) >= _MAX_MODELS:
                self._models.clear()
            # F = [[I, dt I], [0, I]]
            F = np.array([[1.0, 0.0, dt_s, 0.0], [0.0, 1.0, 0.0, dt_s], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]])
            # Q = accel_sigma^2 [[dt^4/4 I, dt^3/2 I], [dt^3/2 I, dt^2 I]] (white acceleration noise)
            Q = Q_discrete_white_noise(dim=2, dt=dt_s, var=self.accel_var, block_size=2, order_by_dim=False)
            for a in (F, Q):
                a.flags.writeable = False
            model = self._models[key] = (F, Q)
        self.kf.F, self.kf.Q = model
        # x = F x
        # P = F P F' + Q
        self.kf.predict()

    def update(self, north_m: float, east_m: float, R: np.ndarray | None = None) -> None:
        """Fuse a position fix.

        Parameters
        ----------
        north_m, east_m : float
            The target's measured position, local NED, m.
        R : np.ndarray, optional
            The fix's 2x2 covariance, m^2; None uses the filter's (``meas_sigma_m``).
        """
        # y = z - H x
        # S = H P H' + R
        # K = P H' S^-1
        # x = x + K y
        # P = (I - K H) P (I - K H)' + K R K'  (Joseph form)
        self.kf.update(np.array([north_m, east_m]), R=R)

    @property
    def position(self) -> tuple[float, float]:
        """Estimated target position (north, east), m."""
        return float(self.kf.x[0]), float(self.kf.x[1])

    @property
    def velocity(self) -> tuple[float, float]:
        """Estimated target velocity (north, east), m/s."""
        return float(self.kf.x[2]), float(self.kf.x[3])

    def range_bearing_sigma(self, dx_m: float, dy_m: float) -> tuple[float, float]:
        """1-sigma range (m) and bearing (rad) uncertainty of the target seen along (dx, dy)
        (infinite when the offset is zero).

        Parameters
        ----------
        dx_m, dy_m : float
            Target minus observer, north and east, m.
        """
        s = math.hypot(dx_m, dy_m)
        if s == 0.0:
            return math.inf, math.inf
        u = np.array([dx_m, dy_m]) / s
        perp = np.array([-u[1], u[0]])
        cov = self.kf.P[0:2, 0:2]
        return math.sqrt(float(u @ cov @ u)), math.sqrt(float(perp @ cov @ perp)) / s

    def significant_velocity(self, n_sigma: float = 2.0) -> tuple[float, float]:
        """The velocity, or zero where it is within ``n_sigma`` of the filter's own uncertainty.

        A still target's estimate wanders with the measurement noise; feeding that forward
        makes the follower hunt. A velocity the filter cannot tell from zero is taken as zero
        (a chi-square test on the 2-D velocity, ``n_sigma`` standard deviations).

        Parameters
        ----------
        n_sigma : float
            How many standard deviations from zero a velocity must be to count.
        """
        v = self.kf.x[2:4]
        cov = self.kf.P[2:4, 2:4]
        try:
            d2 = float(v @ np.linalg.solve(cov, v))
        except np.linalg.LinAlgError:
            return self.velocity
        return self.velocity if d2 > n_sigma**2 else (0.0, 0.0)


class FormationController:
    """Thin stateful shell: filter, bearing SMC memory, odometry history, track timers.

    Parameters
    ----------
    settings : FormationSettings
        The slot, control law, gains and filter noise; :attr:`settings` may be replaced
        between steps (a new slot).
    """

    def __init__(self, settings: FormationSettings) -> None:
        self.settings = settings
        self.estimator = TargetEstimator(settings.meas_sigma_m, settings.accel_sigma_mps2)
        self.bearing_smc = SlidingModeController(settings.bearing)
        self._odom: deque[Odometry] = deque(maxlen=64)
        self._t_last_meas = -math.inf
        # the time of the last measurement fused (its image time): one handed again (a camera
        # slower than the guidance steps) is not fused again
        self._t_fused = -math.inf
        self._sample_gap: float | None = None  # between the last two measurements fused (their times), s
        self._t_prev: float | None = None
        self._target_heading: float | None = None
        # the search once LOST: the turn's direction (+1 right, -1 left), its heading a step
        # ago and how far it has turned (rad); None while not searching
        self._search: tuple[float, float, float, float] | None = None
        # LOST by the coast and slow-down running out: held until a fresh sighting (a longer
        # coast set meanwhile applies to the next occlusion, not to a target long unseen)
        self._timed_out = False
        self.trail = Trail()  # the target's path, for the trail law (started by the first fix)
        self._trail_restart = True
        self._law = settings.controller  # a law changed while running starts afresh
        self.status = TrackStatus.LOST

    def _odometry_at(self, t_s: float) -> Odometry:
        """The follower's pose at ``t_s`` (nearest kept sample), for delayed measurements."""
        return min(self._odom, key=lambda o: abs(o.t_s - t_s))

    def step(self, meas: RelativeMeasurement | None, odom: Odometry) -> FormationOutput:
        """Commands for this guidance step from the latest measurement (or none).

        Parameters
        ----------
        meas : RelativeMeasurement or None
            The newest measurement of the target (None before the first); one older than
            ``odom`` is placed with the odometry of its own time.
        odom : Odometry
            The follower's pose and speed now.

        Raises
        ------
        ValueError
            An odometry value that is not a number (it would stay in the target's filter for
            good), named.
        TypeError
            ``odom`` that is not an :class:`Odometry`.
        """
        if not isinstance(odom, Odometry):
            raise TypeError(f"odometry must be an Odometry(t_s, north_m, east_m, yaw_rad, speed_mps), got {odom!r}")
        for name in ("t_s", "north_m", "east_m", "yaw_rad", "speed_mps"):
            if not math.isfinite(getattr(odom, name)):
                raise ValueError(f"odometry {name} is {getattr(odom, name)!r}: the formation law needs a number")
        st = self.settings
        if st.controller != self._law:  # a ground station chose another law (LFC_LAW)
            self._law = st.controller
            self._trail_restart = True  # the trail has not been kept while another law drove
            self.bearing_smc.reset()
        law = st.controller
        if law == "trail" and abs(st.bearing_cmd_rad) > TRAIL_MAX_BEARING_RAD:
            law = "smc"  # a ground station set a slot wider than the trail law holds (LFC_BEARING)
        if law == "smc" and abs(st.bearing_cmd_rad) >= SMC_MAX_BEARING_RAD:
            law = "p"  # ... or one at or past the side: the position law holds any slot
        dt = 0.0 if self._t_prev is None else odom.t_s - self._t_prev
        self._t_prev = odom.t_s
        self._odom.append(odom)
        est = self.estimator
        if est.initialised:
            est.predict(dt)
        bearing = _value(meas.bearing_rad) if meas is not None and meas.status is TrackStatus.TRACKING else None
        measured_range = _value(meas.range_m) if meas is not None and bearing is not None else None
        if measured_range is not None and measured_range <= 0.0:
            measured_range = None  # no distance (a sensor's garbage): the bearing alone counts
        stale = odom.t_s - self._t_last_meas > st.coast_s + st.slowdown_s
        # a bearing-only sighting can keep a running filter alive, not start one
        sighted = measured_range is not None or (bearing is not None and est.initialised and not stale)
        # each measurement is fused once: one handed again (the camera slower than the steps)
        # adds nothing the filter has not taken, and taken again it would shrink the filter's
        # uncertainty as if it were new
        fresh = sighted and meas is not None and meas.t_s > self._t_fused
        if fresh and meas is not None and bearing is not None:
            gap = meas.t_s - self._t_fused
            if math.isfinite(gap) and (self._sample_gap is None or gap <= 3.0 * self._sample_gap):
                self._sample_gap = gap  # the camera's pace (a gap across an occlusion is not)
            self._t_fused = meas.t_s
            at = self._odometry_at(meas.t_s)
            R = None
            if measured_range is not None:
                dn, de = body_to_ned(measured_range * math.cos(bearing), measured_range * math.sin(bearing), at.yaw_rad)
                n, e = at.north_m + dn, at.east_m + de
            else:
                n, e, R = self._bearing_fix(meas, bearing, at)
            if not est.initialised or stale:
                est.init(n, e)
                self._trail_restart = True  # a target found afresh: its old trail is not its path now
            else:
                # the fix describes meas.t_s: bring it to now with the estimated velocity
                vn, ve = est.velocity
                lag = max(0.0, odom.t_s - meas.t_s)
                est.update(n + vn * lag, e + ve * lag, R)
            self._t_last_meas = odom.t_s
        since = odom.t_s - self._t_last_meas
        sensor_lost = meas is not None and meas.status is TrackStatus.LOST
        self._timed_out = not fresh and (self._timed_out or since > st.coast_s + st.slowdown_s)
        # a measurement handed again is the latest frame while the next is not yet due (twice
        # the gap between the last two; until there are two, the coast or two steps): a
        # camera that stopped is then a target unseen, and coasts
        due = max(st.coast_s, 2.0 * dt) if self._sample_gap is None else 2.0 * self._sample_gap
        if fresh or (sighted and since <= due):
            self.status = TrackStatus.TRACKING
        elif sensor_lost or not est.initialised or self._timed_out:
            self.status = TrackStatus.LOST
        else:
            self.status = TrackStatus.OCCLUDED

        if self.status is TrackStatus.LOST:
            self.bearing_smc.reset()
            if est.initialised:
                _rng, brg = self._relative(odom)  # (the side it was last seen on, for the search)
                turn = self._look(odom, brg) if self._timed_out else 0.0
                # no range or bearing said for a lost target: the filter's estimate runs on
                # with its last velocity (26.9 m off for a leader 2 m away, on the ground
                # station's rng_err), which is no measure of where it is
                return FormationOutput(0.0, turn, self.status, None, None, est.velocity, since, law)
            return FormationOutput(0.0, 0.0, self.status, None, None, (0.0, 0.0), since, law)

        self._search = None
        (tn, te), (vn, ve) = est.position, est.significant_velocity()
        dx, dy = tn - odom.north_m, te - odom.east_m
        rng, brg = self._relative(odom)
        if st.controller == "trail" and law != "trail":  # a slot too wide for the trail (LFC_BEARING)
            self._trail_restart = True
        if law == "smc":
            speed, yaw_rate = self._smc(dx, dy, vn, ve, rng, brg, odom, dt)
        elif law == "trail":
            speed, yaw_rate = self._trail(tn, te, vn, ve, odom, dt, fresh)
        else:
            speed, yaw_rate = self._p_baseline(tn, te, vn, ve, odom)
        if self.status is TrackStatus.OCCLUDED and since > st.coast_s:
            scale = clamp(1.0 - (since - st.coast_s) / st.slowdown_s, 0.0, 1.0)
            speed *= scale
            yaw_rate *= scale
        return FormationOutput(speed, yaw_rate, self.status, rng, brg, (vn, ve), since, law)

    def _look(self, odom: Odometry, bearing_rad: float) -> float:
        """The yaw rate of a LOST follower's search: one full turn in place towards the side
        of ``bearing_rad`` (the filter's bearing to the target as the search begins), then 0.

        The turn is counted on the odometry, the way it turns (a yaw that does not change, or
        goes the other way, is no progress), and ends at twice the time a full turn takes at
        the rate, whatever the odometry says (a vehicle that cannot turn on the spot).
        """
        st = self.settings
        rate = min(st.search_yaw_rate_radps, st.bearing.max_yaw_rate_radps)
        if rate <= 0.0:
            return 0.0
        if self._search is None:
            self._search = (-1.0 if bearing_rad < 0.0 else 1.0, odom.t_s, odom.yaw_rad, 0.0)
        side, t0, last_yaw, turned = self._search
        turned += side * wrap_pi(odom.yaw_rad - last_yaw)
        self._search = (side, t0, odom.yaw_rad, turned)
        done = turned >= 2.0 * math.pi or odom.t_s - t0 > 2.0 * (2.0 * math.pi / rate)
        return 0.0 if done else side * rate

    def _relative(self, odom: Odometry) -> tuple[float, float]:
        tn, te = self.estimator.position
        dx, dy = tn - odom.north_m, te - odom.east_m
        return math.hypot(dx, dy), wrap_pi(math.atan2(dy, dx) - odom.yaw_rad)

    def _smc(
        self, dx: float, dy: float, vn: float, ve: float, rng: float, brg: float, odom: Odometry, dt: float
    ) -> tuple[float, float]:
        st = self.settings
        err = wrap_pi(brg - st.bearing_cmd_rad)
        if vn == 0.0 and ve == 0.0:  # the target is still (to the filter's confidence)
            sigma_r, sigma_b = self.estimator.range_bearing_sigma(dx, dy)
            if abs(rng - st.range_cmd_m) < 2.0 * sigma_r and abs(err) < 2.0 * sigma_b:
                self.bearing_smc.reset()
                return 0.0, 0.0  # in the slot to within the sensor's noise: hold, do not hunt
        speed = smc_speed_mps(dx, dy, vn, ve, odom.yaw_rad, st.range_cmd_m, st.range)
        # equivalent control: turn rate of the world line of sight, from the relative velocity
        rel_vn = vn - odom.speed_mps * math.cos(odom.yaw_rad)
        rel_ve = ve - odom.speed_mps * math.sin(odom.yaw_rad)
        los_rate = (dx * rel_ve - dy * rel_vn) / max(rng * rng, 1e-6)
        los_rate = clamp(los_rate, -st.bearing.max_yaw_rate_radps, st.bearing.max_yaw_rate_radps)
        return speed, self.bearing_smc.step(err, dt, los_rate)

    def _trail(
        self, tn: float, te: float, vn: float, ve: float, odom: Odometry, dt: float, fresh: bool
    ) -> tuple[float, float]:
        """The target's trail driven: the bearing law on the heading to a point
        ``trail_lookahead_m`` ahead along it (offset sideways by the slot), the range law on
        the gap along it, slowed by the heading still to turn. The trail grows only from fresh
        fixes of a moving target: not from the filter's guess while it is hidden (a corner
        turned out of sight would go in as an overshoot), nor from its noise while it stands."""
        st = self.settings
        trail = self.trail
        dx, dy = tn - odom.north_m, te - odom.east_m
        # a negative bearing (the target ahead-left) puts the follower right of the trail
        offset = -st.range_cmd_m * math.sin(st.bearing_cmd_rad)
        if not self._trail_restart and fresh and (vn != 0.0 or ve != 0.0):
            trail.extend(tn, te)
        if not self._trail_restart:
            fix = trail.locate(odom.north_m, odom.east_m)
            gap = trail.end_s(tn, te) - fix.s_m
            # the target behind the follower along its trail (it came back towards it, or was
            # found again there): that trail is not the way to it now
            self._trail_restart = gap < 0.0
        if self._trail_restart:
            # the trail starts level with the follower, ``offset`` to its left, and runs straight to the target
            start = (odom.north_m + offset * math.sin(odom.yaw_rad), odom.east_m - offset * math.cos(odom.yaw_rad))
            trail.reset(start, (tn, te), odom.yaw_rad)
            self._trail_restart = False
            fix = trail.locate(odom.north_m, odom.east_m)
            gap = trail.end_s(tn, te) - fix.s_m
        gap_cmd = st.range_cmd_m * math.cos(st.bearing_cmd_rad)
        if vn == 0.0 and ve == 0.0:  # the target is still (to the filter's confidence)
            sigma_r, _ = self.estimator.range_bearing_sigma(dx, dy)
            if abs(gap - gap_cmd) < 2.0 * sigma_r:
                self.bearing_smc.reset()
                return 0.0, 0.0  # in the slot to within the sensor's noise: hold, do not hunt
        an, ae = trail.aim(odom.north_m, odom.east_m, st.trail_lookahead_m, offset)
        heading = math.atan2(ae - odom.east_m, an - odom.north_m)
        # keep the target in view: the heading within the view's limit of its line of sight
        sight = math.atan2(dy, dx)
        limit = self._view_limit_rad()
        heading = sight + clamp(wrap_pi(heading - sight), -limit, limit)
        err = wrap_pi(heading - odom.yaw_rad)
        n1, e1 = trail.points[-1]
        n0, e0 = trail.points[-2]
        ahead = math.hypot(n1 - n0, e1 - e0)
        target_speed = (vn * (n1 - n0) + ve * (e1 - e0)) / ahead if ahead > 0 else math.hypot(vn, ve)
        speed = trail_speed_mps(gap, gap_cmd, target_speed, err, st.range)
        straight = math.hypot(dx, dy)
        if speed < 0.0 and straight > st.range_cmd_m:
            speed = 0.0  # further than the slot in a straight line: backing off the trail only adds to it
        near = TRAIL_MIN_RANGE * st.range_cmd_m
        if straight < near and dx * math.cos(odom.yaw_rad) + dy * math.sin(odom.yaw_rad) > 0.5 * straight:
            # too near a target ahead (within 60 deg of the heading), however far along the
            # trail: back away, as the range law does (not from one beside or behind it)
            speed = min(speed, smc_speed_mps(dx, dy, vn, ve, odom.yaw_rad, near, st.range))
        return speed, self.bearing_smc.step(err, dt)

    def _view_limit_rad(self) -> float:
        """How far the trail law's heading may be from the target's line of sight, rad."""
        st = self.settings
        if st.view_half_fov_rad >= math.pi:
            return math.pi
        banner = math.atan2(st.banner_half_m, st.range_cmd_m)
        return max(st.view_half_fov_rad - banner - VIEW_MARGIN_RAD, abs(st.bearing_cmd_rad))

    def _heading_of_target(self, vn: float, ve: float, yaw_rad: float) -> float:
        """The target's heading, rad: the way it moves (``vn``, ``ve``, m/s) when it moves, else
        the last such, else the follower's own ``yaw_rad`` (a follower in formation faces as
        its target does)."""
        if math.hypot(vn, ve) > 0.05:
            self._target_heading = math.atan2(ve, vn)
        return self._target_heading if self._target_heading is not None else yaw_rad

    def _bearing_fix(self, meas: RelativeMeasurement, bearing: float, at: Odometry) -> tuple[float, float, np.ndarray]:
        """A bearing-only sighting as a position fix of the target's reference point (north,
        east, m) and its covariance: the ray from where it starts (the camera, on the follower
        at its pose ``at``) meets the seen point (the banner, behind the target's reference
        point along its heading) at the filter's own distance to that point; the target's
        point is then that far ahead of it. The target's heading is the way it moves while it
        clearly moves (:data:`MOVING_MPS`), else taken as the follower's own (a follower in
        formation faces as its target does); the variance is large along the line of sight,
        and across it the bearing's own plus what the heading may misplace the offset by (a
        fifth of it while moving, all of it when the heading is taken)."""
        est = self.estimator
        dn, de = body_to_ned(*meas.origin_body_m, at.yaw_rad)
        on, oe = at.north_m + dn, at.east_m + de
        vn, ve = est.significant_velocity()
        moving = math.hypot(vn, ve) > MOVING_MPS
        heading = math.atan2(ve, vn) if moving else at.yaw_rad
        back_n, back_e = meas.seen_back_m * math.cos(heading), meas.seen_back_m * math.sin(heading)
        pn, pe = est.position
        rng = max(0.1, math.hypot(pn - back_n - on, pe - back_e - oe))
        los = at.yaw_rad + bearing
        u = np.array([math.cos(los), math.sin(los)])
        v = np.array([-u[1], u[0]])
        offset_sd = meas.seen_back_m * (0.2 if moving else 1.0)
        R = np.outer(u, u) * 0.5**2 + np.outer(v, v) * ((rng * 0.02) ** 2 + offset_sd**2)
        return on + rng * u[0] + back_n, oe + rng * u[1] + back_e, R

    def _p_baseline(self, tn: float, te: float, vn: float, ve: float, odom: Odometry) -> tuple[float, float]:
        """AP_Follow style: desired velocity = target velocity + P x offset error."""
        st = self.settings
        heading = self._heading_of_target(vn, ve, odom.yaw_rad)
        # the slot: range_cmd behind the target, seen at bearing_cmd from an aligned follower
        back, side = body_to_ned(
            -st.range_cmd_m * math.cos(st.bearing_cmd_rad), -st.range_cmd_m * math.sin(st.bearing_cmd_rad), heading
        )
        want_n, want_e = (
            vn + st.p_gain_per_s * (tn + back - odom.north_m),
            ve + st.p_gain_per_s * (te + side - odom.east_m),
        )
        mag = math.hypot(want_n, want_e)
        if mag < 0.02:  # inside the slot and the target still: stay
            return 0.0, 0.0
        err = wrap_pi(math.atan2(want_e, want_n) - odom.yaw_rad)
        speed = clamp(mag * max(0.0, math.cos(err)), st.range.min_speed_mps, st.range.max_speed_mps)
        limit = st.bearing.max_yaw_rate_radps
        return speed, clamp(st.p_heading_gain_per_s * err, -limit, limit)
