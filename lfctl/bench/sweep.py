"""lfctl bench sweep: runs per minute of a sweep with 1 and with N workers (N = usable cores),
on a Dask LocalCluster and on a ``dask scheduler`` with ``dask worker`` processes on
127.0.0.1, against the same runs by :func:`lfctl.sim.runner.run_scenario` in a plain loop.

The runs are CPU-bound: the convoy with truth sensing (FMU stepping, guidance, links; no
rendering), the same scenario at different seeds. A shared machine's speed drifts by tens of
percent over minutes, more than the engine costs, so the cases take turns: each round runs a
block of the plain loop and of each engine with 1 and N workers (a cluster started afresh for
each block), in an order rotated by one case each round; speed-up is the median over the
rounds of ratios within a round, runs/min and start+close medians of the rounds' own figures.
A block's wall time counts from the first submission to the last row (the cluster's start
and close are reported on their own). "Block / loop" is a 1-worker block's wall time over the
loop block's of the same round: blocks a minute apart, so the drift is in it.

The engine's per-run overhead is measured in pairs, on one 1-worker engine kept up: the same
run through the engine (from its submission to its row: dispatch, the run on the worker, the
result back, the row written) and in the plain loop, one right after the other, which one
first alternating; the overhead is the median of the pairs' ratios, seconds apart and so
out of the drift's reach. "Between runs" is the engine's own share within the blocks: a
block's wall time on its workers beyond the runs' own (as each worker timed its run), over
the runs' own.
"""

from __future__ import annotations

import logging
import statistics
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from lfctl.bench.common import print_json, print_table, run_as_script
from lfctl.sim.camera_pool import usable_cores
from lfctl.sim.runner import run_scenario
from lfctl.sweep.engine import SweepResult, local_cluster, run_sweep, scheduler_processes
from lfctl.sweep.spec import SweepPlan, parse_sweep, plan

__all__ = ["main"]

DURATION_S = 200.0  # simulated seconds per run: about 2 s of one core here
ENGINES = ("LocalCluster", "dask scheduler (tcp)")
PAIRS = 10  # pairs of runs per engine for the per-run overhead


def _plan(runs: int, duration_s: float) -> SweepPlan:
    return plan(
        parse_sweep(
            f'name = "bench"\nscenario = "convoy"\nseeds = {runs}\n'
            f'[set]\n"sim.duration_s" = {duration_s}\n"sim.sensing" = "truth"\n'
        )
    )


def _loop(p: SweepPlan) -> float:
    t0 = time.perf_counter()
    for r in p.runs:
        run_scenario(r.config)
    return time.perf_counter() - t0


def _checked(res: SweepResult, engine: str) -> SweepResult:
    if res.failed:
        sys.exit(f"bench sweep: {len(res.failed)} runs failed on {engine}: {res.failed[0]['error']}")
    return res


def _engine(engine: str, workers: int, p: SweepPlan, out: Path) -> tuple[float, float, float]:
    """One block on an engine started for it: (wall time of the runs, start-up and close, the
    runs' own wall times as their workers measured them, summed), s."""
    t0 = time.perf_counter()
    if engine == "LocalCluster":
        res = run_sweep(p, out, workers=workers, plots=False)
    else:
        with scheduler_processes(workers) as address:
            res = run_sweep(p, out, scheduler=address, workers=workers, plots=False)
    rest = time.perf_counter() - t0 - res.wall_s
    _checked(res, engine)
    return res.wall_s, rest, sum(float(r["wall_time_s"]) for r in res.rows)


def _pairs(engine: str, p: SweepPlan, pairs: int, out: Path) -> list[tuple[float, float]]:
    """(through the engine, in the loop) wall times of one run, pair by pair, on an engine with
    one worker kept up (its first run, a warm-up, not counted); which goes first alternates."""
    got: list[tuple[float, float]] = []
    with local_cluster(1) if engine == "LocalCluster" else scheduler_processes(1) as address:
        _checked(run_sweep(p, out / f"pair-{engine.split()[0]}-warm-up", scheduler=address, plots=False), engine)
        for i in range(pairs):
            walls: dict[str, float] = {}
            for side in ("engine", "loop") if i % 2 == 0 else ("loop", "engine"):
                if side == "loop":
                    walls[side] = _loop(p)
                else:
                    folder = out / f"pair-{engine.split()[0]}-{i}"
                    walls[side] = _checked(
                        run_sweep(p, folder, scheduler=address, workers=1, plots=False), engine
                    ).wall_s
            got.append((walls["engine"], walls["loop"]))
    return got


def _median(values: list[float]) -> float:
    return statistics.median(values) if values else float("nan")


def _quartiles(values: list[float]) -> list[float]:
    """First and third quartiles (both the one value, of one)."""
    if len(values) < 2:
        return values * 2
    q = statistics.quantiles(values, n=4, method="inclusive")  # within the data, for few values
    return [q[0], q[2]]


def main(quick: bool = False) -> None:
    """Run the benchmark, print its table and JSON line (``quick``: one short round)."""
    logging.getLogger("distributed").setLevel(logging.ERROR)  # workers starting and stopping
    n = usable_cores()
    rounds, per_worker, pairs = (1, 2, 2) if quick else (3, 4, PAIRS)
    duration = 20.0 if quick else DURATION_S
    one, many = _plan(per_worker, duration), _plan(per_worker * n, duration)
    blocks: dict[tuple[str, int], list[tuple[float, float]]] = {}
    cases: list[tuple[str, int, Callable[[Path], tuple[float, float]]]] = [
        ("plain loop", 1, lambda _: (_loop(one), 0.0, 0.0))
    ]
    for engine in ENGINES:
        for workers in dict.fromkeys((1, n)):
            p = one if workers == 1 else many

            def block(out: Path, e: str = engine, w: int = workers, q: SweepPlan = p) -> tuple[float, float, float]:
                return _engine(e, w, q, out)

            cases.append((engine, workers, block))
    with tempfile.TemporaryDirectory(prefix="lfctl-bench-sweep-") as tmp:
        for r in range(rounds):
            turn = r % len(cases)  # no case always first, or always after the same one
            for engine, workers, block in cases[turn:] + cases[:turn]:
                out = Path(tmp) / f"{r}-{engine.split()[0]}-{workers}"
                blocks.setdefault((engine, workers), []).append(block(out))
        single = _plan(1, duration)
        paired = {engine: _pairs(engine, single, pairs, Path(tmp)) for engine in ENGINES}
    loop = [wall for wall, _, _ in blocks[("plain loop", 1)]]
    results: list[dict[str, Any]] = []
    for (engine, workers), got in blocks.items():
        walls = [wall for wall, _, _ in got]
        runs = per_worker * workers
        row: dict[str, Any] = {
            "engine": engine,
            "workers": workers,
            "runs": runs,
            "rounds": rounds,
            "wall_s": [round(w, 2) for w in walls],
            "runs_per_min": round(60.0 * runs / _median(walls), 1),
            "startup_s": round(_median([s for _, s, _ in got]), 2),
        }
        if engine != "plain loop":
            # the engine's own time: the block's wall time on its workers beyond the runs' own
            # (dispatch, results, idle workers), over the runs' own; the machine's drift moves
            # both alike, so this one holds where the ratio to the loop's block does not
            between = [(w * workers - ran) / ran for w, _, ran in got]
            row["between_runs_pct"] = round(100.0 * _median(between), 1)
        if engine != "plain loop" and workers == 1:
            ratios = [w / base for w, base in zip(walls, loop, strict=True)]
            row["block_over_loop_pct"] = round(100.0 * (_median(ratios) - 1.0), 1)
            row["block_over_loop_pct_rounds"] = [round(100.0 * (x - 1.0), 1) for x in ratios]
            each = [e / base for e, base in paired[engine]]
            row["overhead_pct"] = round(100.0 * (_median(each) - 1.0), 1)
            row["overhead_pct_quartiles"] = [round(100.0 * (q - 1.0), 1) for q in _quartiles(each)]
            row["overhead_ms_per_run"] = round(1000.0 * _median([e - base for e, base in paired[engine]]), 1)
            row["pairs"] = len(each)
        if engine != "plain loop" and workers > 1:
            ones = [w for w, _, _ in blocks[(engine, 1)]]
            # rate with N workers over the rate with 1, round by round
            ups = [(runs / w) / (per_worker / w1) for w, w1 in zip(walls, ones, strict=True)]
            row["speedup"] = round(_median(ups), 2)
            row["speedup_rounds"] = [round(u, 2) for u in ups]
            row["speedup_per_worker"] = round(row["speedup"] / workers, 2)
        results.append(row)
    print(
        f"convoy runs, truth sensing, {duration:g} s simulated each; {n} usable cores; {rounds} rounds, each: "
        f"{per_worker} runs per worker per case, the cases in turn; medians over the rounds. Overhead: "
        f"{pairs} pairs of one run through a 1-worker engine and in the loop, median (quartiles)"
    )
    print_table(
        ("engine", "workers", "runs", "wall s (each round)", "runs/min", "speed-up", "per worker", "block / loop %",
         "overhead %", "ms/run", "between runs %", "start+close s"),
        [
            (r["engine"], r["workers"], r["runs"], " ".join(f"{w:.2f}" for w in r["wall_s"]), r["runs_per_min"],
             r.get("speedup", "-"), r.get("speedup_per_worker", "-"), r.get("block_over_loop_pct", "-"),
             f"{r['overhead_pct']} ({r['overhead_pct_quartiles'][0]} .. {r['overhead_pct_quartiles'][1]})"
             if "overhead_pct" in r else "-",
             r.get("overhead_ms_per_run", "-"), r.get("between_runs_pct", "-"), r["startup_s"])
            for r in results
        ],
    )  # fmt: skip
    print_json("sweep", {"cores": n, "rounds": rounds, "runs_per_worker": per_worker, "pairs": pairs,
                         "duration_s": duration, "cases": results})  # fmt: skip


if __name__ == "__main__":
    run_as_script(main, __doc__)
