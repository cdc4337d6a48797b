"""A sweep's tables, summary and plots from rows (no simulation, no Dask)."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import pytest

from lfctl.errors import ConfigError
from lfctl.sweep.plots import MAX_LINES, line_keys, plot_sweep
from lfctl.sweep.results import (
    HEADLINE,
    append_row,
    mean_ci,
    metric_columns,
    read_journal,
    read_rows,
    report,
    summarise,
    summary_markdown,
    write_meta,
    write_tables,
)


def test_mean_ci_is_students_t_by_hand() -> None:
    mean, lo, hi = mean_ci([1.0, 2.0, 3.0, 4.0, None, math.nan])  # None and NaN are left out
    # s = sqrt(5/3) = 1.29099; t(0.975, 3) = 3.18245; half = 3.18245 * 1.29099 / 2 = 2.05426
    assert mean == 2.5 and lo == pytest.approx(2.5 - 2.05426, abs=1e-5) and hi == pytest.approx(4.55426, abs=1e-5)
    assert mean_ci([7.0]) == (7.0, None, None)
    assert mean_ci([None]) == (None, None, None)


def test_an_interval_stays_within_what_its_figure_can_be() -> None:
    from lfctl.sweep.results import figure_range

    # lost seconds 0, 0, 60: mean 20, s = 34.641, half = 4.30265 * 34.641 / sqrt(3) = 86.05
    mean, lo, hi = mean_ci([0.0, 0.0, 60.0], figure_range("follower1.lost_s"))
    assert mean == 20.0 and lo == 0.0 and hi == pytest.approx(106.05, abs=0.01)
    # a share: 0.8, 1, 1 -> mean 0.9333, half = 4.30265 * 0.11547 / sqrt(3) = 0.28684
    mean, lo, hi = mean_ci([0.8, 1.0, 1.0], figure_range("follower1.track_success"))
    assert lo == pytest.approx(0.64649, abs=1e-4) and hi == 1.0
    assert figure_range("follower1.bearing_cmd_deg") == (-180.0, 180.0)
    assert figure_range("wall_time_s") == (-math.inf, math.inf)


def _row(run: int, variant: int, value: float | None, status: str = "ok", **extra: object) -> dict:
    row = {"run": run, "variant": variant, "seed": run, "repetition": 0, "sensing.range_noise_m": 0.1 * variant}
    row.update({c: None for c in metric_columns(["f1"])})
    row.update({"f1.range_err_rms_m": value, "f1.lost_s": 0.0 if value is not None else None})
    row.update(waypoints_reached=None, sim_time_s=3.0, wall_time_s=0.5, status=status, error="", log_path="")
    row.update(extra)
    return row


def test_summary_counts_failures_and_takes_figures_from_ok_runs_only() -> None:
    rows = [_row(0, 0, 1.0), _row(1, 0, 3.0), _row(2, 0, None, "error", error="FmuError: x"), _row(3, 1, 2.0)]
    s = summarise(rows, ["sensing.range_noise_m"], ["f1.range_err_rms_m"])
    assert [(v["variant"], v["runs"], v["ok"], v["failed"]) for v in s] == [(0, 3, 2, 1), (1, 1, 1, 0)]
    assert s[0]["f1.range_err_rms_m.mean"] == 2.0 and s[0]["f1.range_err_rms_m.ci95_lo"] < 2.0
    assert s[1]["f1.range_err_rms_m.ci95_lo"] is None  # one run: no interval
    assert s[1]["sensing.range_noise_m"] == 0.1


def test_a_figure_some_ok_runs_lack_says_how_many_its_interval_is_over() -> None:
    # variant 0: three ok runs, one without the figure (no errors in a run no longer than the
    # settling time): the mean 2.0 and its interval are over two runs, said as (n 2)
    rows = [_row(0, 0, 1.0), _row(1, 0, 3.0), _row(2, 0, None), _row(3, 1, 2.0), _row(4, 1, 2.0)]
    s = summarise(rows, ["sensing.range_noise_m"], ["f1.range_err_rms_m"])
    assert [(v["ok"], v["f1.range_err_rms_m.n"]) for v in s] == [(3, 2), (2, 2)]
    lines = summary_markdown(s, ["sensing.range_noise_m"], ["f1"]).splitlines()
    # t(0.975, 1) = 12.706, s = 1.4142: half = 12.706 * 1.4142 / sqrt(2) = 12.706; cut at 0
    assert lines[2].endswith("| 3/3 | 2 [0, 14.7] (n 2) |") and lines[3].endswith(
        "| 2/2 | 2 [2, 2] |"
    )  # all of them: no n


def test_a_headline_figure_no_variant_has_is_said_not_dropped_in_silence() -> None:
    # a sweep of 5 s runs (no longer than the settling time) had no range error column and no word why
    rows = [_row(0, 0, 1.0), _row(1, 1, None)]
    s = summarise(rows, ["sensing.range_noise_m"], ["f1.range_err_rms_m", "f1.lost_s"])
    text = summary_markdown(s, ["sensing.range_noise_m"], ["f1"])
    assert "| range_err_rms_m |" in text.splitlines()[0] + " |"  # some variant has it: shown
    # each reason said where it applies, and only there
    assert text.splitlines()[-1] == (
        "no figures for bearing_err_rms_deg, chattering_per_s, track_success in any variant (runs no longer than "
        "the 5 s settling time have no errors; a camera figure needs camera sensing)"
    )
    none = summary_markdown(summarise([_row(0, 0, None)], ["sensing.range_noise_m"], ["f1.range_err_rms_m"]),
                            ["sensing.range_noise_m"], ["f1"])  # fmt: skip
    assert "no figures for range_err_rms_m, " in none and "settling time" in none
    truth = _row(0, 0, 1.0, **{"f1.bearing_err_rms_deg": 2.0, "f1.chattering_per_s": 0.5})  # (no track_success)
    camera_only = summarise([truth], ["sensing.range_noise_m"], [f"f1.{m}" for m in HEADLINE])
    assert summary_markdown(camera_only, ["sensing.range_noise_m"], ["f1"]).splitlines()[-1] == (
        "no figures for track_success in any variant (a camera figure needs camera sensing)"
    )
    failed = summarise([_row(0, 0, None, "error", error="FmuError: x")], ["sensing.range_noise_m"], ["f1.lost_s"])
    assert "no figures: no run succeeded" in summary_markdown(failed, ["sensing.range_noise_m"], ["f1"])


def test_tables_round_trip_with_mixed_and_array_values_and_report_rebuilds_summary_and_plots(tmp_path: Path) -> None:
    keys = ["sensing.range_noise_m", "guidance.controller", "scene.lighting[1].tint_bgr"]
    rows = []
    for run in range(8):
        variant = run // 2
        row = _row(run, variant, 0.01 * (run + 1))
        row["sensing.range_noise_m"] = 0 if variant % 2 == 0 else 0.05  # an int beside floats
        row["guidance.controller"] = "smc" if variant < 2 else "p"
        row["scene.lighting[1].tint_bgr"] = [1.0, 1.0, 1.2]
        rows.append(row)
    rows[7] = _row(7, 3, None, "crashed", error="KilledWorker: ...")
    rows[7].update({k: rows[6][k] for k in keys})
    for r in reversed(rows):  # the journal is in the order runs finish
        append_row(tmp_path, r)
    append_row(tmp_path, rows[0])  # written twice (a resumed session): one row per run
    with open(tmp_path / "runs.jsonl", "a") as f:
        f.write('{"run": 9, "varia')  # a line cut short by a crash
    journal = read_journal(tmp_path)
    assert [r["run"] for r in journal] == list(range(8))
    # --resume appends the next row after the torn line, on a line of its own: kept
    append_row(tmp_path, _row(8, 4, 0.5))
    assert [r["run"] for r in read_journal(tmp_path)] == list(range(9))
    journal = [r for r in read_journal(tmp_path) if r["run"] < 8]
    write_meta(tmp_path, {"name": "t", "keys": keys, "followers": ["f1"]})
    write_tables(tmp_path, journal, keys, ["f1"])
    back = read_rows(tmp_path)
    assert [r["run"] for r in back] == list(range(8))
    assert [r["sensing.range_noise_m"] for r in back[:4]] == [0.0, 0.0, 0.05, 0.05]
    assert back[0]["scene.lighting[1].tint_bgr"] == "[1.0, 1.0, 1.2]" and back[7]["status"] == "crashed"
    with open(tmp_path / "runs.csv") as f:
        table = list(csv.DictReader(f))
    assert len(table) == 8 and table[7]["error"] == "KilledWorker: ..." and table[7]["f1.range_err_rms_m"] == ""
    summary = report(tmp_path)
    assert [s["ok"] for s in summary.rows] == [2, 2, 2, 1]
    assert "| variant | sensing.range_noise_m | guidance.controller" in summary.markdown
    pngs = sorted(p.name for p in summary.files if p.suffix == ".png")
    assert pngs == ["guidance.controller.png", "sensing.range_noise_m.png"]  # the tint does not vary
    assert all((tmp_path / "plots" / p).stat().st_size > 10_000 for p in pngs)
    assert (tmp_path / "summary.md").read_text().startswith("# sweep t: 8 runs, 1 failed")
    assert json.loads((tmp_path / "sweep.json").read_text())["name"] == "t"


def test_the_report_of_a_stopped_sweep_says_it_is_unfinished(tmp_path: Path) -> None:
    # sweep.json plans 12 runs, 6 have rows: the report read like a whole sweep of 6
    for run in range(6):
        append_row(tmp_path, _row(run, 0, 0.01 * (run + 1)))
    write_meta(tmp_path, {"name": "t", "keys": [], "followers": ["f1"], "runs": 12})
    write_tables(tmp_path, read_journal(tmp_path), [], ["f1"])
    summary = report(tmp_path)
    assert summary.markdown.startswith("unfinished: 6 of its 12 runs have rows")
    assert "--resume" in summary.markdown.splitlines()[0]
    assert "unfinished: 6 of its 12" in (tmp_path / "summary.md").read_text()
    write_meta(tmp_path, {"name": "t", "keys": [], "followers": ["f1"], "runs": 6})  # all there
    assert "unfinished" not in report(tmp_path).markdown


def test_report_of_a_folder_without_a_sweep_says_so(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="no such folder"):
        report(tmp_path / "nowhere")
    with pytest.raises(ConfigError, match="holds no sweep"):
        report(tmp_path)
    write_meta(tmp_path, {"name": "t", "keys": [], "followers": []})
    with pytest.raises(ConfigError, match="has the sweep run there"):
        report(tmp_path)
    append_row(tmp_path, {"run": 0})  # a journal but no table: the way back is named
    with pytest.raises(ConfigError, match="run the sweep again there with --resume"):
        report(tmp_path)


def test_plots_pool_the_other_keys_when_they_make_too_many_lines(tmp_path: Path) -> None:
    keys = ["a", "b"]
    rows = [_row(n, n // 2, 0.01 * n, a=n % 2, b=n // 2) for n in range(2 * (MAX_LINES + 1) * 2)]
    made = plot_sweep(tmp_path, rows, keys, ["f1"])
    assert [p.name for p in made] == ["a.png", "b.png"]  # a: b has 14 values, pooled; b: two lines of a
    rows = [dict(r, c=r["run"] % 3) for r in rows]
    assert line_keys(rows, "a", ["a", "b", "c"]) == (["c"], ["b"])  # b alone makes 14 lines: pooled
    assert line_keys(rows, "b", ["a", "b", "c"]) == (["a", "c"], [])  # 2 x 3 lines
    assert len(plot_sweep(tmp_path / "c", rows, ["a", "b", "c"], ["f1"])) == 3


def test_a_table_write_stopped_midway_leaves_the_old_file_whole(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import pyarrow.csv as pacsv

    first = [_row(0, 0, 0.01), _row(1, 0, 0.02)]
    write_tables(tmp_path, first, [], ["follower1"])
    before = (tmp_path / "runs.csv").read_bytes()
    real = pacsv.write_csv

    def cut_short(table: object, path: object) -> None:
        Path(str(path)).write_text('"run","variant"\n0,')  # part of a file, then a third Ctrl-C
        raise KeyboardInterrupt

    monkeypatch.setattr(pacsv, "write_csv", cut_short)
    with pytest.raises(KeyboardInterrupt):
        write_tables(tmp_path, [*first, _row(2, 1, 0.03)], [], ["follower1"])
    monkeypatch.setattr(pacsv, "write_csv", real)
    assert (tmp_path / "runs.csv").read_bytes() == before  # the old table, whole
    assert [r["run"] for r in read_rows(tmp_path)] == [0, 1, 2]  # the Parquet file was written before: whole too
    assert sorted(p.name for p in tmp_path.iterdir()) == ["runs.csv", "runs.parquet"]  # no part left behind


def test_a_foreign_table_or_description_is_named(tmp_path: Path) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    from lfctl.sweep.results import read_meta, read_rows

    pq.write_table(pa.table({"a": [1, 2]}), tmp_path / "runs.parquet")
    with pytest.raises(ConfigError, match=r"runs.parquet: not a sweep's results table \(no column 'run', 'variant'"):
        read_rows(tmp_path)
    for text, why in (("[1]", "not a sweep's description"), ('{"keys": 5}', "'keys' must be a list of names")):
        (tmp_path / "sweep.json").write_text(text)
        with pytest.raises(ConfigError, match=why):
            read_meta(tmp_path)


def test_a_value_drawn_at_random_is_shown_to_four_digits_in_the_summary() -> None:
    rows = [dict(_row(0, 0, 1.0), **{"sensing.range_noise_m": 1.875286399814001})]
    text = summary_markdown(
        summarise(rows, ["sensing.range_noise_m"], ["f1.range_err_rms_m"]), ["sensing.range_noise_m"], ["f1"]
    )
    assert "| 0 | 1.875 | 1/1 |" in text and "1.8752" not in text


@pytest.mark.parametrize(
    ("line", "why"),
    [
        (
            b'{"run": 1, "variant": 0, "status": "ok", "f1.lost_s": "abc"}',
            r"line 2: f1\.lost_s must be a number or null, got 'abc'",
        ),
        (
            b'{"run": 1, "variant": 0, "status": "ok", "f1.lost_s": true}',
            r"line 2: f1\.lost_s must be a number or null, got True",
        ),
        (
            b'{"run": 1, "variant": 0, "status": "ok", "f1.lost_s": 123456789012345678901234567890}',
            r"line 2: f1\.lost_s must be a number or null, got a whole number of 30 digits",
        ),
        (
            b'{"run": 1, "variant": 0, "status": "ok", "wall_time_s": [1]}',
            r"line 2: wall_time_s must be a number or null, got \[1\]",
        ),
        (b"[" * 100_000 + b"]" * 100_000, r"line 2: nested too deeply to be a run's row"),
    ],
    ids=["text", "boolean", "huge-int", "list", "deep"],
)
def test_a_hand_edited_journal_line_is_named_by_line_and_column_and_reaches_no_table(
    tmp_path: Path, line: bytes, why: str
) -> None:
    # a text figure went into runs.parquet and then every `sweep report` ended in TypeError;
    # a huge whole number in OverflowError, a deep line in RecursionError (internal errors)
    append_row(tmp_path, _row(0, 0, 0.1))
    with open(tmp_path / "runs.jsonl", "ab") as f:
        f.write(line + b"\n")
    append_row(tmp_path, _row(2, 1, 0.2))
    with pytest.raises(ConfigError, match=why):
        read_journal(tmp_path)


def test_a_line_that_is_not_json_is_said_unless_it_is_the_last(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    import logging

    append_row(tmp_path, _row(0, 0, 0.1))
    with open(tmp_path / "runs.jsonl", "ab") as f:
        f.write(b"garbage typed in by hand\n")
    append_row(tmp_path, _row(1, 0, 0.2))
    with open(tmp_path / "runs.jsonl", "ab") as f:
        f.write(b'{"run": 2, "varia')  # the last line, cut short by a crash: not said
    with caplog.at_level(logging.WARNING, logger="lfctl.sweep.results"):
        assert [r["run"] for r in read_journal(tmp_path)] == [0, 1]
        read_journal(tmp_path)  # (said once, however often a resume reads it)
    said = [r.getMessage() for r in caplog.records]
    assert len(said) == 1 and f"{tmp_path / 'runs.jsonl'}: line 2 is not JSON, skipped" in said[0], said


def test_a_table_with_text_in_a_figure_column_is_named_not_an_internal_error(tmp_path: Path) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    rows = [_row(0, 0, 0.1), _row(1, 0, 0.2)]
    table = {k: [r.get(k) for r in rows] for k in rows[0]}
    table["f1.lost_s"] = ["abc", "0.5"]  # as write_tables wrote a hand-edited journal's text
    pq.write_table(pa.table(table), tmp_path / "runs.parquet")
    write_meta(tmp_path, {"name": "t", "keys": [], "followers": ["f1"]})
    with pytest.raises(
        ConfigError, match=r"runs\.parquet, the row of run 0: f1\.lost_s must be a number or null, got 'abc'"
    ):
        report(tmp_path)


def test_a_count_column_keeps_its_type_when_no_run_has_one(tmp_path: Path) -> None:
    # every run failed: waypoints_reached was double, and the table would not concatenate
    # (pyarrow.concat_tables) with a sweep's whose runs succeeded, where it is int64
    import pyarrow as pa
    import pyarrow.parquet as pq

    tables = []
    for name, rows in (("ok", [_row(0, 0, 1.0, waypoints_reached=3)]), ("failed", [_row(0, 0, None, "error")])):
        (tmp_path / name).mkdir()
        write_tables(tmp_path / name, rows, ["sensing.range_noise_m"], ["f1"])
        tables.append(pq.read_table(tmp_path / name / "runs.parquet"))
    assert [t.schema.field("waypoints_reached").type for t in tables] == [pa.int64(), pa.int64()]
    assert tables[0].schema == tables[1].schema
    assert pa.concat_tables(tables).column("waypoints_reached").to_pylist() == [3, None]
