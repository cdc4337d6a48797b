"""lfctl bench sweep: runs per minute of a sweep with 1 and with N workers (N = usable cores),
on a Dask LocalCluster and on a ``dask scheduler`` with ``dask worker`` processes on
127.0.0.1, against the same runs by :func:`lfctl.sim.runner.run_scenario` in a plain loop.

The runs are CPU-bound: the convoy with truth sensing (FMU stepping, guidance, links; no
rendering), the same scenario at different seeds. Wall time counts from the first
submission to the last row (cluster start-up is reported on its own); the engine's overhead
is the 1-worker sweep's wall time over the loop's, per run.
"""

from __future__ import annotations

import logging
import sys
import tempfile
import time
from pathlib import Path

from lfctl.bench.common import print_json, print_table
from lfctl.sim.camera_pool import usable_cores
from lfctl.sim.runner import run_scenario
from lfctl.sweep.engine import run_sweep, scheduler_processes
from lfctl.sweep.spec import parse_sweep, plan

__all__ = ["main"]

DURATION_S = 200.0  # simulated seconds per run: about 1.5 s of one core here


def _sweep(runs: int, duration_s: float) -> str:
    return (
        f'name = "bench"\nscenario = "convoy"\nseeds = {runs}\n'
        f'[set]\n"sim.duration_s" = {duration_s}\n"sim.sensing" = "truth"\n'
    )


def main(quick: bool = False) -> None:
    """Run the benchmark, print its table and JSON line (``quick``: fewer, shorter runs)."""
    logging.getLogger("distributed").setLevel(logging.ERROR)  # workers starting and stopping
    n = usable_cores()
    runs = 4 if quick else 12 * n
    duration = 20.0 if quick else DURATION_S
    p = plan(parse_sweep(_sweep(runs, duration)))
    t0 = time.perf_counter()
    for r in p.runs:
        run_scenario(r.config)
    loop_s = time.perf_counter() - t0
    results = [{"engine": "plain loop", "workers": 1, "runs": runs, "wall_s": round(loop_s, 2), "startup_s": 0.0}]
    with tempfile.TemporaryDirectory(prefix="lfctl-bench-sweep-") as tmp:
        for workers in (1, n):
            t0 = time.perf_counter()
            res = run_sweep(p, Path(tmp) / f"local-{workers}", workers=workers, plots=False)
            startup = time.perf_counter() - t0 - res.wall_s
            results.append(
                {"engine": "LocalCluster", "workers": workers, "runs": runs, "wall_s": round(res.wall_s, 2),
                 "startup_s": round(startup, 2)}
            )  # fmt: skip
        for workers in (1, n):
            t0 = time.perf_counter()
            with scheduler_processes(workers) as address:
                up = time.perf_counter() - t0
                res = run_sweep(p, Path(tmp) / f"tcp-{workers}", scheduler=address, workers=workers, plots=False)
            results.append(
                {"engine": "dask scheduler (tcp)", "workers": workers, "runs": runs, "wall_s": round(res.wall_s, 2),
                 "startup_s": round(up, 2)}
            )  # fmt: skip
            if any(r["status"] != "ok" for r in res.rows):
                sys.exit(f"bench sweep: runs failed on {address}")
    for r in results:
        r["runs_per_min"] = round(60.0 * runs / r["wall_s"], 1)
    for engine in ("LocalCluster", "dask scheduler (tcp)"):
        one, many = (r for r in results if r["engine"] == engine)
        many["speedup"] = round(many["runs_per_min"] / one["runs_per_min"], 2)
        many["speedup_per_worker"] = round(many["speedup"] / n, 2)
        one["overhead_pct"] = round(100.0 * (one["wall_s"] - loop_s) / loop_s, 1)
        one["overhead_ms_per_run"] = round(1000.0 * (one["wall_s"] - loop_s) / runs, 1)
    print(f"{runs} runs of the convoy, truth sensing, {duration:g} s simulated each; {n} usable cores")
    print_table(
        ("engine", "workers", "wall s", "runs/min", "speed-up", "per worker", "overhead %", "ms/run", "start-up s"),
        [
            (r["engine"], r["workers"], r["wall_s"], r["runs_per_min"], r.get("speedup", "-"),
             r.get("speedup_per_worker", "-"), r.get("overhead_pct", "-"), r.get("overhead_ms_per_run", "-"),
             r["startup_s"])
            for r in results
        ],
    )  # fmt: skip
    print_json("sweep", {"cores": n, "runs": runs, "duration_s": duration, "cases": results})


if __name__ == "__main__":
    main("--quick" in sys.argv)
