"""The benchmarks `lfctl bench` runs. Each module has ``main(quick)``, prints a Markdown
table and ends with one JSON line, and measures against a baseline in the same run; run one
with ``python -m lfctl.bench.<name>`` or ``lfctl bench <name>``."""

from __future__ import annotations

import importlib
import json
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

__all__ = ["NAMES", "BenchOutcome", "run_all", "run_one"]

#: every benchmark, in the order `lfctl bench` runs them
NAMES = ("cosim", "vision", "formation", "link", "record", "e2e", "sweep")


@dataclass(frozen=True)
class BenchOutcome:
    """One benchmark run as a child process: its table, its JSON result or why it failed."""

    name: str  # the benchmark (one of NAMES)
    table: list[str]  # what it printed before its JSON line (its Markdown table)
    result: dict[str, object] | None  # its JSON line, parsed; None when it failed
    error: str = ""  # why it failed ("" when it did not)


def run_one(name: str, quick: bool = False, fuzz: bool = False, soak_s: float | None = None) -> None:
    """Run one benchmark in this process (its output is the result).

    Parameters
    ----------
    name : str
        One of :data:`NAMES`.
    quick : bool
        Shorter runs, for a smoke check.
    fuzz : bool
        ``link`` only: the fuzz and soak benchmark (:mod:`lfctl.bench.link_fuzz`) instead.
    soak_s : float, optional
        With ``fuzz``: the soak's length, s.
    """
    if fuzz:
        from lfctl.bench import link_fuzz

        link_fuzz.main(quick, soak_s)
        return
    importlib.import_module(f"lfctl.bench.{name}").main(quick)


def _run_child(name: str, quick: bool) -> BenchOutcome:
    cmd = [sys.executable, "-m", f"lfctl.bench.{name}", *(["--quick"] if quick else [])]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    print(proc.stdout, end="", flush=True)
    lines = proc.stdout.strip().splitlines()
    if proc.returncode != 0 or not lines or not lines[-1].startswith("{"):
        err = proc.stderr.strip()[-2000:] or f"exit {proc.returncode}, no JSON line"
        print(err, file=sys.stderr)
        return BenchOutcome(name, lines, None, f"exit {proc.returncode}: {err.splitlines()[-1] if err else ''}")
    return BenchOutcome(name, lines[:-1], json.loads(lines[-1]))


def run_all(names: tuple[str, ...] = NAMES, quick: bool = False, out_dir: Path = Path()) -> list[BenchOutcome]:
    """Run benchmarks one by one, each in its own process, and write ``bench-results.md`` and
    ``bench-results.json`` in ``out_dir``.

    Parameters
    ----------
    names : tuple of str
        Which benchmarks.
    quick : bool
        Shorter runs.
    out_dir : Path
        Where the result files go.
    """
    outcomes = []
    for name in names:
        print(f"== lfctl bench {name}", flush=True)
        outcomes.append(_run_child(name, quick))
    md = ["# lfctl bench results", ""]
    for o in outcomes:
        md += [f"## {o.name}", "", *(o.table if o.result is not None else [f"FAILED ({o.error})"]), ""]
    (out_dir / "bench-results.md").write_text("\n".join(md) + "\n")
    results = {o.name: o.result for o in outcomes if o.result is not None}
    (out_dir / "bench-results.json").write_text(json.dumps(results, indent=1) + "\n")
    return outcomes
