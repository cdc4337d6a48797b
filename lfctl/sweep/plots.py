"""Plots of a sweep: every figure against every swept key that takes more than one value.

One PNG per swept key (and per follower when there are several), a panel per figure: the
mean over the ``ok`` runs at each value of the key with its 95 % confidence interval (as
:func:`lfctl.sweep.results.mean_ci`), one line per combination of the other swept keys'
values while they make at most :data:`MAX_LINES` lines (in the sweep's order), pooled over
the keys after that. Numeric keys are drawn on a number line, others as categories in the
sweep's order.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from lfctl.sweep.results import figure_range, mean_ci
from lfctl.sweep.task import FIGURES

__all__ = ["MAX_LINES", "line_keys", "plot_sweep"]

#: at most this many lines per panel (combinations of the other keys); more are pooled
MAX_LINES = 6
_SLOT = {"range_cmd_m", "bearing_cmd_deg"}  # the slot is an input, not a result


def _key(value: Any) -> Any:
    return json.dumps(value, sort_keys=True) if isinstance(value, (list, dict)) else value


def _numeric(values: Sequence[Any]) -> bool:
    return all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values)


def _file_name(key: str, follower: str | None) -> str:
    slug = re.sub(r"[^A-Za-z0-9_.\-]+", "_", key).strip("_")
    return f"{slug}--{follower}.png" if follower else f"{slug}.png"


def line_keys(rows: Sequence[dict[str, Any]], key: str, keys: Sequence[str]) -> tuple[list[str], list[str]]:
    """Which of the other swept keys get a line each in a plot against ``key``, and which are
    pooled: the others in the sweep's order, each kept while the combinations of the kept
    ones stay within :data:`MAX_LINES`.

    Parameters
    ----------
    rows : sequence of dict
        The runs' rows.
    key : str
        The key on the x axis.
    keys : sequence of str
        The swept keys that vary.
    """
    lines: list[str] = []
    for k in keys:
        if k != key and len({tuple(_key(r.get(o)) for o in [*lines, k]) for r in rows}) <= MAX_LINES:
            lines.append(k)
    return lines, [k for k in keys if k != key and k not in lines]


def plot_sweep(
    plot_dir: Path, rows: Sequence[dict[str, Any]], keys: Sequence[str], followers: Sequence[str]
) -> list[Path]:
    """Draw the plots; returns the files written (none when no key varies or no run finished).

    Parameters
    ----------
    plot_dir : Path
        Where the PNGs go (made if missing).
    rows, keys, followers : sequence
        The runs' rows (dicts), the swept keys and the followers' names, as
        :func:`lfctl.sweep.results.write_tables` takes them.
    """
    from lfctl.data import pyplot

    plt = pyplot()

    ok = [r for r in rows if r.get("status") == "ok"]
    varied = [k for k in keys if len({_key(r.get(k)) for r in rows}) > 1]
    if not ok or not varied:
        return []
    plot_dir.mkdir(parents=True, exist_ok=True)
    made = []
    for key in varied:
        others, pooled = line_keys(ok, key, varied)
        combos = list(dict.fromkeys(tuple(_key(r.get(k)) for k in others) for r in ok))  # in plan order
        series = {c: [r for r in ok if tuple(_key(r.get(k)) for k in others) == c] for c in combos}
        xs_all = list(dict.fromkeys(_key(r.get(key)) for r in ok))
        numeric = _numeric(xs_all)
        if numeric:
            xs_all.sort()
        for follower in followers:
            figures = [
                fig for fig in FIGURES if fig not in _SLOT and any(r.get(f"{follower}.{fig}") is not None for r in ok)
            ]
            if not figures:
                continue
            ncols = min(4, len(figures))
            nrows = math.ceil(len(figures) / ncols)
            fig, axes = plt.subplots(nrows, ncols, figsize=(4.2 * ncols, 3.2 * nrows), squeeze=False)
            for ax, name in zip(axes.flat, figures, strict=False):
                column = f"{follower}.{name}"
                for i, (combo, members) in enumerate(series.items()):
                    px, py, lo, hi = [], [], [], []
                    for j, x in enumerate(xs_all):
                        mean, a, b = mean_ci(
                            (r.get(column) for r in members if _key(r.get(key)) == x), figure_range(column)
                        )
                        if mean is None:
                            continue
                        shift = (i - (len(series) - 1) / 2) * 0.08 if not numeric else 0.0
                        px.append(x if numeric else j + shift)
                        py.append(mean)
                        lo.append(mean - a if a is not None else 0.0)
                        hi.append(b - mean if b is not None else 0.0)
                    label = ", ".join(f"{k} = {v}" for k, v in zip(others, combo, strict=True)) or None
                    style = "-" if numeric else "none"  # categories have no order to draw a line along
                    ax.errorbar(px, py, yerr=[lo, hi], marker="o", ms=4, capsize=3, ls=style, label=label)
                ax.set_title(name, fontsize=10)
                ax.set_xlabel(key, fontsize=9)
                if not numeric:
                    ax.set_xticks(range(len(xs_all)), [str(x) for x in xs_all], fontsize=8)
                    ax.set_xlim(-0.5, len(xs_all) - 0.5)
                ax.grid(alpha=0.3)
            spare = list(axes.flat)[len(figures) :]
            for ax in spare:
                ax.axis("off")
            who = f"{follower}: " if len(followers) > 1 else ""
            note = f" (pooled over {', '.join(pooled)})" if pooled else ""
            fig.suptitle(f"{who}mean and 95 % CI over ok runs against {key}{note}", fontsize=11)
            handles, labels = axes.flat[0].get_legend_handles_labels()
            if others and spare:  # the legend in an empty panel, off the data
                spare[0].legend(handles, labels, loc="center", fontsize=8)
                fig.tight_layout()
            elif others:  # below the panels
                fig.legend(handles, labels, loc="lower center", ncol=min(3, len(labels)), fontsize=8)
                fig.tight_layout(rect=(0, 0.04 * math.ceil(len(labels) / 3), 1, 1))
            else:
                fig.tight_layout()
            made.append(plot_dir / _file_name(key, follower if len(followers) > 1 else None))
            fig.savefig(made[-1], dpi=90)
            plt.close(fig)
    return made
