"""Scenario TOML -> frozen dataclasses, validated; every error names the key.

``load_config(path)`` is the only reader of scenario files. Keys ending in ``_deg`` (and
``_degps`` for rates) fill the ``_rad`` (``_radps``) field of the same stem, converted once
here. Unknown keys, wrong types and out-of-range values raise :class:`ConfigError` naming
the dotted key, the value and what was expected.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
import types
import typing
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from lfctl.errors import ConfigError

__all__ = [
    "AuditConfig",
    "BannerConfig",
    "CameraConfig",
    "Config",
    "FormationConfig",
    "GuidanceConfig",
    "LightKey",
    "LinkConfig",
    "MissionConfig",
    "OccluderConfig",
    "PropConfig",
    "RecordingConfig",
    "SceneConfig",
    "ScriptConfig",
    "SensingConfig",
    "SimConfig",
    "Slot",
    "VehicleConfig",
    "config_from_table",
    "load_config",
    "parse_config",
]

# ----------------------------------------------------------------------------------------
# Sections


def _positive(key: str, value: float) -> None:
    if not (value > 0 and math.isfinite(value)):
        raise ConfigError(f"{key} must be > 0, got {value!r}")


def _non_negative(key: str, value: float) -> None:
    if not (value >= 0 and math.isfinite(value)):
        raise ConfigError(f"{key} must be >= 0, got {value!r}")


@dataclass(frozen=True)
class SimConfig:
    """[sim]: the co-simulation clock and the rates of each subsystem."""

    dt_s: float = 0.01  # physics step: every FMU advances by this much per tick, s (<= 1)
    duration_s: float = 60.0  # simulated time, s
    seed: int = 0  # seeds every random stream (sensor noise, renderers): same seed, same run
    #: "lockstep" runs as fast as the CPU allows, deterministic; "realtime" paces to the wall
    #: clock and opens a UDP port per vehicle
    clock: Literal["lockstep", "realtime"] = "lockstep"
    guidance_rate_hz: float = 20.0  # the leader's autopilot and each follower's stack
    camera_rate_hz: float = 30.0  # rendered frames per follower (camera sensing)
    telemetry_rate_hz: float = 10.0  # vehicle poses to the log and the trajectory kept for the summary
    #: each follower's formation status (NAMED_VALUE_FLOAT) to the ground station
    status_rate_hz: float = 2.0
    #: "truth": range and bearing from the world truth with noise ([sensing]); "camera": each
    #: follower's view rendered and perceived
    sensing: Literal["truth", "camera"] = "truth"
    #: processes besides the main one that render and track followers' cameras: -1 one per
    #: spare core (at most one per follower beyond the first), 0 none
    camera_workers: int = -1

    def __post_init__(self) -> None:
        _positive("sim.dt_s", self.dt_s)
        if self.camera_workers < -1:
            raise ConfigError(f"sim.camera_workers must be -1 (auto), 0 or more, got {self.camera_workers!r}")
        if self.dt_s > 1.0:
            raise ConfigError(f"sim.dt_s must be <= 1 s, got {self.dt_s!r}")
        _positive("sim.duration_s", self.duration_s)
        if self.seed < 0:
            raise ConfigError(f"sim.seed must be >= 0, got {self.seed!r}")
        for name in ("guidance_rate_hz", "camera_rate_hz", "telemetry_rate_hz", "status_rate_hz"):
            rate = getattr(self, name)
            _positive(f"sim.{name}", rate)
            if rate > 1.0 / self.dt_s + 1e-9:
                raise ConfigError(
                    f"sim.{name} = {rate!r} Hz is faster than the physics rate 1/dt = {1.0 / self.dt_s:g} Hz"
                )


@dataclass(frozen=True)
class VehicleConfig:
    """One [[vehicles]] entry.

    ``name`` (letters, digits, ``-``, ``_``) is unique; ``role`` is ``"leader"`` (exactly one,
    first) or ``"follower"``. ``model`` names a built-in model (fmu_models/); ``fmu`` a user
    FMU file instead, with ``map`` (role -> variable name) and ``units`` (role -> unit) where
    its names differ.
    """

    name: str
    role: Literal["leader", "follower"]
    model: str = "SkidSteerRover"
    fmu: str | None = None
    fmi_version: int = 2  # which build of a built-in model to load: 2 or 3
    north_m: float = 0.0  # initial position north, local NED, m
    east_m: float = 0.0  # initial position east, m
    yaw_rad: float = 0.0  # initial heading, rad (TOML yaw_deg)
    parameters: Mapping[str, float] = field(default_factory=dict)  # FMU parameter name -> value
    map: Mapping[str, str] = field(default_factory=dict)
    units: Mapping[str, str] = field(default_factory=dict)
    # follower only: whom to follow and where (the formation controller holds this slot)
    target: str | None = None  # the vehicle it follows (None: as [formation] says)
    range_m: float | None = None  # commanded range to the target, m (None: as [formation] says)
    bearing_rad: float | None = None  # commanded bearing, clockwise positive (TOML bearing_deg)

    def __post_init__(self) -> None:
        key = f"vehicles[{self.name}]"
        if not self.name or not self.name.replace("_", "").replace("-", "").isalnum():
            raise ConfigError(f"vehicles.name must be letters, digits, '-' or '_', got {self.name!r}")
        if self.fmi_version not in (2, 3):
            raise ConfigError(f"{key}.fmi_version must be 2 or 3, got {self.fmi_version!r}")
        for k in ("north_m", "east_m", "yaw_rad"):
            if not math.isfinite(getattr(self, k)):
                raise ConfigError(f"{key}.{k} must be finite, got {getattr(self, k)!r}")
        if self.range_m is not None:
            _positive(f"{key}.range_m", self.range_m)
        if self.bearing_rad is not None and not -math.pi <= self.bearing_rad <= math.pi:
            raise ConfigError(f"{key}.bearing_deg must be within [-180, 180], got {math.degrees(self.bearing_rad):.6g}")
        if self.role == "leader":
            for k in ("target", "range_m", "bearing_rad"):
                if getattr(self, k) is not None:
                    raise ConfigError(f"{key}.{_toml_key(k)}: a leader follows nobody, got {getattr(self, k)!r}")
        for p, v in self.parameters.items():
            if not math.isfinite(v):
                raise ConfigError(f"{key}.parameters.{p} must be finite, got {v!r}")


@dataclass(frozen=True)
class ScriptConfig:
    """[script]: open-loop inputs for runs without guidance.

    ``leader`` is a list of ``[duration_s, speed_mps, yaw_rate_deg_s]`` segments, repeated
    to the end of the run (used when ``[mission]`` has no waypoints); ``followers`` is
    ``"formation"`` (closed-loop formation control), ``"stand"`` (zero commands) or
    ``"copy"`` (the leader's commands, open loop).
    """

    leader: tuple[tuple[float, float, float], ...] = ((4.0, 0.3, 0.0), (3.0, 0.3, 30.0))
    followers: Literal["formation", "stand", "copy"] = "formation"

    def __post_init__(self) -> None:
        if not self.leader:
            raise ConfigError("script.leader must have at least one [duration_s, speed_mps, yaw_rate_deg_s] segment")
        for i, seg in enumerate(self.leader):
            if len(seg) != 3:
                raise ConfigError(
                    f"script.leader[{i}] must be [duration_s, speed_mps, yaw_rate_deg_s], got {list(seg)!r}"
                )
            _positive(f"script.leader[{i}][0] (duration_s)", seg[0])


@dataclass(frozen=True)
class MissionConfig:
    """[mission]: the leader's route in local NED, flown in AUTO.

    ``waypoints`` holds ``[north_m, east_m]`` or ``[north_m, east_m, hold_s]`` (wait there).
    Without waypoints the leader follows ``[script]``.
    """

    waypoints: tuple[tuple[float, ...], ...] = ()
    acceptance_radius_m: float = 0.3  # a waypoint is reached within this distance, m
    cruise_speed_mps: float = 0.3  # the leader's speed on straight legs, m/s
    lookahead_m: float = 0.8  # LOS lookahead on the path, m; 0: pure pursuit of the waypoint (eq. 12)

    def __post_init__(self) -> None:
        _positive("mission.acceptance_radius_m", self.acceptance_radius_m)
        _positive("mission.cruise_speed_mps", self.cruise_speed_mps)
        _non_negative("mission.lookahead_m", self.lookahead_m)
        for i, wp in enumerate(self.waypoints):
            if len(wp) not in (2, 3) or not all(math.isfinite(c) for c in wp):
                raise ConfigError(
                    f"mission.waypoints[{i}] must be [north_m, east_m] or [north_m, east_m, hold_s] of finite numbers, got {list(wp)!r}"
                )
            if len(wp) == 3 and wp[2] < 0:
                raise ConfigError(f"mission.waypoints[{i}] hold_s must be >= 0, got {wp[2]!r}")


@dataclass(frozen=True)
class GuidanceConfig:
    """[guidance]: controller choice, gains and limits (leader heading, follower formation)."""

    controller: Literal["smc", "p"] = "smc"  # followers' law: sliding mode, or the P baseline
    max_speed_mps: float = 0.5  # followers' speed limit; also caps the leader's cruise speed
    reverse_speed_mps: float = 0.15  # followers may back up this fast to restore the range
    max_yaw_rate_radps: float = math.radians(90.0)  # every vehicle's yaw-rate limit (TOML max_yaw_rate_degps)
    # followers' sliding-mode range law (RangeGains)
    range_eta_mps: float = 0.25  # reaching rate outside the boundary layer, m/s
    range_phi_m: float = 0.25  # boundary-layer half-width, m
    min_cos_bearing: float = 0.2  # floor on |cos(bearing)| (the broadside singularity)
    # followers' sliding-mode bearing law (BearingGains); TOML *_degps, *_deg
    bearing_eta_radps: float = math.radians(70.0)  # yaw rate outside the boundary layer
    bearing_lambda_s: float = 0.1  # weight of the error rate in the sliding variable, s
    bearing_phi_rad: float = math.radians(15.0)  # boundary-layer half-width
    # the leader's sliding-mode heading law in AUTO (BearingGains); TOML *_degps, *_deg
    heading_eta_radps: float = math.radians(60.0)  # yaw rate outside the boundary layer
    heading_lambda_s: float = 0.1  # weight of the error rate in the sliding variable, s
    heading_phi_rad: float = math.radians(20.0)  # boundary-layer half-width
    turn_slowdown: float = 0.6  # fraction of its speed the leader sheds for a 180 deg turn (0..1)
    p_gain: float = 0.8  # the P baseline's position gain (FOLL_POS_P), 1/s
    coast_s: float = 2.0  # followers coast on their filter this long without a measurement, s
    slowdown_s: float = 1.0  # then slow to a stop over this long before the track is LOST, s

    def __post_init__(self) -> None:
        for name in (
            "max_speed_mps", "max_yaw_rate_radps", "range_eta_mps", "range_phi_m", "min_cos_bearing",
            "bearing_eta_radps", "bearing_phi_rad", "heading_eta_radps", "heading_phi_rad", "p_gain", "slowdown_s",
        ):  # fmt: skip
            _positive(f"guidance.{_toml_key(name)}", getattr(self, name))
        for name in ("bearing_lambda_s", "heading_lambda_s", "coast_s", "reverse_speed_mps"):
            _non_negative(f"guidance.{name}", getattr(self, name))
        if not 0 <= self.turn_slowdown <= 1:
            raise ConfigError(f"guidance.turn_slowdown must be within [0, 1], got {self.turn_slowdown!r}")
        if self.min_cos_bearing > 1:
            raise ConfigError(f"guidance.min_cos_bearing must be <= 1, got {self.min_cos_bearing!r}")


@dataclass(frozen=True)
class SensingConfig:
    """[sensing]: the truth sensor (``--sensing truth``): noise, delay, field of view, dropouts.

    ``dropouts`` are ``[start_s, end_s]`` windows with no measurement: an occluder crossing.
    """

    range_noise_m: float = 0.01  # 1-sigma Gaussian noise on the range, m
    bearing_noise_rad: float = math.radians(0.3)  # 1-sigma noise on the bearing (TOML bearing_noise_deg)
    delay_s: float = 0.05  # age of a measurement when the follower gets it, s (<= 1)
    fov_rad: float = math.radians(360.0)  # full field of view; outside it the target is hidden (TOML fov_deg)
    max_range_m: float = 10.0  # the target is hidden beyond this range, m
    dropouts: tuple[tuple[float, float], ...] = ()

    def __post_init__(self) -> None:
        for name in ("range_noise_m", "bearing_noise_rad", "delay_s"):
            _non_negative(f"sensing.{_toml_key(name)}", getattr(self, name))
        _positive("sensing.fov_deg", self.fov_rad)
        _positive("sensing.max_range_m", self.max_range_m)
        if self.delay_s > 1.0:
            raise ConfigError(f"sensing.delay_s must be <= 1 s, got {self.delay_s!r}")
        for i, w in enumerate(self.dropouts):
            if len(w) != 2 or not w[0] < w[1]:
                raise ConfigError(f"sensing.dropouts[{i}] must be [start_s, end_s] with start < end, got {list(w)!r}")


@dataclass(frozen=True)
class FormationConfig:
    """[formation]: a shipped shape that fills each follower's target, range and bearing.

    ``shape``: ``"column"`` (one behind the other), ``"echelon"`` (a diagonal line back to the
    right), ``"vee"`` (alternating right and left arms). ``targets``: ``"chain"`` (follow the
    vehicle ahead in the shape) or ``"leader"`` (all follow the leader). A follower's own
    ``target``/``range_m``/``bearing_deg`` override the shape.
    """

    shape: Literal["none", "column", "echelon", "vee"] = "none"
    targets: Literal["chain", "leader"] = "chain"
    spacing_m: float = 1.5  # range to the target, m; with targets = "leader", times the place in line or arm
    angle_rad: float = math.radians(30.0)  # echelon, vee: how far off straight behind a follower sits (TOML angle_deg)

    def __post_init__(self) -> None:
        _positive("formation.spacing_m", self.spacing_m)
        if not 0 <= self.angle_rad < math.pi / 2:
            raise ConfigError(f"formation.angle_deg must be within [0, 90), got {math.degrees(self.angle_rad):.6g}")


@dataclass(frozen=True)
class CameraConfig:
    """[camera]: the pinhole camera on each follower (and the real camera for `lfctl follow`).

    Intrinsics come from ``hfov_deg`` unless ``fx_px`` (and optionally ``fy_px``, ``cx_px``,
    ``cy_px``) are given. ``tracker`` picks the tracker the frames feed (the ablation's
    baselines ``"hue"`` and ``"hs-lbp"``, or lfctl's ``"full"``). The mount is ``mount_forward_m`` ahead of the vehicle's reference
    point at ``mount_height_m`` above the ground, pitched ``pitch_deg`` (positive: nose up).
    """

    width_px: int = 640  # image width, px (16..8192)
    height_px: int = 480  # image height, px (16..8192)
    hfov_rad: float = math.radians(62.0)  # horizontal field of view, sets fx (TOML hfov_deg)
    fx_px: float = 0.0  # focal length, px; 0: from hfov
    fy_px: float = 0.0  # focal length, px; 0: fx
    cx_px: float = 0.0  # principal point, px; 0: the image centre
    cy_px: float = 0.0  # principal point, px; 0: the image centre
    k1: float = 0.0  # radial distortion (OpenCV model)
    k2: float = 0.0  # radial distortion, second coefficient
    mount_forward_m: float = 0.12  # camera ahead of the vehicle's reference point, m
    mount_height_m: float = 0.2  # camera above the ground, m
    pitch_rad: float = 0.0  # positive: nose up (TOML pitch_deg)
    noise_sigma: float = 2.0  # sensor noise, digital numbers (0..255)
    motion_blur: bool = False  # blur rendered frames along the image rows while the follower turns
    #: the tracker the camera feeds: "full" (lfctl's), "hs-lbp" (the paper's features, no
    #: filters) or "hue" (the paper's hue-only CAMShift baseline); see lfctl.vision.tracker
    tracker: Literal["full", "hs-lbp", "hue"] = "full"

    def __post_init__(self) -> None:
        if not (16 <= self.width_px <= 8192 and 16 <= self.height_px <= 8192):
            raise ConfigError(
                f"camera.width_px/height_px must be within 16..8192, got {self.width_px}x{self.height_px}"
            )
        if not 0 < self.hfov_rad < math.radians(170):
            raise ConfigError(f"camera.hfov_deg must be within (0, 170), got {math.degrees(self.hfov_rad):.6g}")
        for name in ("fx_px", "fy_px", "cx_px", "cy_px", "noise_sigma", "mount_height_m"):
            _non_negative(f"camera.{name}", getattr(self, name))
        if not -math.pi / 3 <= self.pitch_rad <= math.pi / 3:
            raise ConfigError(f"camera.pitch_deg must be within [-60, 60], got {math.degrees(self.pitch_rad):.6g}")


@dataclass(frozen=True)
class BannerConfig:
    """[banner]: the leader's marker banner: four markers on a square of side ``side_m``
    (the paper's E) on a textured panel on the vehicle's back."""

    side_m: float = 0.14  # side of the square the marker centres sit on, m
    marker_size_m: float = 0.035  # side of one square marker, m
    panel_size_m: float = 0.22  # side of the square panel, m
    centre_height_m: float = 0.2  # height of the banner's centre above the ground, m
    #: the banner's plane is this far behind the vehicle's reference point (its centre of
    #: rotation), m: a follower measures the banner and adds this to reach the vehicle
    back_m: float = 0.155
    marker_hue_deg: float = 0.0  # red; HSV hue in degrees (0..360)
    marker_saturation: float = 0.85  # the markers' HSV saturation (0..1) in the rendered scene
    panel_bgr: tuple[int, ...] = (215, 218, 222)  # near white: the markers carry the hue

    def __post_init__(self) -> None:
        for name in ("side_m", "marker_size_m", "panel_size_m", "centre_height_m"):
            _positive(f"banner.{name}", getattr(self, name))
        _non_negative("banner.back_m", self.back_m)
        if self.side_m + self.marker_size_m > self.panel_size_m:
            raise ConfigError(
                f"banner.side_m + marker_size_m ({self.side_m + self.marker_size_m:g}) must fit on panel_size_m ({self.panel_size_m:g})"
            )
        if not 0 <= self.marker_hue_deg < 360:
            raise ConfigError(f"banner.marker_hue_deg must be within [0, 360), got {self.marker_hue_deg!r}")
        if len(self.panel_bgr) != 3 or not all(0 <= c <= 255 for c in self.panel_bgr):
            raise ConfigError(f"banner.panel_bgr must be [b, g, r] within 0..255, got {list(self.panel_bgr)!r}")


@dataclass(frozen=True)
class PropConfig:
    """One [[scene.props]]: a vertical panel in the world, still or moving.

    ``kind``: ``"wall"`` / ``"box"`` (textured clutter), ``"distractor"`` (flat, the markers'
    hue at saturation 0.6), ``"textured_distractor"`` (the markers' hue and saturation,
    hatched), ``"panel_clutter"`` (flat, the banner panel's colour).
    """

    kind: Literal["wall", "box", "distractor", "textured_distractor", "panel_clutter"]
    north_m: float  # the panel's centre at t = 0, local NED, m
    east_m: float  # the panel's centre at t = 0, m
    yaw_rad: float = 0.0  # the panel's normal, from north
    width_m: float = 0.5  # the panel's size, m
    height_m: float = 0.5  # the panel's size, m
    base_m: float = 0.0  # height of the lower edge above ground
    vel_north_mps: float = 0.0  # constant velocity of the panel, north, m/s
    vel_east_mps: float = 0.0  # constant velocity of the panel, east, m/s

    def __post_init__(self) -> None:
        _positive("scene.props.width_m", self.width_m)
        _positive("scene.props.height_m", self.height_m)


@dataclass(frozen=True)
class OccluderConfig:
    """One [[scene.occluders]]: a panel that crosses between a follower and its target.

    At ``t_s`` it appears ``lateral_m`` to the side of the line of sight, ``fraction`` of the
    way from the follower to the target, and moves across it at ``speed_mps``.
    """

    t_s: float
    follower: str = ""  # whose view it crosses ("": every follower's)
    width_m: float = 0.6  # the panel's size, m
    height_m: float = 0.6  # the panel's size, m
    speed_mps: float = 0.4
    fraction: float = 0.5
    lateral_m: float = 1.2

    def __post_init__(self) -> None:
        _non_negative("scene.occluders.t_s", self.t_s)
        for name in ("width_m", "height_m", "speed_mps", "lateral_m"):
            _positive(f"scene.occluders.{name}", getattr(self, name))
        if not 0 < self.fraction < 1:
            raise ConfigError(f"scene.occluders.fraction must be within (0, 1), got {self.fraction!r}")


@dataclass(frozen=True)
class LightKey:
    """One [[scene.lighting]] key frame; gain and tint are interpolated between keys."""

    t_s: float  # when this key holds, s (keys in time order)
    gain: float = 1.0  # brightness factor, > 0
    tint_bgr: tuple[float, ...] = (1.0, 1.0, 1.0)  # per-channel factors (B, G, R), > 0

    def __post_init__(self) -> None:
        _non_negative("scene.lighting.t_s", self.t_s)
        _positive("scene.lighting.gain", self.gain)
        if len(self.tint_bgr) != 3 or not all(c > 0 for c in self.tint_bgr):
            raise ConfigError(f"scene.lighting.tint_bgr must be three positive factors, got {list(self.tint_bgr)!r}")


@dataclass(frozen=True)
class SceneConfig:
    """[scene]: what the simulated camera sees besides the vehicles."""

    ground: Literal["concrete", "checker", "carpet"] = "concrete"  # the floor's texture
    props: tuple[PropConfig, ...] = ()  # [[scene.props]]: still or moving panels
    occluders: tuple[OccluderConfig, ...] = ()  # [[scene.occluders]]: panels crossing a line of sight
    lighting: tuple[LightKey, ...] = ()  # [[scene.lighting]] key frames (none: constant light)
    flicker_amplitude: float = 0.0  # relative brightness swing of a flicker, 0..1
    flicker_hz: float = 0.0  # its frequency, Hz (0: none)
    shadow_gain: float = 1.0  # < 1: a shadow band sweeps across the image
    shadow_period_s: float = 20.0  # period of the shadow band's sweep across the image, s

    def __post_init__(self) -> None:
        if not 0 <= self.flicker_amplitude < 1:
            raise ConfigError(f"scene.flicker_amplitude must be within [0, 1), got {self.flicker_amplitude!r}")
        _non_negative("scene.flicker_hz", self.flicker_hz)
        if not 0 < self.shadow_gain <= 1:
            raise ConfigError(f"scene.shadow_gain must be within (0, 1], got {self.shadow_gain!r}")
        _positive("scene.shadow_period_s", self.shadow_period_s)
        times = [k.t_s for k in self.lighting]
        if times != sorted(times):
            raise ConfigError(f"scene.lighting key frames must be in time order, got t_s {times!r}")


@dataclass(frozen=True)
class AuditConfig:
    """[audit]: limits `lfctl audit --strict` enforces on this scenario's logs."""

    max_range_err_rms_frac: float = 0.10  # largest range error RMS, as a fraction of the commanded range
    max_bearing_err_rms_deg: float = 5.0  # largest bearing error RMS, degrees
    min_separation_m: float = 0.3  # closest any follower may come to another vehicle, m

    def __post_init__(self) -> None:
        _positive("audit.max_range_err_rms_frac", self.max_range_err_rms_frac)
        _positive("audit.max_bearing_err_rms_deg", self.max_bearing_err_rms_deg)
        _non_negative("audit.min_separation_m", self.min_separation_m)


@dataclass(frozen=True)
class LinkConfig:
    """[link]: MAVLink. Vehicle n (leader 0) listens on ``udp_base_port + n`` with
    ``--realtime`` and sends telemetry to ``gcs_udpout`` too; home is the geodetic origin of
    the local NED frame (GLOBAL_POSITION_INT, missions)."""

    udp_host: str = "127.0.0.1"  # address the vehicles' UDP ports bind to
    udp_base_port: int = 14561
    gcs_udpout: str = "127.0.0.1:14550"  # "" for none
    home_lat_deg: float = 12.9602  # CSIR-NAL, Bengaluru
    home_lon_deg: float = 77.6690  # home longitude, degrees
    home_alt_m: float = 900.0  # home altitude, m
    rate_hz: float = 50.0  # how often the endpoints read their links and stream telemetry, Hz
    signing_passphrase: str = ""  # non-empty: MAVLink 2 signing on the UDP links (key = SHA-256)

    def __post_init__(self) -> None:
        if not 1 <= self.udp_base_port <= 65000:
            raise ConfigError(f"link.udp_base_port must be within 1..65000, got {self.udp_base_port!r}")
        if self.gcs_udpout and (":" not in self.gcs_udpout or not self.gcs_udpout.rsplit(":", 1)[1].isdigit()):
            raise ConfigError(f"link.gcs_udpout must be host:port or empty, got {self.gcs_udpout!r}")
        if not -90 <= self.home_lat_deg <= 90:
            raise ConfigError(f"link.home_lat_deg must be within [-90, 90], got {self.home_lat_deg!r}")
        if not -180 <= self.home_lon_deg <= 180:
            raise ConfigError(f"link.home_lon_deg must be within [-180, 180], got {self.home_lon_deg!r}")
        _positive("link.rate_hz", self.rate_hz)


@dataclass(frozen=True)
class RecordingConfig:
    """[recording]: the run's MCAP log (``<dir>/<UTC time>-<scenario>-<seed>.mcap``)."""

    enabled: bool = True  # record the run (`lfctl sim --no-record` turns it off too)
    dir: str = "logs"
    images: bool = True  # record the camera frames as JPEG (camera sensing only)
    image_rate_hz: float = 30.0  # at most the camera rate
    jpeg_quality: int = 85  # 1..100
    compression: Literal["zstd", "lz4", "none"] = "zstd"  # of the MCAP chunks
    chunk_size_bytes: int = 1024 * 1024  # MCAP chunk size, bytes (>= 1024)

    def __post_init__(self) -> None:
        _positive("recording.image_rate_hz", self.image_rate_hz)
        if not 1 <= self.jpeg_quality <= 100:
            raise ConfigError(f"recording.jpeg_quality must be within 1..100, got {self.jpeg_quality!r}")
        if self.chunk_size_bytes < 1024:
            raise ConfigError(f"recording.chunk_size_bytes must be >= 1024, got {self.chunk_size_bytes!r}")


@dataclass(frozen=True)
class Slot:
    """Where a follower keeps itself."""

    target: str  # the vehicle it follows
    range_m: float  # commanded range to it, m
    bearing_rad: float  # commanded bearing to it, clockwise positive, rad


@dataclass(frozen=True)
class Config:
    """A whole scenario, as :func:`load_config` reads it.

    Parameters
    ----------
    name : str
        The scenario's name (the file's stem unless the file sets ``name``).
    sim : SimConfig
        ``[sim]``.
    vehicles : tuple of VehicleConfig
        ``[[vehicles]]``: the leader first, then the followers; names unique, follower targets
        leading back to the leader without a cycle.
    script, mission, guidance, sensing, formation, camera, banner, scene, recording, link, audit
        The other sections (``[script]``, ``[mission]``, ...), defaults where absent.
    source : str
        The TOML text, kept for the run record.
    """

    name: str
    sim: SimConfig
    vehicles: tuple[VehicleConfig, ...]
    script: ScriptConfig = field(default_factory=ScriptConfig)
    mission: MissionConfig = field(default_factory=MissionConfig)
    guidance: GuidanceConfig = field(default_factory=GuidanceConfig)
    sensing: SensingConfig = field(default_factory=SensingConfig)
    formation: FormationConfig = field(default_factory=FormationConfig)
    camera: CameraConfig = field(default_factory=CameraConfig)
    banner: BannerConfig = field(default_factory=BannerConfig)
    scene: SceneConfig = field(default_factory=SceneConfig)
    recording: RecordingConfig = field(default_factory=RecordingConfig)
    link: LinkConfig = field(default_factory=LinkConfig)
    audit: AuditConfig = field(default_factory=AuditConfig)
    source: str = ""  # the TOML text, kept for the run record

    def __post_init__(self) -> None:
        if not self.vehicles:
            raise ConfigError("vehicles: need at least one [[vehicles]] entry, got none")
        names = [v.name for v in self.vehicles]
        dup = {n for n in names if names.count(n) > 1}
        if dup:
            raise ConfigError(f"vehicles.name must be unique, got {sorted(dup)!r} more than once")
        leaders = [v.name for v in self.vehicles if v.role == "leader"]
        if len(leaders) != 1:
            raise ConfigError(f'vehicles: need exactly one role = "leader", got {len(leaders)} ({leaders!r})')
        if self.vehicles[0].role != "leader":
            raise ConfigError(f"vehicles: the leader must come first, got {self.vehicles[0].name!r} first")
        for v in self.vehicles:
            if v.target is not None and v.target not in names:
                raise ConfigError(f"vehicles[{v.name}].target names an unknown vehicle {v.target!r} (known: {names})")
            if v.target == v.name:
                raise ConfigError(f"vehicles[{v.name}].target cannot be the vehicle itself")
        for i, occ in enumerate(self.scene.occluders):
            if occ.follower and occ.follower not in names:
                raise ConfigError(
                    f"scene.occluders[{i}].follower names an unknown vehicle {occ.follower!r} (known: {names})"
                )
        # followers' targets must lead back to the leader without a cycle
        target = {name: slot.target for name, slot in self.slots().items()}
        for start in target:
            seen, node = [start], target[start]
            while node in target:
                if node in seen:
                    raise ConfigError(f"vehicles: follower targets form a cycle: {' -> '.join([*seen, node])}")
                seen.append(node)
                node = target[node]

    def slots(self) -> dict[str, Slot]:
        """Each follower's target, range and bearing: its own keys, else the formation shape."""
        f = self.formation
        out: dict[str, Slot] = {}
        followers = [v for v in self.vehicles if v.role == "follower"]
        leader = self.vehicles[0].name
        for k, v in enumerate(followers, start=1):
            shaped = f.shape != "none"
            if f.shape == "vee":  # right arm first, then left, alternating
                side, rank = (1 if k % 2 else -1), (k + 1) // 2
                ahead = leader if rank == 1 else followers[k - 3].name
            else:
                side, rank = 1, k
                ahead = self.vehicles[k - 1].name
            # a follower back-right of its target sees it ahead-left: a negative bearing
            bearing = -side * f.angle_rad if f.shape in ("echelon", "vee") else 0.0
            chain = shaped and f.targets == "chain"
            target = ahead if chain else leader
            distance = f.spacing_m * (rank if shaped and not chain else 1)
            out[v.name] = Slot(
                target=v.target if v.target is not None else target,
                range_m=v.range_m if v.range_m is not None else distance,
                bearing_rad=v.bearing_rad if v.bearing_rad is not None else bearing,
            )
        return out

    @property
    def leader(self) -> VehicleConfig:
        """The one leader (validated to be first)."""
        return self.vehicles[0]

    @property
    def followers(self) -> tuple[VehicleConfig, ...]:
        """Every follower, in file order."""
        return self.vehicles[1:]


# ----------------------------------------------------------------------------------------
# Generic conversion: TOML tables -> the dataclasses above


def _type_name(tp: Any) -> str:
    return getattr(tp, "__name__", None) or str(tp).replace("typing.", "")


def _convert(value: Any, tp: Any, key: str) -> Any:
    origin = typing.get_origin(tp)
    args = typing.get_args(tp)
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        inner = [a for a in args if a is not type(None)]
        return _convert(value, inner[0], key)
    if origin is Literal:
        if value not in args:
            raise ConfigError(f"{key} must be one of {', '.join(repr(a) for a in args)}, got {value!r}")
        return value
    if dataclasses.is_dataclass(tp):
        if not isinstance(value, dict):
            raise ConfigError(f"{key} must be a table, got {value!r}")
        return _build(tp, value, key)
    if tp is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(f"{key} must be a number, got {value!r}")
        return float(value)
    if tp is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(f"{key} must be an integer, got {value!r}")
        return value
    if tp is str:
        if not isinstance(value, str):
            raise ConfigError(f"{key} must be a string, got {value!r}")
        return value
    if tp is bool:
        if not isinstance(value, bool):
            raise ConfigError(f"{key} must be true or false, got {value!r}")
        return value
    if origin is tuple:
        if not isinstance(value, list):
            raise ConfigError(f"{key} must be an array, got {value!r}")
        item = args[0]
        return tuple(_convert(v, item, f"{key}[{i}]") for i, v in enumerate(value))
    if origin in (Mapping, dict, typing.Mapping):
        if not isinstance(value, dict):
            raise ConfigError(f"{key} must be a table, got {value!r}")
        return {k: _convert(v, args[1], f"{key}.{k}") for k, v in value.items()}
    raise TypeError(f"config field type {_type_name(tp)} not handled")  # a bug in this module


def _build(cls: Any, table: dict[str, Any], prefix: str) -> Any:
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls) if f.name != "source"}
    kwargs: dict[str, Any] = {}
    for raw_key, value in table.items():
        name, convert = raw_key, None
        if raw_key.endswith("_deg") and f"{raw_key[:-4]}_rad" in fields:
            name, convert = f"{raw_key[:-4]}_rad", math.radians
        elif raw_key.endswith("_degps") and f"{raw_key[:-6]}_radps" in fields:
            name, convert = f"{raw_key[:-6]}_radps", math.radians
        key = f"{prefix}.{raw_key}" if prefix else raw_key
        if name not in fields or raw_key.endswith(("_rad", "_radps")):
            allowed = sorted(_toml_key(f) for f in fields)
            raise ConfigError(f"unknown key {key!r} (allowed here: {', '.join(allowed)})")
        if name in kwargs:
            raise ConfigError(f"{key} given twice (as degrees and radians)")
        converted = _convert(value, hints[name], key)
        kwargs[name] = convert(converted) if convert else converted
    missing = [
        n
        for n, f in fields.items()
        if n not in kwargs and f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING
    ]
    if missing:
        raise ConfigError(
            f"{prefix or 'scenario'}: missing required key(s) {', '.join(repr(_toml_key(m)) for m in missing)}"
        )
    return cls(**kwargs)


def _toml_key(field_name: str) -> str:
    if field_name.endswith("_radps"):
        return field_name[:-6] + "_degps"
    if field_name.endswith("_rad"):
        return field_name[:-4] + "_deg"
    return field_name


def parse_config(text: str, name: str = "scenario") -> Config:
    """Parse and validate scenario TOML text; see :func:`load_config`.

    Parameters
    ----------
    text : str
        The TOML.
    name : str
        The scenario's name when the text sets none; error messages start with it.

    Raises
    ------
    ConfigError
        Bad TOML, unknown key, wrong type or out-of-range value.
    """
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{name}: not valid TOML: {exc}") from exc
    return config_from_table(data, name, text)


def config_from_table(table: Mapping[str, Any], name: str = "scenario", source: str = "") -> Config:
    """Build and validate a scenario from its TOML tables as :mod:`tomllib` reads them (a
    sweep edits a scenario's tables, then builds each variant with this).

    Parameters
    ----------
    table : mapping
        The scenario's top-level table; not modified.
    name : str
        The scenario's name when the table sets none.
    source : str
        The TOML text the table stands for, kept as :attr:`Config.source`.

    Raises
    ------
    ConfigError
        Unknown key, wrong type or out-of-range value.
    """
    data = dict(table)
    data.setdefault("name", name)
    data.setdefault("sim", {})
    vehicles = data.get("vehicles", [])
    if not isinstance(vehicles, list):
        raise ConfigError(f"vehicles must be an array of tables ([[vehicles]]), got {vehicles!r}")
    tables = []
    for i, v in enumerate(vehicles):
        if not isinstance(v, dict):
            raise ConfigError(f"vehicles[{i}] must be a table, got {v!r}")
        tables.append(v)
    data["vehicles"] = tables
    # Vehicle errors name the vehicle: build them one by one with their name in the key.
    built = []
    for i, v in enumerate(tables):
        label = f"vehicles[{v.get('name', i)}]"
        built.append(_build(VehicleConfig, v, label))
    rest = {k: v for k, v in data.items() if k != "vehicles"}
    top = _build(_ConfigTable, rest, "")
    sections = {f.name: getattr(top, f.name) for f in dataclasses.fields(_ConfigTable)}
    return Config(**sections, vehicles=tuple(built), source=source)


@dataclass(frozen=True)
class _ConfigTable:
    """Top-level keys other than [[vehicles]] (which parse_config builds one by one)."""

    name: str
    sim: SimConfig = field(default_factory=SimConfig)
    script: ScriptConfig = field(default_factory=ScriptConfig)
    mission: MissionConfig = field(default_factory=MissionConfig)
    guidance: GuidanceConfig = field(default_factory=GuidanceConfig)
    sensing: SensingConfig = field(default_factory=SensingConfig)
    formation: FormationConfig = field(default_factory=FormationConfig)
    camera: CameraConfig = field(default_factory=CameraConfig)
    banner: BannerConfig = field(default_factory=BannerConfig)
    scene: SceneConfig = field(default_factory=SceneConfig)
    recording: RecordingConfig = field(default_factory=RecordingConfig)
    link: LinkConfig = field(default_factory=LinkConfig)
    audit: AuditConfig = field(default_factory=AuditConfig)


def load_config(path: str | Path) -> Config:
    """Read and validate a scenario file.

    Parameters
    ----------
    path : str or Path
        A TOML scenario (see examples/).

    Raises
    ------
    ConfigError
        Unreadable file, bad TOML, unknown key, wrong type or out-of-range value.
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"cannot read scenario {p}: {exc}") from exc
    try:
        return parse_config(text, name=p.stem)
    except ConfigError as exc:
        raise ConfigError(f"{p}: {exc}") from None
