"""The leader's banner: a light square panel on the vehicle's back with four square markers
of one hue at the corners of a square of side E (the paper's marker constellation), or one
ArUco tag at its centre.

Geometry only, shared by the renderer (which draws it) and perception (which measures it):
where the banner sits on its vehicle (``back_m`` behind its reference point, which
perception adds to the measured banner to reach the vehicle) and where the four points
perception measures (the markers' centres, or the tag's corners) are in the world.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from lfctl.config import BannerConfig
from lfctl.frames import rot_z

__all__ = ["BannerGeometry"]


@dataclass(frozen=True)
class BannerGeometry:
    """Where a banner is and how big.

    Parameters
    ----------
    side_m : float
        Side of the square the four marker centres sit on (the paper's E), m.
    marker_size_m : float
        Side of one marker, m.
    panel_size_m : float
        Side of the square panel, m.
    centre_height_m : float
        Height of the banner's centre above the ground, m.
    back_m : float
        How far the banner's plane is behind the vehicle's reference point, m (> 0).
    kind : "markers" or "aruco"
        What the panel carries: the four markers, or one ArUco tag.
    tag_size_m : float
        Side of the ArUco tag's black square, m (``kind = "aruco"``).
    """

    side_m: float
    marker_size_m: float
    panel_size_m: float
    centre_height_m: float
    back_m: float
    kind: Literal["markers", "aruco"] = "markers"
    tag_size_m: float = 0.165

    @staticmethod
    def from_config(cfg: BannerConfig) -> BannerGeometry:
        """The geometry a scenario's ``[banner]`` describes.

        Parameters
        ----------
        cfg : BannerConfig
            The ``[banner]`` section.
        """
        return BannerGeometry(
            cfg.side_m, cfg.marker_size_m, cfg.panel_size_m, cfg.centre_height_m, cfg.back_m, cfg.kind, cfg.tag_size_m
        )

    @property
    def square_m(self) -> float:
        """Side of the square perception measures, m: the markers' centres' (E), or the tag's."""
        return self.tag_size_m if self.kind == "aruco" else self.side_m

    @property
    def panel_over_side(self) -> float:
        """Panel side / measured square's side: the banner's box from its markers' (or tag's) box."""
        return self.panel_size_m / self.square_m

    @property
    def offset_body_m(self) -> float:
        """The banner centre's position along the body x axis (negative: behind), m."""
        return -self.back_m

    def frame_ned(self, north_m: float, east_m: float, yaw_rad: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The banner's centre and its unit axes (right and down, as seen from behind) in NED.

        Parameters
        ----------
        north_m, east_m : float
            The carrying vehicle's reference point, m.
        yaw_rad : float
            The carrying vehicle's heading, rad.
        """
        Rz = rot_z(yaw_rad)
        centre = np.array([north_m, east_m, 0.0]) + Rz @ np.array([self.offset_body_m, 0.0, -self.centre_height_m])
        right = Rz @ np.array([0.0, 1.0, 0.0])
        down = np.array([0.0, 0.0, 1.0])
        return centre, right, down

    def markers_ned(self, north_m: float, east_m: float, yaw_rad: float) -> np.ndarray:
        """The four marker centres (the tag's corners for an ArUco banner) in NED, (4, 3):
        TL, TR, BR, BL as seen from behind.

        Parameters
        ----------
        north_m, east_m : float
            The carrying vehicle's reference point, m.
        yaw_rad : float
            The carrying vehicle's heading, rad.
        """
        centre, right, down = self.frame_ned(north_m, east_m, yaw_rad)
        half = self.square_m / 2
        return np.array(
            [
                centre - right * half - down * half,
                centre + right * half - down * half,
                centre + right * half + down * half,
                centre - right * half + down * half,
            ]
        )
