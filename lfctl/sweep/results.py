"""A sweep's folder: what it is (``sweep.json``), its runs as they finish (``runs.jsonl``),
the results table (``runs.parquet``, ``runs.csv``: one row per run), the summary per variant
with mean and 95 % confidence interval (``summary.parquet``, ``summary.csv``, ``summary.md``)
and the plots (``plots/``). :func:`report` rebuilds the summary and plots from the table
(``lfctl sweep report DIR``).

The interval is Student's t on the runs that finished (``ok``) of each variant: mean +-
t(0.975, n - 1) s / sqrt(n), cut to what the figure can be (a share within 0-1, times and
errors not below 0). It needs two runs; with one the bounds are empty.
"""

from __future__ import annotations

import json
import logging
import math
import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.csv as pacsv
import pyarrow.parquet as pq

from lfctl.checks import write_whole
from lfctl.errors import ConfigError
from lfctl.metrics import SETTLE_S
from lfctl.sweep.task import FIGURE_RANGES, FIGURES, ID_COLUMNS, STATUS_COLUMNS

log = logging.getLogger(__name__)

__all__ = [
    "HEADLINE",
    "JOURNAL",
    "META",
    "SweepSummary",
    "append_row",
    "figure_range",
    "mean_ci",
    "metric_columns",
    "read_journal",
    "read_meta",
    "read_rows",
    "report",
    "summarise",
    "summary_markdown",
    "write_meta",
    "write_tables",
]

#: what the sweep is: name, plan digest, code, keys, followers, runs planned
META = "sweep.json"
#: one JSON row per finished run, appended as runs finish (what ``--resume`` reads)
JOURNAL = "runs.jsonl"
#: the figures the printed summary shows per follower (all of them are in summary.csv)
HEADLINE = ("range_err_rms_m", "bearing_err_rms_deg", "lost_s", "chattering_per_s", "track_success")
#: of them, those a run has only after the settling time, and only with camera sensing
ERROR_FIGURES = frozenset({"range_err_rms_m", "bearing_err_rms_deg"})
CAMERA_FIGURES = frozenset({"track_success"})
#: the columns besides the followers' figures that hold a number (or nothing)
NUMBER_COLUMNS = ("waypoints_reached", "sim_time_s", "wall_time_s")
#: of them, those that count (a whole number): int64 in every table, even one where no run has one
WHOLE_COLUMNS = frozenset({"waypoints_reached"})
#: the largest whole number a figure may be (what a table's 64-bit integer column holds)
MAX_WHOLE = 2**63 - 1
#: the journal lines skipped already said, by file (a resume reads the journal more than once)
_said_skipped: set[tuple[str, tuple[int, ...]]] = set()


@dataclass(frozen=True)
class SweepSummary:
    """The summary of a sweep's rows: one row per variant, its Markdown, the files written."""

    rows: list[dict[str, Any]]  # per variant: keys, runs, ok, failed, <metric>.mean / .ci95_lo / .ci95_hi / .n
    markdown: str  # the headline figures as a Markdown table
    files: list[Path]  # summary tables and plots written


def write_meta(out_dir: Path, meta: dict[str, Any]) -> None:
    """Write ``sweep.json``.

    Parameters
    ----------
    out_dir : Path
        The sweep's folder.
    meta : dict
        ``name``, ``digest``, ``code``, ``keys``, ``followers``, ``runs`` and anything else
        JSON can hold.
    """
    with write_whole(out_dir / META) as tmp:
        tmp.write_text(json.dumps(meta, indent=1, default=str) + "\n")


def read_meta(out_dir: Path) -> dict[str, Any]:
    """Read ``sweep.json``.

    Parameters
    ----------
    out_dir : Path
        The sweep's folder.

    Raises
    ------
    ConfigError
        The folder holds no sweep (or a damaged ``sweep.json``).
    """
    if not Path(out_dir).is_dir():
        raise ConfigError(f"{out_dir}: {'not a folder' if Path(out_dir).exists() else 'no such folder'}")
    try:
        meta = json.loads((out_dir / META).read_text())
    except FileNotFoundError:
        raise ConfigError(f"{out_dir} holds no sweep (no {META})") from None
    except (OSError, ValueError) as exc:
        raise ConfigError(f"{out_dir / META}: cannot read it: {exc}") from None
    if not isinstance(meta, dict):
        raise ConfigError(f"{out_dir / META}: not a sweep's description (a JSON object), got {type(meta).__name__}")
    for key in ("keys", "followers"):
        value = meta.get(key, [])
        if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
            raise ConfigError(f"{out_dir / META}: {key!r} must be a list of names, got {value!r}")
    return meta


def append_row(out_dir: Path, row: dict[str, Any]) -> None:
    """Append one finished run to the journal (``runs.jsonl``), flushed at once.

    Parameters
    ----------
    out_dir : Path
        The sweep's folder.
    row : dict
        The run's row.
    """
    path = out_dir / JOURNAL
    with open(path, "a+b") as f:
        # a last line a crash cut short is ended first: the row goes on a line of its own (the
        # torn one stays, and reading skips it), not onto the fragment, where both would be lost
        torn = False
        if f.seek(0, os.SEEK_END) > 0:
            f.seek(-1, os.SEEK_END)
            torn = f.read(1) != b"\n"
        f.write((("\n" if torn else "") + json.dumps(row, default=str) + "\n").encode("utf-8"))


def read_journal(out_dir: Path) -> list[dict[str, Any]]:
    """The rows in the journal, one per run (the last one written wins), by run number.
    A line that is not JSON (cut short by a crash: a resume goes on after it, on a line of its
    own) is skipped, and said (a warning naming it) unless it is the last; a JSON line that is
    not a run's row, or whose figures are not numbers, is a ConfigError naming the line and
    the column (nothing of it reaches the results table).

    Parameters
    ----------
    out_dir : Path
        The sweep's folder.
    """
    path = out_dir / JOURNAL
    if not path.exists():
        return []
    rows: dict[int, dict[str, Any]] = {}
    lines = path.read_bytes().splitlines()
    skipped = []
    for k, raw in enumerate(lines):
        if not raw.strip():
            continue
        try:
            row = json.loads(raw.decode("utf-8"))
        except RecursionError:
            raise ConfigError(f"{path}, line {k + 1}: nested too deeply to be a run's row") from None
        except ValueError:  # (a UnicodeDecodeError too)
            if k < len(lines) - 1:
                skipped.append(k + 1)
            continue  # a row cut short by a crash (a resume appends after it): its run is run again
        fields = [row.get(f) for f in ("run", "variant", "status")] if isinstance(row, dict) else [None] * 3
        run, variant, status = fields
        if not all(isinstance(n, int) and not isinstance(n, bool) and n >= 0 for n in (run, variant)) or not (
            isinstance(status, str)
        ):
            raise ConfigError(
                f"{path}, line {k + 1}: not a run's row (run and variant numbers and a status; got "
                f"run {_shown(run)}, variant {_shown(variant)}, status {_shown(status)})"
            )
        check_numbers(row, f"{path}, line {k + 1}")
        rows[run] = row
    if skipped and (str(path), tuple(skipped)) not in _said_skipped:
        _said_skipped.add((str(path), tuple(skipped)))
        shown = ", ".join(map(str, skipped[:10])) + (f" and {len(skipped) - 10} more" if len(skipped) > 10 else "")
        log.warning(
            "%s: line%s %s not JSON, skipped (cut short by a crash, or damaged: a run with no other row is run "
            "again on --resume)",
            path,
            "s" if len(skipped) > 1 else "",
            shown + (" are" if len(skipped) > 1 else " is"),
        )
    return [rows[k] for k in sorted(rows)]


def _shown(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def is_number_column(column: str) -> bool:
    """True for a column that holds a number or nothing: a follower's figure
    (``<follower>.<figure>``, a follower's name holds no dot) or one of :data:`NUMBER_COLUMNS`.

    Parameters
    ----------
    column : str
        The column's name.
    """
    head, dot, figure = column.rpartition(".")
    return column in NUMBER_COLUMNS or (bool(dot) and "." not in head and figure in FIGURES)


def check_numbers(row: dict[str, Any], where: str) -> None:
    """Each figure of a run's row a number or null (a hand-edited journal's text, Boolean or
    whole number past 64 bits is a ConfigError naming ``where`` and the column).

    Parameters
    ----------
    row : dict
        The row.
    where : str
        The row's place, for the message (the journal's line).
    """
    for column, value in row.items():
        if value is None or not isinstance(column, str) or not is_number_column(column):
            continue
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(f"{where}: {column} must be a number or null, got {_shown(value)}")
        if isinstance(value, int) and abs(value) > MAX_WHOLE:
            raise ConfigError(
                f"{where}: {column} must be a number or null, got a whole number of {len(str(abs(value)))} digits "
                f"(past {MAX_WHOLE})"
            )


def metric_columns(followers: Sequence[str]) -> list[str]:
    """Every figure column of a sweep with these followers, in table order.

    Parameters
    ----------
    followers : sequence of str
        The followers' names.
    """
    return [f"{f}.{fig}" for f in followers for fig in FIGURES]


def _cell(value: Any) -> Any:
    """A table cell: arrays and tables as JSON text, the rest as is."""
    return json.dumps(value) if isinstance(value, (list, dict, tuple)) else value


def _column(values: list[Any], empty: pa.DataType | None = None) -> pa.Array:
    """One column, numbers widened to float when mixed with floats, anything else mixed as text;
    of type ``empty`` (default float64) when no value is present."""
    present = [v for v in values if v is not None]
    kinds = {type(v) for v in present}
    if kinds <= {int, float} and float in kinds:
        return pa.array([None if v is None else float(v) for v in values], pa.float64())
    if len(kinds) > 1:
        return pa.array([None if v is None else str(v) for v in values], pa.string())
    if not present:
        return pa.array(values, empty or pa.float64())
    return pa.array(values)


def _table(rows: Sequence[dict[str, Any]], columns: Sequence[str]) -> pa.Table:
    # (a count stays int64 when no run has one, every run failed: sweeps' tables concatenate)
    return pa.table(
        {c: _column([_cell(r.get(c)) for r in rows], pa.int64() if c in WHOLE_COLUMNS else None) for c in columns}
    )


def write_tables(
    out_dir: Path, rows: Sequence[dict[str, Any]], keys: Sequence[str], followers: Sequence[str]
) -> list[Path]:
    """Write the results table, one row per run by run number: ``runs.parquet`` and
    ``runs.csv``. Columns: the identity, the swept keys, every follower's figures, then
    ``waypoints_reached``, ``sim_time_s``, ``wall_time_s``, ``status``, ``error``,
    ``log_path``.

    Parameters
    ----------
    out_dir : Path
        The sweep's folder.
    rows : sequence of dict
        The runs' rows.
    keys : sequence of str
        The swept keys.
    followers : sequence of str
        The followers.
    """
    columns = [*ID_COLUMNS, *keys, *metric_columns(followers), *STATUS_COLUMNS]
    table = _table(sorted(rows, key=lambda r: int(r["run"])), columns)
    out = [out_dir / "runs.parquet", out_dir / "runs.csv"]
    _write_table(table, *out)
    return out


def _write_table(table: pa.Table, parquet: Path, csv: Path) -> None:
    """A table as Parquet and CSV, each file replaced whole."""
    with write_whole(parquet) as tmp:
        pq.write_table(table, tmp)
    with write_whole(csv) as tmp:
        pacsv.write_csv(table, tmp)


def read_rows(out_dir: str | Path) -> list[dict[str, Any]]:
    """The results table of a sweep's folder (``runs.parquet``), one dict per run.

    Parameters
    ----------
    out_dir : str or Path
        The sweep's folder.

    Raises
    ------
    ConfigError
        No results table there.
    """
    path = Path(out_dir) / "runs.parquet"
    try:
        table = pq.read_table(path)
    except FileNotFoundError:
        journal = Path(out_dir) / JOURNAL
        hint = (
            f"its runs are in {JOURNAL}: run the sweep again there with --resume to rebuild the table"
            if journal.exists()
            else "has the sweep run there?"
        )
        raise ConfigError(f"{out_dir} has no results table (runs.parquet): {hint}") from None
    except (OSError, pa.ArrowException) as exc:
        raise ConfigError(f"{path}: cannot read it: {exc}") from None
    missing = [c for c in ("run", "variant", "status") if c not in table.column_names]
    if missing:
        raise ConfigError(f"{path}: not a sweep's results table (no column {', '.join(map(repr, missing))})")
    rows = list(table.to_pylist())
    for row in rows:  # (a table written from a hand-edited journal before lfctl checked it)
        check_numbers(row, f"{path}, the row of run {row.get('run')}")
    return rows


def mean_ci(
    values: Iterable[float | None], bounds: tuple[float, float] = (-math.inf, math.inf)
) -> tuple[float | None, float | None, float | None]:
    """Mean and 95 % confidence interval (Student's t) of the values present, the interval
    kept within what the figure can be (a share within 0-1, a time or an error not below 0:
    cut there, the interval still holds the mean as often).

    Parameters
    ----------
    values : iterable of float or None
        One figure over runs; None and non-finite values are left out.
    bounds : (float, float)
        The lowest and highest the figure can be (:data:`~lfctl.sweep.task.FIGURE_RANGES`).

    Returns
    -------
    (mean, lo, hi)
        None for each that cannot be had (no values; one value: no interval).
    """
    from scipy.stats import t

    a = np.array([v for v in values if v is not None and math.isfinite(v)], float)
    if a.size == 0:
        return None, None, None
    mean = float(a.mean())
    if a.size < 2:
        return mean, None, None
    half = float(t.ppf(0.975, a.size - 1) * a.std(ddof=1) / math.sqrt(a.size))
    return mean, max(mean - half, bounds[0]), min(mean + half, bounds[1])


def figure_range(column: str) -> tuple[float, float]:
    """What a results column can be, by its figure (``<follower>.<figure>``); unbounded for
    any other column.

    Parameters
    ----------
    column : str
        The column's name.
    """
    return FIGURE_RANGES.get(column.rsplit(".", 1)[-1], (-math.inf, math.inf))


def summarise(rows: Sequence[dict[str, Any]], keys: Sequence[str], metrics: Sequence[str]) -> list[dict[str, Any]]:
    """One row per variant: its swept values, runs, ``ok``, ``failed``, and per metric
    ``<metric>.mean``, ``.ci95_lo``, ``.ci95_hi`` over its ``ok`` runs, and ``.n``, how many
    of them have the figure (a run with no scored frame has no tracking success, one no
    longer than the settling time no errors: fewer than ``ok``).

    Parameters
    ----------
    rows : sequence of dict
        The runs' rows.
    keys : sequence of str
        The swept keys.
    metrics : sequence of str
        The figure columns to summarise.
    """
    by_variant: dict[int, list[dict[str, Any]]] = {}
    for r in rows:
        by_variant.setdefault(int(r["variant"]), []).append(r)
    out = []
    for variant in sorted(by_variant):
        runs = by_variant[variant]
        ok = [r for r in runs if r["status"] == "ok"]
        s: dict[str, Any] = {"variant": variant, **{k: runs[0].get(k) for k in keys}}
        s.update(runs=len(runs), ok=len(ok), failed=len(runs) - len(ok))
        for m in metrics:
            values = [v for v in (r.get(m) for r in ok) if v is not None and math.isfinite(v)]
            s[f"{m}.mean"], s[f"{m}.ci95_lo"], s[f"{m}.ci95_hi"] = mean_ci(values, figure_range(m))
            s[f"{m}.n"] = len(values)
        out.append(s)
    return out


def _num(value: float | None) -> str:
    if value is None:
        return "-"
    return f"{value:.3g}" if abs(value) < 1000 else f"{value:.0f}"


def _key_text(value: Any) -> str:
    """A swept value in the summary's table: a float to 4 significant digits (a value drawn
    at random would print all 16), the rest as the tables hold it."""
    return f"{value:.4g}" if isinstance(value, float) else str(_cell(value))


def summary_markdown(summary: Sequence[dict[str, Any]], keys: Sequence[str], followers: Sequence[str]) -> str:
    """The headline figures (:data:`HEADLINE`) per variant as a Markdown table: ``mean [lo, hi]``.

    Parameters
    ----------
    summary : sequence of dict
        What :func:`summarise` gave.
    keys : sequence of str
        The swept keys.
    followers : sequence of str
        The followers.
    """
    shown = [
        f"{f}.{fig}"
        for f in followers
        for fig in HEADLINE
        if any(s.get(f"{f}.{fig}.mean") is not None for s in summary)
    ]
    prefix = len(followers) > 1
    head = ["variant", *keys, "ok/runs", *[(m if prefix else m.split(".", 1)[1]) for m in shown]]
    lines = ["| " + " | ".join(head) + " |", "|" + "|".join(" --- " for _ in head) + "|"]
    for s in summary:
        cells = [str(s["variant"]), *[_key_text(s.get(k)) for k in keys], f"{s['ok']}/{s['runs']}"]
        for m in shown:
            mean, lo, hi = s.get(f"{m}.mean"), s.get(f"{m}.ci95_lo"), s.get(f"{m}.ci95_hi")
            n = s.get(f"{m}.n", s["ok"])
            cells.append(
                _num(mean)
                + (f" [{_num(lo)}, {_num(hi)}]" if lo is not None else "")
                + (f" (n {n})" if n != s["ok"] else "")
            )
        lines.append("| " + " | ".join(cells) + " |")
    left_out = [(f"{f}.{fig}" if prefix else fig) for f in followers for fig in HEADLINE if f"{f}.{fig}" not in shown]
    if left_out and not any(s["ok"] for s in summary):  # said, not dropped in silence
        lines += ["", "no figures: no run succeeded (the failed column and the rows' error say why)"]
    elif left_out:
        kinds = {m.rsplit(".", 1)[-1] for m in left_out}
        why = [
            *(
                [f"runs no longer than the {SETTLE_S:g} s settling time have no errors"]
                if kinds & ERROR_FIGURES
                else []
            ),
            *(["a camera figure needs camera sensing"] if kinds & CAMERA_FIGURES else []),
        ]
        lines += ["", f"no figures for {', '.join(left_out)} in any variant" + (f" ({'; '.join(why)})" if why else "")]
    return "\n".join(lines) + "\n"


def report(out_dir: str | Path, plots: bool = True) -> SweepSummary:
    """Rebuild a sweep's summary (and plots) from its results table.

    Writes ``summary.parquet``, ``summary.csv``, ``summary.md`` and, with ``plots``, one PNG
    per swept key and follower in ``plots/``.

    Parameters
    ----------
    out_dir : str or Path
        The sweep's folder (what ``lfctl sweep`` wrote).
    plots : bool
        Draw the plots too.

    Raises
    ------
    ConfigError
        The folder holds no sweep or no results table.
    """
    from lfctl.sweep.plots import plot_sweep

    folder = Path(out_dir)
    meta = read_meta(folder)
    rows = read_rows(folder)
    keys, followers = list(meta["keys"]), list(meta["followers"])
    metrics = [*metric_columns(followers), "waypoints_reached", "wall_time_s"]
    summary = summarise(rows, keys, metrics)
    files = [folder / "summary.parquet", folder / "summary.csv", folder / "summary.md"]
    columns = ["variant", *keys, "runs", "ok", "failed"] + [
        f"{m}.{s}" for m in metrics for s in ("mean", "ci95_lo", "ci95_hi", "n")
    ]
    _write_table(_table(summary, columns), files[0], files[1])
    md = summary_markdown(summary, keys, followers)
    planned = meta.get("runs")
    if isinstance(planned, int) and not isinstance(planned, bool) and len(rows) < planned:
        # a stopped sweep: say so where it is read, or half a sweep passes for a whole one
        md = (
            f"unfinished: {len(rows)} of its {planned} runs have rows (variants without any are not "
            f"in the table); `lfctl sweep SPEC --out {folder} --resume` finishes it\n\n" + md
        )
    title = f"# sweep {meta['name']}: {len(rows)} runs, {sum(r['status'] != 'ok' for r in rows)} failed\n\n"
    with write_whole(files[2]) as tmp:
        tmp.write_text(title + md)
    if plots:
        files += plot_sweep(folder / "plots", rows, keys, followers)
    return SweepSummary(summary, md, files)
