"""Sweeps: many runs of one scenario with keys varied, on a Dask cluster (`lfctl sweep`).

A sweep file (:mod:`lfctl.sweep.spec`) names a base scenario, the keys every run changes, grid
axes and random samples over any scenario key by dotted path, seeds and repetitions. Every
variant is built and validated before anything runs (:func:`plan`); :func:`run_sweep` runs
them on a Dask ``LocalCluster`` or a running scheduler (:mod:`lfctl.sweep.engine`), one row
per run (:mod:`lfctl.sweep.task`); :mod:`lfctl.sweep.results` writes the table (Parquet and
CSV), the per-variant summary with 95 % confidence intervals, and the plots.
"""

from __future__ import annotations

from lfctl.sweep.engine import SweepProgress, SweepResult, local_cluster, run_sweep, scheduler_processes
from lfctl.sweep.results import SweepSummary, read_rows, report
from lfctl.sweep.spec import Run, SweepPlan, SweepSpec, Variant, load_sweep, parse_sweep, plan, set_key, with_keys

__all__ = [
    "Run",
    "SweepPlan",
    "SweepProgress",
    "SweepResult",
    "SweepSpec",
    "SweepSummary",
    "Variant",
    "load_sweep",
    "local_cluster",
    "parse_sweep",
    "plan",
    "read_rows",
    "report",
    "run_sweep",
    "scheduler_processes",
    "set_key",
    "with_keys",
]
