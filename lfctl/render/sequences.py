"""Rendered test sequences with ground truth: the tiers of `lfctl bench vision` and the
vision tests. A still follower camera at the origin looks north; the leader moves in front
of it with scripted range, bearing and heading; each tier adds what makes tracking hard.

Tiers: ``clear``; ``distractor`` (a flat marker-hue panel crossing beside the banner at a
controlled image gap of 0, 30 or 60 px); ``lighting`` (a drop to 40 % with a warm tint,
flicker and a shadow band); ``occlusion`` (a panel passes in front: partial, then full for
over a second); ``textured_distractor``; ``panel_clutter`` (flat panels the banner panel's
colour beside the path: the hard one); ``range`` (0.5 to 4 m with the leader turning up
to +-60 deg).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Literal

import numpy as np

from lfctl.config import BannerConfig, CameraConfig, LightKey, PropConfig, SceneConfig
from lfctl.render.renderer import FrameTruth, Renderer, VehiclePose

__all__ = ["TIERS", "Sequence", "make_sequence"]

#: the tiers, easiest first (see the module docstring)
TIERS = ("clear", "distractor", "lighting", "occlusion", "textured_distractor", "panel_clutter", "range")
FPS = 30.0
GAPS_PX = (0, 30, 60)


@dataclass(frozen=True)
class Sequence:
    """A tier at a seed: render it frame by frame with :meth:`frames` (30 frames per second).

    Parameters
    ----------
    tier : str
        One of :data:`TIERS`.
    seed : int
        Seeds the leader's motion and the renderer.
    n_frames : int
        Length of the sequence.
    camera, banner, scene : CameraConfig, BannerConfig, SceneConfig
        What the renderer draws.
    gap_px : int or None
        Distractor tiers: the image gap between the banner and the distractor, px; None for
        the other tiers.
    """

    tier: str
    seed: int
    n_frames: int
    camera: CameraConfig
    banner: BannerConfig
    scene: SceneConfig
    gap_px: int | None = None

    def leader(self, t_s: float) -> VehiclePose:
        """The leader's pose at ``t_s`` (relative to the camera vehicle at the origin).

        Parameters
        ----------
        t_s : float
            Time from the first frame, s.
        """
        rng = np.random.default_rng(self.seed)
        phase = float(rng.uniform(0, 2 * math.pi))
        if self.tier == "range":
            r = 2.25 - 1.75 * math.cos(2 * math.pi * t_s / 10.0)
            b = 0.12 * math.sin(2 * math.pi * t_s / 7.0 + phase)
            h = math.radians(60.0) * math.sin(2 * math.pi * t_s / 6.0 + phase)
        elif self.tier in ("distractor", "textured_distractor"):
            r, b, h = 2.0, 0.03 * math.sin(t_s + phase), 0.2 * math.sin(0.7 * t_s + phase)
        elif self.tier == "panel_clutter":
            r = 2.0 + 0.2 * math.sin(0.5 * t_s + phase)
            b = 0.22 * math.sin(2 * math.pi * t_s / 10.0 + phase)  # sweeps past the clutter
            h = 0.3 * math.sin(0.6 * t_s + phase)
        else:
            r = 1.8 + 0.3 * math.sin(0.6 * t_s + phase)
            b = 0.2 * math.sin(0.5 * t_s + phase)
            h = 0.45 * math.sin(0.4 * t_s + phase)
        return VehiclePose(r * math.cos(b), r * math.sin(b), h)

    def frames(self) -> Iterator[tuple[float, np.ndarray, FrameTruth]]:
        """Yield ``(t_s, frame, truth)`` for every frame."""
        renderer = Renderer(self.camera, self.banner, self.scene, self.seed)
        follower = VehiclePose(0.0, 0.0, 0.0, banner=False)
        for k in range(self.n_frames):
            t = k / FPS
            frame, truth = renderer.render(t, follower, [self.leader(t)], 0, "follower")
            yield t, frame, truth


def make_sequence(
    tier: str,
    seed: int,
    n_frames: int = 300,
    camera: CameraConfig | None = None,
    banner: BannerConfig | None = None,
    realism: Literal["on", "off"] = "off",
) -> Sequence:
    """The tier's sequence for a seed (deterministic).

    Parameters
    ----------
    tier : str
        One of :data:`TIERS` (ValueError for another).
    seed : int
        Picks the props' places, the leader's motion phase and, for the distractor tiers,
        the gap (0, 30 or 60 px).
    n_frames : int
        Length, frames at 30 per second.
    camera : CameraConfig, optional
        The camera (default :class:`~lfctl.config.CameraConfig`'s).
    banner : BannerConfig, optional
        The banner (default :class:`~lfctl.config.BannerConfig`'s).
    realism : {"off", "on"}
        The renderer's look (``scene.realism``): ``"off"``, the flat look the tracker's tests
        pin, or ``"on"``, with photographed ground, walls and background picked per seed
        (what ``lfctl bench vision`` renders).
    """
    if tier not in TIERS:
        raise ValueError(f"unknown tier {tier!r} (known: {', '.join(TIERS)})")
    cam = camera or CameraConfig()
    ban = banner or BannerConfig()
    rng = np.random.default_rng(seed + 1000)
    duration = n_frames / FPS
    wall = PropConfig("wall", 7.0, 0.0, math.pi, width_m=9.0, height_m=1.6)
    boxes = tuple(
        PropConfig(
            "box",
            float(rng.uniform(3.5, 6.0)),
            float(rng.uniform(-2.5, 2.5)),
            math.pi + float(rng.uniform(-0.5, 0.5)),
            width_m=0.5,
            height_m=0.4,
        )
        for _ in range(3)
    )
    props: tuple[PropConfig, ...] = (wall, *boxes)
    lighting: tuple[LightKey, ...] = ()
    occluders = ()
    flicker, shadow = 0.0, 1.0
    gap = None
    fx = (cam.width_px / 2) / math.tan(cam.hfov_rad / 2)
    if tier in ("distractor", "textured_distractor"):
        gap = GAPS_PX[seed % len(GAPS_PX)]
        depth = 2.0 - ban.back_m - cam.mount_forward_m  # the banner's distance from the camera
        size = 0.2
        top_of_banner = ban.centre_height_m + ban.panel_size_m / 2
        base = top_of_banner + gap * depth / fx  # the gap, as seen in the image, above the banner
        kind = "distractor" if tier == "distractor" else "textured_distractor"
        speed = 1.6 / duration  # crosses 1.6 m of the view during the sequence
        props += (PropConfig(kind, 2.0 - 0.16, -0.8, math.pi, width_m=size, height_m=size, base_m=base, vel_east_mps=speed),)  # fmt: skip
    elif tier == "lighting":
        lighting = (
            # drops to 40 % and turns warm between 30 % and 50 % of the run
            LightKey(0.0, 1.0),
            LightKey(0.3 * duration, 1.0),
            LightKey(0.5 * duration, 0.4, (1.0, 0.95, 1.25)),
            LightKey(duration, 0.45, (1.0, 0.95, 1.25)),
        )
        flicker, shadow = 0.05, 0.6
    elif tier == "occlusion":
        from lfctl.config import OccluderConfig

        # appears 1.1 m left of the line of sight, 40 % of the way, crosses at 0.3 m/s:
        # partial, then fully hidden for about 1.4 s, then partial again
        occluders = (
            OccluderConfig(2.0, "follower", width_m=0.55, height_m=0.7, speed_mps=0.3, fraction=0.4, lateral_m=1.1),
        )
    elif tier == "panel_clutter":
        for side in (-1, 1):
            props += (
                PropConfig(
                    "panel_clutter",
                    2.1,
                    side * 0.42,
                    math.pi,
                    width_m=ban.panel_size_m,
                    height_m=ban.panel_size_m,
                    base_m=ban.centre_height_m - ban.panel_size_m / 2,
                ),
            )
    scene = SceneConfig(
        ground="concrete",
        realism=realism,
        textures="footage",  # with realism "on": photographed ground, walls and background, picked per seed
        props=props,
        occluders=occluders,
        lighting=lighting,
        flicker_amplitude=flicker,
        flicker_hz=2.0 if flicker else 0.0,
        shadow_gain=shadow,
        shadow_period_s=6.0,
    )
    return Sequence(tier, seed, n_frames, cam, ban, scene, gap)
