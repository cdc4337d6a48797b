"""The Foxglove layout lfctl ships (``examples/foxglove-layout.json``), built with
foxglove-sdk's layout types from the topic names the recorder uses.

3D (the ``map`` frame, east-north-up, following the leader; slots, vehicles and mission
from ``/scene``, ``/scene/vehicles`` and ``/scene/mission``, the camera frames from
``/tf``), Map (every ``/<vehicle>/fix``), the follower's camera with its annotations, plots
of its range and bearing error (against the truth in a simulation, its own estimate on a
rover), and the Log.
It opens a live ``lfctl sim --live`` as well as a recorded log.
"""

from __future__ import annotations

import foxglove.layouts as fl

from lfctl.record.writer import MAP_FRAME, MISSION_TOPIC, SCENE_TOPIC, VEHICLES_TOPIC, image_topic

__all__ = ["layout_json"]


def layout_json(
    follower: str | None = "follower1",
    leader: str = "leader",
    image_format: str = "h264",
    camera: bool = True,
    scene: bool = True,
) -> str:
    """The layout as JSON (Foxglove: Layout, Import from file).

    Parameters
    ----------
    follower : str or None
        Whose camera and errors it shows; None (a run with no follower): neither, whose
        topics would never come.
    leader : str
        The vehicle the 3D view follows.
    image_format : str
        ``h264`` (``/<follower>/camera/video``) or ``jpeg`` (``.../image/compressed``).
    camera : bool
        The run has a camera (camera sensing): without one there is no camera panel, whose
        topics would never come.
    scene : bool
        The run publishes the 3D scene (``/scene``, ``/scene/vehicles``, ``/scene/mission``:
        the simulator's slots, vehicles and mission) and its controller's errors are against
        the truth; without it (``lfctl follow``) the 3D view shows ``/tf``'s frames only and
        the errors are the follower's estimate.
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
    view3d = fl.ThreeDeePanel(
        title="formation",
        config=fl.ThreeDeeConfig(
            follow_tf=leader,
            fixed_frame=MAP_FRAME,
            follow_mode="follow-position",
            enu_frame_id=MAP_FRAME,
            topics=(
                {
                    t: fl.BaseRendererSceneUpdateTopicSettings(visible=True)
                    for t in (SCENE_TOPIC, VEHICLES_TOPIC, MISSION_TOPIC)
                }
                if scene
                else {}
            ),
        ),
    )
    errors = fl.PlotPanel(
        # (a simulation's are against the truth; a real rover's are its own estimate)
        title=f"{follower} formation errors ({'truth' if scene else 'estimate'})",
        config=fl.PlotConfig(
            paths=[
                fl.PlotSeries(value=f"/{follower}/controller.range_error_m", label="range error (m)", enabled=True),
                fl.PlotSeries(
                    value=f"/{follower}/controller.bearing_error_deg", label="bearing error (deg)", enabled=True
                ),
            ],
            show_legend=True,
        ),
    )
    layout = fl.Layout(
        content=_split(
            "row",
            (3, _split("column", (3, view3d), (2, errors)) if follower is not None else view3d),
            (
                2,
                _split(
                    "column",
                    *([(3, image)] if camera and follower is not None else []),
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
