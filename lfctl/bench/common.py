"""Shared helpers for the benchmark scripts: table printing and the closing JSON line."""

from __future__ import annotations

import json
import platform
from collections.abc import Sequence

__all__ = ["print_json", "print_table"]


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
