"""The camera annotations the recorder writes, in Foxglove's image coordinates: their origin is
the top-left corner of the top-left pixel, so pixel (i, j) covers [i, i+1] x [j, j+1] (OpenCV
centres it at (i, j))."""

from __future__ import annotations

import cv2
import numpy as np
from foxglove import messages as fm
from foxglove_schemas_protobuf.ImageAnnotations_pb2 import ImageAnnotations

from lfctl.record.writer import _annotations
from lfctl.vision.markers import find_constellations, refine
from lfctl.vision.track_state import TrackStatus
from lfctl.vision.tracker import TrackState

SIDE = 9  # px: a marker's square (odd: its centroid is a whole pixel in OpenCV's convention)
SQUARES = [(40, 30), (100, 30), (100, 90), (40, 90)]  # top-left pixel of each marker, TL, TR, BR, BL


def recorded(track: TrackState) -> ImageAnnotations:
    """The annotations as Foxglove decodes them."""
    return ImageAnnotations.FromString(_annotations(fm.Timestamp(sec=1, nsec=0), track, None).encode())


def test_the_markers_are_drawn_on_their_centres_and_the_window_on_its_pixels_edges() -> None:
    frame = np.full((130, 160, 3), 230, np.uint8)
    for x, y in SQUARES:
        frame[y : y + SIDE, x : x + SIDE] = (20, 20, 230)  # red, the banner's default hue
    hsv = cv2.cvtColor(frame, cv2.COLOR_BGR2HSV)
    (c,) = find_constellations(hsv, 0.0)
    markers = refine(c, hsv, 0.0).centres  # as the tracker reports them
    x0, y0 = SQUARES[0]
    window = (x0, y0, SQUARES[2][0] + SIDE - x0, SQUARES[2][1] + SIDE - y0)  # the markers' pixels, whole
    ann = recorded(TrackState(0, TrackStatus.TRACKING, window, 1.0, 0.0, markers, None))
    outline, dots = ann.points
    # each marker's square covers [x, x+SIDE] x [y, y+SIDE]: its centre is half a side in
    got = [(p.x, p.y) for p in dots.points]
    assert np.allclose(got, [(x + SIDE / 2, y + SIDE / 2) for x, y in SQUARES], atol=1e-6), got
    # the window's outline runs along the outer edges of its outermost pixels
    right, bottom = window[0] + window[2], window[1] + window[3]
    assert [(p.x, p.y) for p in outline.points] == [(x0, y0), (right, y0), (right, bottom), (x0, bottom)]
    assert right == SQUARES[2][0] + SIDE and bottom == SQUARES[2][1] + SIDE  # the last marker pixel's far edge
