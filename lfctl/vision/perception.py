"""Perception: camera frames in, the target's range and bearing out. The one pipeline the
simulated camera (`lfctl sim`, camera sensing), a real rover (`lfctl follow`) and
`lfctl track` all run:

    frame -> tracker (CAMShift on H x S x LBP, Kalman filters, marker constellation;
             or, for an ArUco banner, cv2.aruco with the same filters: lfctl.vision.aruco)
          -> pose of the four points (solvePnP IPPE_SQUARE, else the paper's eq. 9-11)
          -> the banner's offset on its vehicle -> RelativeMeasurement

When the markers are hidden but the histogram tracker holds its window, the window's centre
column still gives a bearing: a bearing-only measurement (no range) that the formation
filter fuses. Pure: frames and times in, values out.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from lfctl.config import BannerConfig, CameraConfig
from lfctl.vision.aruco import ArucoSettings, ArucoTracker
from lfctl.vision.banner import BannerGeometry
from lfctl.vision.boxes import Box
from lfctl.vision.camera_model import CameraModel
from lfctl.vision.frames import FrameError
from lfctl.vision.pose import MarkerPose, paper_pose, pnp_pose, to_vehicle_frame
from lfctl.vision.track_state import RelativeMeasurement, TrackStatus
from lfctl.vision.tracker import Tracker, TrackerSettings, TrackState, tracker_kind

__all__ = ["BannerPerception", "Perception", "banner_in_picture", "slot_box"]

#: a bearing-only measurement from the tracked window counts for this much of the window's quality
WINDOW_QUALITY = 0.3


@dataclass(frozen=True)
class Perception:
    """One frame, perceived.

    Parameters
    ----------
    t_s : float
        The frame's time, s.
    track : TrackState or None
        The tracker's result; None before the target was first found.
    pose : MarkerPose or None
        The banner's pose from its markers, when all four were seen.
    measurement : RelativeMeasurement
        What the formation controller gets: range and bearing (TRACKING with a pose), a
        bearing only (TRACKING from the window), or OCCLUDED / LOST with no values.
    """

    t_s: float
    track: TrackState | None
    pose: MarkerPose | None
    measurement: RelativeMeasurement


def slot_box(camera: CameraModel, banner: BannerGeometry, range_m: float, bearing_rad: float) -> Box | None:
    """Where the target's banner shows in the image when the follower holds its slot (the
    target at ``range_m``, ``bearing_rad``, heading the same way), or None when out of view.

    Parameters
    ----------
    camera : CameraModel
        The follower's camera.
    banner : BannerGeometry
        The target's banner.
    range_m, bearing_rad : float
        The slot: range (m) and bearing (rad, clockwise positive) of the target.
    """
    centre = np.array(
        [
            range_m * math.cos(bearing_rad) + banner.offset_body_m,
            range_m * math.sin(bearing_rad),
            -banner.centre_height_m,
        ]
    )
    h = banner.panel_size_m / 2  # the panel square to the follower's axis (the same heading)
    corners = centre + np.array([[0.0, -h, -h], [0.0, h, -h], [0.0, h, h], [0.0, -h, h]])
    cam = (corners - camera.mount_body_m) @ camera.R_body_from_cam  # each row R^T p: camera frame
    if np.any(cam[:, 2] <= 0.05):
        return None
    px = camera.pixels(cam[:, :2] / cam[:, 2:3])  # through the lens
    (x0, y0), (x1, y1) = px.min(axis=0), px.max(axis=0)
    return int(round(x0)), int(round(y0)), max(1, int(round(x1 - x0))), max(1, int(round(y1 - y0)))


def banner_in_picture(camera: CameraModel, banner: BannerGeometry, range_m: float, bearing_rad: float) -> bool:
    """Whether the target's banner shows wholly in the picture when the follower holds its
    slot (:func:`slot_box`): a follower whose slot leaves it out loses its target there.

    Parameters
    ----------
    camera, banner, range_m, bearing_rad
        As :func:`slot_box` takes them.
    """
    box = slot_box(camera, banner, range_m, bearing_rad)
    if box is None:
        return False
    x, y, w, h = box
    return x >= 0 and y >= 0 and x + w <= camera.width and y + h <= camera.height


class BannerPerception:
    """The tracker (or the ArUco detector), the pose and the banner's offset, frame after frame.

    Parameters
    ----------
    camera : CameraModel
        Intrinsics, distortion and mount of the camera the frames come from.
    banner : BannerGeometry
        The target's banner.
    settings : TrackerSettings or ArucoSettings
        The marker tracker's settings (kind, marker hue, ...), or the ArUco detector's.
    expected_box : Box, optional
        Where the target should appear at the start (see :func:`slot_box`): with several
        banners in view, the tracker starts on the one nearest it.
    """

    def __init__(
        self,
        camera: CameraModel,
        banner: BannerGeometry,
        settings: TrackerSettings | ArucoSettings,
        expected_box: Box | None = None,
    ) -> None:
        self.camera = camera
        self.banner = banner
        self.settings = settings
        self.expected_box = expected_box
        self.restart()

    def restart(self) -> None:
        """Look for the target afresh, as at the start (its markers or tag, the one nearest
        ``expected_box``): after a gap in the frames (a camera that stopped and came back) the
        track's filters know nothing of where it went meanwhile."""
        settings = self.settings
        self.tracker: Tracker | ArucoTracker = (
            ArucoTracker(settings) if isinstance(settings, ArucoSettings) else Tracker(settings)
        )
        self.started = False

    @staticmethod
    def from_config(
        camera: CameraConfig,
        banner: BannerConfig,
        slot: tuple[float, float] | None = None,
        *,
        kind: str = "full",
        use_markers: bool = True,
        marker_hue_deg: float | None = None,
    ) -> BannerPerception:
        """Perception as a scenario's ``[camera]`` and ``[banner]`` describe it: the marker
        tracker, or for ``banner.kind = "aruco"`` the ArUco detector (``kind``,
        ``use_markers`` and ``marker_hue_deg`` then do not apply).

        Parameters
        ----------
        camera, banner : CameraConfig, BannerConfig
            The scenario's sections.
        slot : (range_m, bearing_rad), optional
            The follower's slot: the tracker starts on the banner nearest where it shows.
        kind : "full", "hs-lbp" or "hue" ("hue-only" too; ConfigError for another)
            The tracker (see :class:`TrackerSettings`).
        use_markers : bool
            Use the banner's markers (pose, reacquisition); False tracks any object by its
            histogram only.
        marker_hue_deg : float, optional
            The markers' hue, degrees (default the banner's).
        """
        kind = tracker_kind(kind)  # a wrong name refused, with a tag banner too
        cam = CameraModel.from_config(camera)
        cam.check_lens()  # (a real camera's too: no ray for the picture's edge is no lens)
        geometry = BannerGeometry.from_config(banner)
        expected = slot_box(cam, geometry, *slot) if slot is not None else None
        if banner.kind == "aruco":
            tag = ArucoSettings(banner.aruco_dictionary, banner.aruco_id, geometry.panel_over_side)
            return BannerPerception(cam, geometry, tag, expected)
        settings = TrackerSettings(
            kind=kind,
            marker_hue_deg=banner.marker_hue_deg if marker_hue_deg is None else marker_hue_deg,
            marker_saturation=banner.marker_saturation,
            marker_over_side=geometry.marker_size_m / geometry.side_m,
            panel_over_side=geometry.panel_over_side,
            use_markers=use_markers,
        )
        return BannerPerception(cam, geometry, settings, expected)

    def step(self, t_s: float, frame: np.ndarray, roi: Box | None = None) -> Perception:
        """Perceive one frame.

        Until the target is found, each frame is searched for the banner's markers or tag (or, with
        ``roi``, the tracker starts on that window); after that the tracker follows it.

        Parameters
        ----------
        t_s : float
            The frame's time, s.
        frame : np.ndarray
            BGR image, uint8, H x W x 3.
        roi : Box, optional
            Start on this window (x, y, w, h) instead of searching for the markers; used
            only while not started.

        Raises
        ------
        FrameError
            A bad frame, or one of another size than the camera model's (its intrinsics
            would place the target wrongly: build the perception for the frames' size).
        """
        cam = self.camera
        if getattr(frame, "shape", None) is not None and frame.shape[:2] != (cam.height, cam.width):
            raise FrameError(
                f"frame is {frame.shape[1]}x{frame.shape[0]}, the camera model {cam.width}x{cam.height}: give the "
                "camera config the frames' width_px and height_px (and their intrinsics)"
            )
        track: TrackState | None
        if not self.started:
            if roi is not None:
                track = self.tracker.init(frame, roi)
            else:
                track = self.tracker.init_from_markers(frame, self.expected_box)
            self.started = track is not None
        else:
            track = self.tracker.update(frame)
        pose = self.marker_pose(track.markers) if track is not None and track.markers is not None else None
        return Perception(t_s, track, pose, self._measurement(t_s, track, pose))

    def marker_pose(self, markers: np.ndarray) -> MarkerPose | None:
        """The banner's pose from its four marker centres, or its tag's corners (TL, TR, BR,
        BL, pixels): PnP, else the paper's two-pair estimate.

        Parameters
        ----------
        markers : np.ndarray
            (4, 2) marker centres (tag corners) in raw (distorted) pixels.
        """
        side = self.banner.square_m
        cam = self.camera
        found = pnp_pose(markers, cam.K, cam.dist, side)
        if found is not None:
            return found
        if np.any(cam.dist != 0):  # the paper's estimate is a pinhole one: take the lens out first
            rays = cam.rays(markers)
            markers = rays * (cam.K[0, 0], cam.K[1, 1]) + (cam.K[0, 2], cam.K[1, 2])
        return paper_pose(markers, cam.K, side, cam.R_body_from_cam)

    def vehicle_relative(self, pose: MarkerPose) -> tuple[float, float, float]:
        """Range (m), bearing (rad) and relative heading (rad) between the two vehicles'
        reference points, from the banner's pose.

        Parameters
        ----------
        pose : MarkerPose
            The banner in the camera frame.
        """
        cam = self.camera
        return to_vehicle_frame(pose, cam.mount_body_m, cam.R_body_from_cam, self.banner.back_m)

    def _measurement(self, t_s: float, track: TrackState | None, pose: MarkerPose | None) -> RelativeMeasurement:
        if track is not None and track.status is TrackStatus.TRACKING:
            if pose is not None:
                rng, brg, _ = self.vehicle_relative(pose)
                return RelativeMeasurement(t_s, TrackStatus.TRACKING, rng, brg, min(pose.quality, track.quality))
            if track.bbox is not None:
                # markers hidden (banner turned edge-on, partly covered) but the histogram
                # tracker holds the window: a bearing-only measurement the formation filter fuses
                return self._window_measurement(t_s, track)
        status = track.status if track is not None else TrackStatus.LOST
        return RelativeMeasurement(t_s, status if status is not TrackStatus.TRACKING else TrackStatus.OCCLUDED)

    def _window_measurement(self, t_s: float, track: TrackState) -> RelativeMeasurement:
        """Bearing only, from the tracked window's centre (its size says too little): the ray
        from the camera (the lens taken out) to the banner, given with the camera's mount and
        the banner's place on the leader, so that the formation filter places it between the
        two vehicles' reference points."""
        assert track.bbox is not None
        x, y, w, h = track.bbox
        cam = self.camera
        u, v = cam.rays(np.array([[x + w / 2.0, y + h / 2.0]]))[0]  # normalised image coordinates
        ray_body = cam.R_body_from_cam @ np.array([u, v, 1.0])
        bearing = math.atan2(ray_body[1], ray_body[0])
        origin = (float(cam.mount_body_m[0]), float(cam.mount_body_m[1]))
        return RelativeMeasurement(
            t_s, TrackStatus.TRACKING, None, bearing, WINDOW_QUALITY * track.quality, origin, self.banner.back_m
        )
