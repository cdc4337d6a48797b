"""The Foxglove layout lfctl ships (``examples/foxglove-layout.json``), built with
foxglove-sdk's layout types from the topic names the recorder uses.

3D (the ``map`` frame, east-north-up, following the leader; vehicles, mission and slots
from ``/scene``, the camera frames from ``/tf``), Map (every ``/<vehicle>/fix``), the
follower's camera with its annotations, plots of its range and bearing error, and the Log.
It opens a live ``lfctl sim --live`` as well as a recorded log.
"""

from __future__ import annotations

import foxglove.layouts as fl

from lfctl.record.writer import MAP_FRAME, image_topic

__all__ = ["layout_json"]


def layout_json(
    follower: str = "follower1",
    leader: str = "leader",
    image_format: str = "h264",
    camera: bool = True,
    scene: bool = True,
) -> str:
    """The layout as JSON (Foxglove: Layout, Import from file).

    Parameters
    ----------
    follower : str
        Whose camera and errors it shows.
    leader : str
        The vehicle the 3D view follows.
    image_format : str
        ``h264`` (``/<follower>/camera/video``) or ``jpeg`` (``.../image/compressed``).
    camera : bool
        The run has a camera (camera sensing): without one there is no camera panel, whose
        topics would never come.
    scene : bool
        The run publishes ``/scene`` (the simulator's vehicles, mission and slots); without
        it (``lfctl follow``) the 3D view shows ``/tf``'s frames only.
    """
    image = fl.ImagePanel(
        title=f"{follower} camera",
        config=fl.ImageConfig(
            image_mode=fl.ImageModeConfig(
                image_topic=image_topic(follower, image_format),
                calibration_topic=f"/{follower}/camera/calibration",
                annotations={f"/{follower}/camera/annotations": fl.ImageAnnotationSettings(visible=True)},
            )
        ),
    )
    scene = fl.ThreeDeePanel(
        title="formation",
        config=fl.ThreeDeeConfig(
            follow_tf=leader,
            fixed_frame=MAP_FRAME,
            follow_mode="follow-position",
            enu_frame_id=MAP_FRAME,
            topics={"/scene": fl.BaseRendererSceneUpdateTopicSettings(visible=True)} if scene else {},
        ),
    )
    errors = fl.PlotPanel(
        title=f"{follower} formation errors (truth)",
        config=fl.PlotConfig(
            paths=[
                fl.PlotSeries(value=f"/{follower}/controller.range_error_m", label="range error (m)"),
                fl.PlotSeries(value=f"/{follower}/controller.bearing_error_deg", label="bearing error (deg)"),
            ],
            show_legend=True,
        ),
    )
    layout = fl.Layout(
        content=_split(
            "row",
            (3, _split("column", (3, scene), (2, errors))),
            (
                2,
                _split(
                    "column",
                    *([(3, image)] if camera else []),
                    (2, fl.MapPanel(title="map", config=fl.MapConfig())),
                    (2, fl.LogPanel(title="log", config=fl.LogConfig(topic_to_render="/log"))),
                ),
            ),
        )
    )
    return layout.to_json()


def _split(direction: str, *items: tuple[float, object]) -> fl.SplitContainer:
    """A split of (proportion, content) items, side by side (``row``) or stacked (``column``)."""
    return fl.SplitContainer(
        direction=direction,  # type: ignore[arg-type]
        items=[fl.SplitItem(proportion=k, content=c) for k, c in items],  # type: ignore[arg-type]
    )
