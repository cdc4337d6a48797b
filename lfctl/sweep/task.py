"""One run of a sweep, as a Dask worker runs it: the scenario through
:func:`lfctl.sim.runner.run_scenario`, its figures flattened into one row of the results table.

A row holds the run's identity (``run``, ``variant``, ``seed``, ``repetition``), the swept
keys' values, every figure of the run summary per follower (``<follower>.<figure>``, see
:data:`FIGURES`), the leader's mission progress, the wall time, the status (``ok``,
``error``: the run raised; ``crashed``: its worker died, twice), the error and the log's
path relative to the sweep's folder.
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

from lfctl.metrics import FormationMetrics, variation_per_s
from lfctl.record.replay import MIN_VISIBLE
from lfctl.sim.camera_sensor import CameraSample
from lfctl.sim.runner import FollowerTrace, run_scenario
from lfctl.sweep.spec import Run
from lfctl.vision.boxes import iou

__all__ = [
    "FIGURES",
    "FIGURE_RANGES",
    "ID_COLUMNS",
    "LOG_MODES",
    "STATUS_COLUMNS",
    "TrackScore",
    "execute",
    "failed_row",
    "log_name",
]

#: the row's identity
ID_COLUMNS = ("run", "variant", "seed", "repetition")
#: after the figures: how the run went
STATUS_COLUMNS = ("waypoints_reached", "sim_time_s", "wall_time_s", "status", "error", "log_path")
#: each follower's figures (column ``<follower>.<figure>``); the slot first, then the results
FIGURES = (
    "range_cmd_m",  # the slot: commanded range, m
    "bearing_cmd_deg",  # and bearing, deg
    "range_err_rms_m",  # after the settling time (lfctl.metrics.SETTLE_S)
    "range_err_max_m",
    "bearing_err_rms_deg",
    "bearing_err_max_deg",
    "min_separation_m",  # closest approach to any vehicle over the run
    "tracking_s",  # seconds in each track state
    "occluded_s",
    "lost_s",
    "control_effort_rad",  # |yaw-rate command| integrated over the run
    "chattering_per_s",  # yaw-rate command sign changes per second
    "speed_cmd_variation_mps2",  # the speed command's absolute changes summed, per second (the range law's chattering)
    "path_err_rms_m",  # off the target's path, less the slot's sideways offset (corner cutting), after settling
    "path_err_max_m",
    "track_success",  # camera: share of frames showing half the banner or more whose window has IoU >= 0.5
    "target_in_view",  # camera: share of frames with the target's banner in the picture
)
#: what each figure can be: (lowest, highest); a confidence interval is kept within it
FIGURE_RANGES = {name: (0.0, math.inf) for name in FIGURES} | {
    "bearing_cmd_deg": (-180.0, 180.0),
    "track_success": (0.0, 1.0),
    "target_in_view": (0.0, 1.0),
}
#: --logs: keep no log, the logs of failed runs (every run is recorded), or every log
LOG_MODES = ("none", "failed", "all")


class TrackScore:
    """Scores one follower's camera against the renderer's truth, frame by frame: as
    ``lfctl replay`` and the vision benchmark do (IoU >= 0.5 over frames that show at least
    half the banner), and how often the target was in the picture at all."""

    def __init__(self) -> None:
        self.frames = 0
        self.in_view = 0
        self.scored = 0
        self.hits = 0

    def add(self, sample: CameraSample) -> None:
        """Score one camera tick.

        Parameters
        ----------
        sample : CameraSample
            The tick's track and truth.
        """
        truth = sample.truth
        self.frames += 1
        self.in_view += bool(truth.in_view)
        if truth.bbox is not None and truth.visible_fraction >= MIN_VISIBLE:
            self.scored += 1
            track = sample.track.bbox if sample.track is not None else None
            self.hits += iou(track, truth.bbox) >= 0.5

    @property
    def success(self) -> float | None:
        """Share of scored frames tracked (None when no frame was scored)."""
        return self.hits / self.scored if self.scored else None

    @property
    def view(self) -> float | None:
        """Share of frames with the target in the picture (None without frames)."""
        return self.in_view / self.frames if self.frames else None


def log_name(run: int) -> str:
    """A run's log, relative to the sweep's folder.

    Parameters
    ----------
    run : int
        The run's number.
    """
    return f"logs/run-{run:05d}.mcap"


def _figures(m: FormationMetrics, trace: FollowerTrace, step_s: float, score: TrackScore | None) -> dict[str, Any]:
    def deg(rad: float | None) -> float | None:
        return None if rad is None else math.degrees(rad)

    st = m.time_in_state_s
    values = (
        m.range_cmd_m,
        math.degrees(m.bearing_cmd_rad),
        m.range_err_rms_m,
        m.range_err_max_m,
        deg(m.bearing_err_rms_rad),
        deg(m.bearing_err_max_rad),
        m.min_separation_m,
        st["tracking"],
        st["occluded"],
        st["lost"],
        m.control_effort_rad,
        m.chattering_per_s,
        variation_per_s(trace.speed_cmd_mps, step_s),
        m.path_err_rms_m,
        m.path_err_max_m,
        score.success if score is not None else None,
        score.view if score is not None else None,
    )
    return {f"{m.name}.{k}": v for k, v in zip(FIGURES, values, strict=True)}


def _identity(run: Run) -> dict[str, Any]:
    """The row's first columns: the run's identity and its swept values."""
    row: dict[str, Any] = dict(zip(ID_COLUMNS, (run.run, run.variant, run.seed, run.repetition), strict=True))
    row.update(run.values)
    return row


def failed_row(
    run: Run, status: str, error: str, log_path: str = "", wall_time_s: float | None = None
) -> dict[str, Any]:
    """The row of a run without figures.

    Parameters
    ----------
    run : Run
        The run.
    status : str
        ``"error"`` (it raised) or ``"crashed"`` (its worker died).
    error : str
        Why, one line.
    log_path : str
        Its log, relative to the sweep's folder ("" for none).
    wall_time_s : float, optional
        How long it ran before it failed, s.
    """
    row = _identity(run)
    row.update(
        waypoints_reached=None, sim_time_s=None, wall_time_s=wall_time_s, status=status, error=error, log_path=log_path
    )
    return row


def execute(run: Run, out_dir: str, logs: str = "none") -> dict[str, Any]:
    """Run one sweep run and return its row; a run that raises gives a row with status
    ``error`` and the exception, never an exception.

    Parameters
    ----------
    run : Run
        The run (its scenario, seed and swept values).
    out_dir : str
        The sweep's folder as the worker sees it: logs go to ``<out_dir>/logs/``.
    logs : "none", "failed" or "all"
        Which logs to keep (``failed`` records every run and deletes the logs of runs that
        succeed).
    """
    import cv2

    cv2.setNumThreads(1)  # one run, one core: OpenCV's own threads would fight the other workers
    if logs not in LOG_MODES:
        raise ValueError(f"logs must be one of {LOG_MODES}, got {logs!r}")
    rel = log_name(run.run) if logs != "none" else ""
    path = Path(out_dir) / rel if rel else None
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        # the run's log is named by its number: an earlier attempt's (a worker killed under it,
        # a run cancelled that went on to its end) is not this run's, and the name is its
        path.unlink(missing_ok=True)
    camera = run.config.sim.sensing == "camera"
    scores = {f.name: TrackScore() for f in run.config.followers} if camera else {}

    def on_frame(follower: str, sample: CameraSample) -> None:
        scores[follower].add(sample)

    t0 = time.perf_counter()
    try:
        # (the scenario's warnings: said by the sweep as it started, once for all its runs)
        report = run_scenario(run.config, record_to=path, on_frame=on_frame if camera else None, warn=False)
    except Exception as exc:  # the row says what went wrong; the sweep goes on
        wall = time.perf_counter() - t0
        kept = rel if path is not None and path.exists() else ""
        return failed_row(run, "error", f"{type(exc).__name__}: {exc}".splitlines()[0], kept, wall)
    wall = time.perf_counter() - t0
    if report.log_path is not None and path is not None:
        # the recorder's own name (another attempt may have taken ours meanwhile: then -2)
        rel = report.log_path.relative_to(out_dir).as_posix()
        if logs == "failed":
            report.log_path.unlink(missing_ok=True)
            rel = ""
    row = _identity(run)
    step_s = 1.0 / run.config.sim.guidance_rate_hz
    for m, trace in zip(report.metrics, report.traces, strict=True):
        row.update(_figures(m, trace, step_s, scores.get(m.name)))
    row.update(
        waypoints_reached=report.n_reached,  # distinct, of the mission last flown, as the summary
        sim_time_s=report.result.sim_time_s,
        wall_time_s=wall,
        status="ok",
        error="",
        log_path=rel,
    )
    return row
