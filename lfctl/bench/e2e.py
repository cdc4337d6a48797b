"""lfctl bench e2e: the whole product, lockstep, as `lfctl sim` runs it.

Camera sensing with the full tracker at 30 Hz, MAVLink in the loop, recording with 30 Hz
images as the scenario says (H.264 by default): real-time factor for leader + 1 (examples/convoy.toml) pinned to one core
and on every core, and leader + 4 (examples/column5.toml with camera sensing) on every
core, and where the time goes: physics (FMU stepping), render, vision (tracker + pose),
guidance, link (MAVLink endpoints), recording (image encoding, poses, messages), other
(the master's own loop). Each stage is timed by the wall clock (perf_counter): CPU time
only while nothing else shares the cores. Render, vision and encoding are summed over the
camera processes (sim.camera_workers), so with workers the split adds up to more than
the wall time. Leader + 1 on one core runs with the scenario's (default, fast) renderer
and recording, and without recording the camera's frames (what the H.264 video costs the
run), the two in turn for three rounds (the table shows each one's median round), and with
``scene.realism = "on"``; a last section measures what each realistic effect costs
per frame (:mod:`lfctl.bench.render_cost`).

Each run's real-time factor is given twice: by the wall clock (the goal's measure) and by the
CPU time the run spent, in this process and the processes it started (:func:`cpu_seconds`).
On one core the two agree when nothing else takes the core; the wall-clock factor falls below
the CPU one by the time the core went elsewhere. Neither tells a slow phase of the host's CPU
(the same code's CPU seconds vary with it): the render-cost table's realism "off" row, the
flat renderer's ms a frame in the same run, is the figure to read them against.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import resource
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import cv2

from lfctl.bench import render_cost
from lfctl.bench.common import print_json, print_table, run_as_script
from lfctl.config import load_config
from lfctl.data import examples_dir
from lfctl.sim.runner import run_scenario

__all__ = ["main"]


@contextlib.contextmanager
def one_core() -> Iterator[None]:
    """Pin this process (and OpenCV) to one core, as `taskset -c N` would."""
    cpus = os.sched_getaffinity(0)
    threads = cv2.getNumThreads()
    os.sched_setaffinity(0, {min(cpus)})
    cv2.setNumThreads(1)
    try:
        yield
    finally:
        os.sched_setaffinity(0, cpus)
        cv2.setNumThreads(threads)


def cpu_seconds() -> float:
    """CPU seconds (user + system) so far of this process, all its threads, and the child
    processes it started that have ended (camera workers, an FMU's own process)."""
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + children.ru_utime + children.ru_stime


def measure(
    name: str, duration: float, tmp: str, pinned: bool = False, realism: str | None = None, images: bool = True
) -> dict:
    """One camera run of ``examples/<name>.toml`` for ``duration`` s, recorded into ``tmp``
    (``images``: with the camera's frames, as the defaults record them): its wall time,
    real-time factor and split by stage."""
    cfg = load_config(examples_dir() / f"{name}.toml")
    cfg = dataclasses.replace(
        cfg,
        sim=dataclasses.replace(cfg.sim, sensing="camera", duration_s=duration),
        recording=dataclasses.replace(cfg.recording, dir=tmp, images=images),
    )
    if realism is not None:
        cfg = dataclasses.replace(cfg, scene=dataclasses.replace(cfg.scene, realism=realism))
    label = name if realism is None else f"{name} (realism {realism})"
    if not images:
        label += " (no image recording)"
    with one_core() if pinned else contextlib.nullcontext():
        cores = len(os.sched_getaffinity(0))
        t0, cpu0 = time.perf_counter(), cpu_seconds()
        report = run_scenario(cfg, record_to=Path(tmp) / f"{name}.mcap")
        wall = time.perf_counter() - t0
        cpu = cpu_seconds() - cpu0
    extra = report.result.extra
    tasks = extra["task_time_s"]
    # render, vision and image encoding are summed over the camera processes (CPU seconds);
    # the rest runs in the main process
    split = {
        "physics": tasks.get("physics", 0.0),
        "render": extra["render_s"],
        "vision": extra["vision_s"],
        "guidance": tasks.get("guidance", 0.0),
        "link": tasks.get("link", 0.0),
        "recording": tasks.get("record", 0.0) + extra["record_camera_s"] + extra["encode_s"],
    }
    main_process = sum(split.values()) - extra["render_s"] - extra["vision_s"] - extra["encode_s"]
    split["other"] = max(0.0, wall - main_process - (tasks.get("camera", 0.0) - extra["record_camera_s"]))
    return {
        "scenario": label,
        "realism": cfg.scene.realism,
        "followers": len(cfg.followers),
        "sim_s": duration,
        "wall_s": wall,
        "real_time_factor": duration / wall,
        # CPU seconds spent, against the simulated ones: what the run costs whatever else the
        # machine does (on one core, the wall-clock factor falls below it by the time the core
        # went to other programs or the host)
        "cpu_s": cpu,
        "cpu_real_time_factor": duration / cpu if cpu > 0 else float("inf"),
        "camera_workers": extra["camera_workers"],
        "cores": cores,
        "split_s": split,
    }


def _median_run(runs: list[dict]) -> dict:
    """The run of median real-time factor (the lower middle one of an even count)."""
    return sorted(runs, key=lambda r: r["real_time_factor"])[(len(runs) - 1) // 2]


def main(quick: bool = False) -> None:
    """Run the benchmark, print its table and JSON line (``quick``: shorter runs)."""
    duration = 10.0 if quick else 40.0
    rounds = 1 if quick else 3
    with tempfile.TemporaryDirectory() as tmp:
        # leader + 1 on one core, with the default recording and without recording the
        # camera's frames (what the video costs), in turn for a few rounds: this kind of
        # machine drifts by tens of percent over minutes, so one run is one sample of it
        pairs = [
            (measure("convoy", duration, tmp, pinned=True), measure("convoy", duration, tmp, pinned=True, images=False))
            for _ in range(rounds)
        ]
        runs = [
            _median_run([a for a, _ in pairs]),
            measure("convoy", duration, tmp),
            measure("column5", duration, tmp),
            # the realistic camera (not the default): what it costs the whole product
            measure("convoy", duration, tmp, pinned=True, realism="on"),
            _median_run([b for _, b in pairs]),
        ]
    rows = []
    for r in runs:
        s = r["split_s"]
        total = sum(s.values())
        rows.append(
            (
                r["scenario"],
                r["followers"],
                r["cores"],
                r["camera_workers"],
                round(r["real_time_factor"], 2),
                round(r["cpu_real_time_factor"], 2),
                *(
                    f"{100 * s[k] / total:.0f} %"
                    for k in ("physics", "render", "vision", "guidance", "link", "recording", "other")
                ),
            )
        )
    print_table(
        (
            "scenario",
            "followers",
            "cores",
            "camera workers",
            "RTF",
            "RTF by CPU time",
            "physics",
            "render",
            "vision",
            "guidance",
            "link",
            "recording",
            "other",
        ),
        rows,
    )
    one, one_all, four, real, bare = runs  # one and bare: the median rounds
    # cost: the seconds spent in every stage (summed over the processes) per simulated second
    # per follower. The stages are timed by the wall clock (perf_counter), so this is CPU time
    # only while nothing else shares the cores: another program's load counts in it
    per_follower = [sum(r["split_s"].values()) / r["sim_s"] / r["followers"] for r in (one_all, four)]
    print(
        f"\nstage seconds (wall clock in each stage, over the processes) per simulated second per follower: {per_follower[0]:.3f} (1 follower), {per_follower[1]:.3f} (4 followers): growth is {'linear' if per_follower[1] <= 1.25 * per_follower[0] else 'super-linear'}"
    )
    print(
        f"recording the camera's frames ({load_config(examples_dir() / 'convoy.toml').recording.image_format}, "
        f"the default) costs leader + 1 on one core {100 * (1 - bare['wall_s'] / one['wall_s']):.0f} % of its wall time: "
        f"{one['real_time_factor']:.2f}x real time with it, {bare['real_time_factor']:.2f}x without"
    )
    for label, k in (("with", 0), ("without", 1)):
        rtfs = " / ".join(f"{pair[k]['real_time_factor']:.2f}" for pair in pairs)
        cpus = " / ".join(f"{pair[k]['cpu_real_time_factor']:.2f}" for pair in pairs)
        print(
            f"leader + 1 on one core {label} image recording, {rounds} round(s) in turn: {rtfs}x real time "
            f"(by CPU time {cpus}x)"
        )
    biggest = max(one["split_s"], key=one["split_s"].get)
    print(f"largest stage for leader + 1: {biggest}")
    print(f"load average (1 min) at the end of the runs: {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    print("\nWhat each realistic effect of the renderer costs (lfctl.bench.render_cost):\n")
    costs = render_cost.effect_costs(frames=60 if quick else 240)
    render_cost.print_costs(costs)
    print_json(
        "e2e",
        {
            "leader_plus_1_one_core_real_time_factor": round(one["real_time_factor"], 3),
            "leader_plus_1_one_core_cpu_real_time_factor": round(one["cpu_real_time_factor"], 3),
            "leader_plus_1_one_core_realism_on_real_time_factor": round(real["real_time_factor"], 3),
            "leader_plus_1_one_core_no_image_recording_real_time_factor": round(bare["real_time_factor"], 3),
            "leader_plus_1_one_core_rounds": [
                {
                    "with_images": round(a["real_time_factor"], 3),
                    "without_images": round(b["real_time_factor"], 3),
                    "with_images_by_cpu": round(a["cpu_real_time_factor"], 3),
                    "without_images_by_cpu": round(b["cpu_real_time_factor"], 3),
                }
                for a, b in pairs
            ],
            "render_cost": costs,
            "leader_plus_1_real_time_factor": round(one_all["real_time_factor"], 3),
            "leader_plus_4_real_time_factor": round(four["real_time_factor"], 3),
            "per_follower_cost_ratio_4_over_1": round(per_follower[1] / per_follower[0], 3),
            "runs": [{**r, "split_s": {k: round(v, 3) for k, v in r["split_s"].items()}} for r in runs],
        },
    )


if __name__ == "__main__":
    run_as_script(main, __doc__)
