"""Shared helpers for the benchmark scripts: table printing and the closing JSON line."""

from __future__ import annotations

import argparse
import json
import platform
import sys
from collections.abc import Callable, Sequence

__all__ = ["print_json", "print_table", "run_as_script"]


def print_table(headers: Sequence[str], rows: Sequence[Sequence[object]]) -> None:
    """Print a Markdown table (readable in a terminal and pasteable into notes).

    Parameters
    ----------
    headers : sequence of str
        Column titles.
    rows : sequence of sequences
        One sequence of cells per row, as many as ``headers``; floats get 3 significant
        digits.
    """
    cells = [[str(h) for h in headers], *[[_fmt(c) for c in r] for r in rows]]
    widths = [max(len(r[i]) for r in cells) for i in range(len(headers))]
    print("| " + " | ".join(c.rjust(w) for c, w in zip(cells[0], widths, strict=True)) + " |")
    print("|" + "|".join("-" * (w + 2) for w in widths) + "|")
    for r in cells[1:]:
        print("| " + " | ".join(c.rjust(w) for c, w in zip(r, widths, strict=True)) + " |")


def _fmt(value: object) -> str:
    if isinstance(value, float):
        return f"{value:.3g}" if abs(value) < 1000 else f"{value:.0f}"
    return str(value)


def print_json(benchmark: str, results: object) -> None:
    """The last line of every benchmark: one JSON object (with the machine and Python).

    Parameters
    ----------
    benchmark : str
        The benchmark's name.
    results : object
        Its figures, JSON-serialisable.
    """
    print(
        json.dumps(
            {
                "benchmark": benchmark,
                "machine": platform.machine(),
                "python": platform.python_version(),
                "results": results,
            }
        )
    )


def run_as_script(main: Callable[[bool], None], doc: str | None, argv: Sequence[str] | None = None) -> None:
    """``python -m lfctl.bench.NAME [--quick]``: run a benchmark's ``main`` with the command
    line's ``--quick``; ``--help`` says what it measures, anything else is refused (a
    misspelt option used to run the whole benchmark).

    Parameters
    ----------
    main : callable
        The benchmark's ``main(quick)``.
    doc : str or None
        Its module's docstring (the help's description).
    argv : sequence of str, optional
        The arguments (default ``sys.argv[1:]``).
    """
    spec = getattr(sys.modules["__main__"], "__spec__", None)
    prog = f"python3 -m {spec.name}" if spec is not None else None  # (run as a module, as lfctl bench does)
    parser = argparse.ArgumentParser(prog=prog, description=(doc or "").strip().split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="shorter runs (a smoke check)")
    main(parser.parse_args(argv).quick)
