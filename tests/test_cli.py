"""The command line: what a user types, what comes back, exit codes 0 / 1 / 2."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from support import unmakeable_folder

from lfctl.cli import main

ROOT = Path(__file__).parents[1]


@pytest.fixture(autouse=True)
def _in_tmp(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Runs write logs/ into the working directory: keep them out of the checkout."""
    monkeypatch.chdir(tmp_path)


def test_sim_convoy_prints_a_summary(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sim", str(ROOT / "examples" / "convoy.toml"), "--duration", "5", "-q"]) == 0
    out = capsys.readouterr().out
    assert "scenario     convoy" in out and "sim time     5.00 s in 500 steps of 10 ms" in out
    assert "real time)" in out and "leader       AUTO 5.0 s; 0/4 waypoints reached" in out
    row = next(line for line in out.splitlines() if line.startswith("follower1  leader"))
    assert len(row.split()) == 13  # name, target, range, bearing, 4 errors, min sep, path RMS, 3 state times


def test_sim_seed_and_duration_override(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sim", str(ROOT / "examples" / "column5.toml"), "--duration", "2", "--seed", "7", "-q"]) == 0
    out = capsys.readouterr().out
    assert "(seed 7, lockstep," in out and "f4" in out


def test_bad_scenario_exits_2_with_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text('[sim]\ndt_s = -1\n[[vehicles]]\nname = "a"\nrole = "leader"\n')
    assert main(["sim", str(bad)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "sim.dt_s must be within [0.0001, 1], got -1.0" in err and "Traceback" not in err
    bad.write_text("[sim\n")  # named once, as a bad key is ("bad.toml: bad: not valid TOML" named it twice)
    assert main(["sim", str(bad)]) == 2
    assert capsys.readouterr().err.startswith(f"lfctl: error: {bad}: not valid TOML: Expected ']'")


def test_corrupt_user_fmu_is_bad_input_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    fmu = tmp_path / "broken.fmu"
    fmu.write_bytes(b"PK\x03\x04 not really")
    scen = tmp_path / "s.toml"
    scen.write_text(f'[[vehicles]]\nname = "a"\nrole = "leader"\nfmu = "{fmu}"\n')
    assert main(["sim", str(scen), "--duration", "1"]) == 2
    assert "broken.fmu is not an FMU" in capsys.readouterr().err


def test_fmu_info_lists_variables_with_units(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["fmu", "info", "SkidSteerRover", "--fmi-version", "3"]) == 0
    out = capsys.readouterr().out
    assert "FMI 3.0" in out
    line = next(x for x in out.splitlines() if x.startswith("yaw_rate_cmd"))
    assert "input" in line and "rad/s" in line


def test_fmu_info_refuses_a_version_it_would_ignore_for_a_file(capsys: pytest.CaptureFixture[str]) -> None:
    from lfctl.fmu.build import build_model

    fmi3 = build_model("SkidSteerRover").fmi3
    assert main(["fmu", "info", str(fmi3), "--fmi-version", "2"]) == 2  # an FMI 3 file was shown as asked for 2
    assert "--fmi-version picks a built-in model's FMU" in capsys.readouterr().err
    assert main(["fmu", "info", str(fmi3)]) == 0 and "FMI 3.0" in capsys.readouterr().out


def test_fmu_info_unknown_target_exits_2(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["fmu", "info", "NoSuchModel"]) == 2
    assert "neither an FMU file nor a built-in model" in capsys.readouterr().err


def test_fmu_build_prints_both_versions(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["fmu", "build", "SkidSteerRover"]) == 0
    out = capsys.readouterr().out
    assert "FMI 2.0" in out and "FMI 3.0" in out and ".fmi3.fmu" in out


def test_unknown_benchmark_exits_2(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bench", "nope"]) == 2
    assert "unknown benchmark 'nope' (known: cosim" in capsys.readouterr().err
    assert main(["bench", ""]) == 2  # an unset "$NAME": not a run of every benchmark
    assert "unknown benchmark '' (known: cosim" in capsys.readouterr().err


@pytest.mark.parametrize("kind", ["fifo", "folder"])
def test_bench_results_that_cannot_be_written_are_refused_before_any_benchmark_runs(
    tmp_path: Path, kind: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    import lfctl.bench
    from lfctl.errors import ConfigError

    target = tmp_path / "bench-results.json"
    if kind == "fifo":
        os.mkfifo(target)
    else:
        target.mkdir()
    monkeypatch.setattr(lfctl.bench, "_run_child", lambda *a: pytest.fail("a benchmark ran"))
    with pytest.raises(ConfigError, match=r"bench-results\.json is not a regular file"):
        lfctl.bench.run_all(("cosim",), out_dir=tmp_path)


def test_a_failed_benchmark_says_its_last_line_only(capsys: pytest.CaptureFixture[str]) -> None:
    from lfctl.bench import _run_child

    outcome = _run_child("no_such_benchmark", quick=True)  # its process fails with a traceback
    err = capsys.readouterr().err
    assert outcome.result is None and "Traceback" not in err
    assert err.startswith("lfctl bench no_such_benchmark failed (exit 1): ") and len(err.splitlines()) == 1


@pytest.mark.slow
@pytest.mark.integration
def test_bench_cosim_prints_table_and_json_line() -> None:
    out = subprocess.run(
        [sys.executable, "-m", "lfctl", "bench", "cosim", "--quick"],
        capture_output=True,
        text=True,
        check=True,
        cwd=ROOT,
    ).stdout
    lines = out.strip().splitlines()
    assert any(line.startswith("| vehicles") for line in lines)
    record = json.loads(lines[-1])
    assert record["benchmark"] == "cosim"
    assert [r["vehicles"] for r in record["results"]] == [1, 2, 10, 50]
    assert all(r["master_over_baseline_ratio"] > 0 for r in record["results"])


def test_python_dash_m_help() -> None:
    out = subprocess.run([sys.executable, "-m", "lfctl", "--help"], capture_output=True, text=True, check=True).stdout
    assert "sim" in out and "fmu" in out and "bench" in out


def test_examples_run_by_name_from_any_directory(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sim", "column5", "--duration", "1", "-q", "--no-record"]) == 0
    assert "scenario     column5" in capsys.readouterr().out
    assert main(["sim", "nosuchexample", "-q"]) == 2
    assert (
        "neither a file nor a shipped example (examples: column5, convoy, convoy-aruco, survey, vee)"
        in capsys.readouterr().err
    )


def test_a_run_that_fails_before_its_first_step_leaves_no_log(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "nofmu.toml"
    bad.write_text('[[vehicles]]\nname = "leader"\nrole = "leader"\nfmu = "missing.fmu"\n')
    assert main(["sim", str(bad), "-q"]) == 2  # a file the scenario names is missing: bad input
    assert "missing.fmu does not exist" in capsys.readouterr().err
    assert not list(tmp_path.glob("logs/*.mcap"))


def test_a_run_that_fails_later_leaves_a_finished_log_that_says_why(tmp_path: Path) -> None:
    from lfctl.config import load_config
    from lfctl.record.audit import audit
    from lfctl.sim.runner import run_scenario

    cfg = load_config(ROOT / "examples" / "convoy.toml")
    path = tmp_path / "broken.mcap"
    calls = [0]

    def stop() -> bool:
        calls[0] += 1
        if calls[0] > 150:
            raise RuntimeError("the disk went away")
        return False

    with pytest.raises(RuntimeError):
        run_scenario(cfg, record_to=path, stop=stop, duration_s=5.0)
    report = audit(path)
    assert report.figures["end"]["reason"] == "error: RuntimeError: the disk went away"
    assert float(report.figures["end"]["t_s"]) == pytest.approx(1.51)  # stop is asked after step 151
    assert any("ended abnormally at t = 1.51 s" in f.what and f.level == "error" for f in report.findings)


def test_the_summarys_state_times_add_up_to_the_run(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sim", "convoy", "--duration", "3", "--sensing", "truth", "--no-record", "-q"]) == 0
    out, err = capsys.readouterr()
    # a name, not a file here: which file ran is said (an edited copy here would be convoy.toml)
    assert err.splitlines()[0] == f"lfctl sim: convoy is the shipped example {ROOT / 'examples' / 'convoy.toml'}"
    row = next(line for line in out.splitlines() if line.startswith("follower1  leader"))
    tracking, occluded, lost = (float(v) for v in row.split()[-3:])
    assert tracking + occluded + lost == pytest.approx(3.0, abs=0.011)  # to 0.01 s, not 0.1 each


def test_video_with_truth_sensing_is_refused_before_it_is_announced(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sim", "convoy", "--duration", "1", "--no-record", "-q", "--sensing", "truth", "--video"]) == 2
    out, err = capsys.readouterr()
    assert "live video needs camera sensing" in err and "RTP/UDP" not in out


@pytest.mark.parametrize(
    ("argv", "said", "not_said"),
    [
        (["gcs", "param", "--help"], ("list ", "get ", "set ", "save ", "load "), ()),
        (["sweep", "--help"], ("95 % confidence",), ("%%",)),
    ],
)
def test_help_lists_every_operation_and_prints_no_escapes(
    argv: list[str], said: tuple[str, ...], not_said: tuple[str, ...], capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit):
        main(argv)
    out = " ".join(capsys.readouterr().out.split())  # argparse wraps to the terminal's width
    assert all(s in out for s in said) and not any(s in out for s in not_said)


def test_fmu_build_into_a_cache_that_is_a_file_exits_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "afile").write_text("mine\n")
    assert main(["fmu", "build", "--cache-dir", str(tmp_path / "afile")]) == 2
    assert f"the FMU cache {tmp_path / 'afile'} is not a folder" in capsys.readouterr().err
    assert (tmp_path / "afile").read_text() == "mine\n"


def test_fmu_info_escapes_the_fmus_own_control_characters(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    import zipfile

    from lfctl.fmu.build import build_model

    src = build_model("KinematicUnicycle").fmi2
    bad = tmp_path / "bad.fmu"
    with zipfile.ZipFile(src) as a, zipfile.ZipFile(bad, "w", zipfile.ZIP_DEFLATED) as b:
        for info in a.infolist():
            data = a.read(info)
            if info.filename == "modelDescription.xml":
                data = data.replace(b'description="Kinematic unicycle', b'description="&#155;2J&#10;FAKE', 1)
            b.writestr(info.filename, data)
    assert main(["fmu", "info", str(bad)]) == 0
    out = capsys.readouterr().out
    assert "\x9b" not in out and r"description  \x9b2J\nFAKE" in out


@pytest.mark.parametrize(
    ("argv", "debug", "verbose"),
    [
        (["sim", "convoy", "--debug"], True, False),  # after the command, as users type it
        (["--debug", "sim", "convoy"], True, False),
        (["sim", "convoy"], False, False),
        (["gcs", "param", "get", "WP_SPEED", "-v"], False, True),  # after a command's action too
        (["-v", "fmu", "info", "unicycle", "--debug"], True, True),
    ],
)
def test_global_options_are_taken_before_or_after_the_command(argv: list[str], debug: bool, verbose: bool) -> None:
    from lfctl.cli import build_parser

    args = build_parser().parse_args(argv)
    assert (args.debug, args.verbose) == (debug, verbose)


@pytest.mark.parametrize(
    ("argv", "said"),
    [
        (["sim", "convoy", "--durration", "3"], "lfctl sim: error: unrecognized arguments: --durration 3 (see lfctl sim --help)"),
        (["fmu", "build", "--nope"], "lfctl fmu build: error: unrecognized arguments: --nope (see lfctl fmu build --help)"),
        (["gcs", "upload", "m.plan", "-x"], "lfctl gcs upload: error: unrecognized arguments: -x (see lfctl gcs upload --help)"),
        (["gcs", "upload", "m.plan", "--target", "2"], "lfctl gcs upload: error: --target is an option of lfctl gcs: give it before 'upload' (see lfctl gcs upload --help)"),
        (["--bogus", "sim", "convoy"], "lfctl: error: unrecognized arguments: --bogus (see lfctl --help)"),
    ],
)  # fmt: skip
def test_a_misspelt_option_is_named_with_the_help_that_lists_the_commands_options(
    argv: list[str], said: str, capsys: pytest.CaptureFixture[str]
) -> None:
    # the top-level --help lists no command's options: "(see lfctl --help)" sent users nowhere
    with pytest.raises(SystemExit) as stop:
        main(argv)
    assert stop.value.code == 2 and capsys.readouterr().err == said + "\n"


@pytest.mark.parametrize("name", ["vision_aruco", "e2e"])
def test_a_benchmark_module_takes_help_and_refuses_a_misspelt_option(name: str) -> None:
    # `python -m lfctl.bench.vision_aruco --help` ran the whole benchmark
    run = [sys.executable, "-m", f"lfctl.bench.{name}"]
    helped = subprocess.run([*run, "--help"], capture_output=True, text=True, timeout=120)
    assert helped.returncode == 0 and helped.stdout.startswith(f"usage: python3 -m lfctl.bench.{name} [-h] [--quick]")
    wrong = subprocess.run([*run, "--quik"], capture_output=True, text=True, timeout=120)
    assert (wrong.returncode, wrong.stdout) == (2, "")
    assert "unrecognized arguments: --quik" in wrong.stderr


def test_audit_names_a_plot_folder_it_cannot_make(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("x")  # a folder cannot be made under a file
    assert main(["audit", str(ROOT / "examples" / "convoy.toml"), "--plot", str(blocker / "plots")]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err == f"lfctl: error: --plot {blocker / 'plots'}: cannot make the folder (Not a directory)\n"


def test_audit_leaves_no_plot_folders_when_nothing_is_plotted(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    garbage = tmp_path / "g.mcap"
    garbage.write_bytes(b"not a log")
    assert main(["audit", str(garbage), "--plot", str(tmp_path / "a" / "b")]) == 1  # nothing readable
    assert main(["audit", str(garbage), "--plot", str(tmp_path / "c"), "--recover", str(garbage)]) == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == ["g.mcap"]  # neither a/ nor a/b/ nor c/ stays
    assert "--recover" in capsys.readouterr().err


def test_gcs_watch_refuses_a_target_it_would_ignore(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["gcs", "--target", "2", "watch", "--count", "1"]) == 2
    assert "--target is not for watch" in capsys.readouterr().err


def test_a_lockstep_run_with_a_live_view_says_it_goes_as_fast_as_it_can(capsys: pytest.CaptureFixture[str]) -> None:
    # a 20 s run sent its video in 5 s of wall time, and nothing said why
    assert main(["sim", "vee", "--duration", "0.2", "--live", "127.0.0.1:0", "--no-record", "-q"]) == 0
    assert "note: lockstep runs as fast as it can" in capsys.readouterr().err


def test_a_realtime_run_says_how_to_start_the_leaders_mission(
    tmp_path: Path, free_udp_ports, capsys: pytest.CaptureFixture[str]
) -> None:
    # the README's live demo showed a scene that never moved: the leader waits for a ground station
    base = free_udp_ports(2)
    scen = tmp_path / "rt.toml"
    scen.write_text(
        (ROOT / "examples" / "convoy.toml").read_text() + f'\n[link]\nudp_base_port = {base}\ngcs_udpout = ""\n'
    )
    assert main(["sim", str(scen), "--realtime", "--sensing", "truth", "--duration", "0.3", "--no-record", "-q"]) == 0
    out = capsys.readouterr().out
    hint = f"leader       waits in HOLD, disarmed, its mission stored: `lfctl gcs --connect udpout:127.0.0.1:{base} mode AUTO`"
    assert hint in out


def test_help_keeps_a_long_path_whole_and_prints_the_code_digest(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    # a wheel's examples sit in .../site-packages/...: argparse broke the line at its hyphen
    from lfctl.data import code_digest

    long = "/home/rover-user/projects/.venv-lfctl/lib/python3.11/site-packages/lfctl/examples"
    monkeypatch.setattr("lfctl.cli.sim.examples_dir", lambda: Path(long))
    monkeypatch.setenv("COLUMNS", "50")
    with pytest.raises(SystemExit):
        main(["sim", "--help"])
    out = capsys.readouterr().out
    assert long in out.splitlines()
    with pytest.raises(SystemExit):
        main(["--version"])
    assert capsys.readouterr().out.strip().endswith(f"(code {code_digest()[:12]})")


@pytest.mark.parametrize("argv", [["--help"], ["--version"], ["fmu", "info", "KinematicUnicycle"]])
@pytest.mark.parametrize("unbuffered", ["", "1"])
def test_a_reader_that_left_before_the_last_write_is_not_an_error(argv: list[str], unbuffered: str) -> None:
    # `lfctl --help | head -n 0`: the output waited in Python's buffer until the interpreter's
    # flush at exit, which printed "Exception ignored ... BrokenPipeError" and exited 120 (with
    # PYTHONUNBUFFERED, --version's print ended in a traceback)
    env = {k: v for k, v in os.environ.items() if k != "PYTHONUNBUFFERED"}
    if unbuffered:
        env["PYTHONUNBUFFERED"] = unbuffered
    proc = subprocess.Popen(
        [sys.executable, "-m", "lfctl", *argv], stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env
    )
    assert proc.stdout is not None and proc.stderr is not None
    proc.stdout.close()  # the reader leaves before anything is written
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=120) == 0 and err == "", err
    # a stdout closed before it started (`lfctl --version >&-`): Python's sys.stdout is None
    shut = subprocess.run(
        ["sh", "-c", '"$0" -m lfctl "$@" >&-', sys.executable, *argv], capture_output=True, env=env, timeout=120
    )
    assert shut.returncode == 0 and b"Error" not in shut.stderr, shut.stderr  # (argparse's help goes to stderr)


def test_paths_with_spaces_stay_whole_in_help_and_are_quoted_in_commands_to_copy(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    # a venv under "~/My Projects": the help broke the examples' folder at its space, and the
    # `lfctl audit LOG` to paste did not quote a log folder with one
    import lfctl.cli.sim

    folder = Path("/home/me/My Projects/venv ü/lib/python3.11/site-packages/lfctl/examples")
    monkeypatch.setattr(lfctl.cli.sim, "examples_dir", lambda: folder)
    monkeypatch.setenv("COLUMNS", "60")
    with pytest.raises(SystemExit):
        main(["sim", "--help"])
    assert str(folder) in capsys.readouterr().out.splitlines()  # a line of its own: it fits none with words
    scenario = tmp_path / "s.toml"
    scenario.write_text((ROOT / "examples" / "convoy.toml").read_text() + '\n[recording]\ndir = "my runs"\n')
    assert main(["sim", str(scenario), "--duration", "0.5", "--sensing", "truth", "-q"]) == 0
    (log,) = (tmp_path / "my runs").glob("*.mcap")
    assert f"check it with `lfctl audit 'my runs/{log.name}'`" in capsys.readouterr().out


def test_plots_without_a_writable_home_use_lfctls_cache_for_matplotlib(tmp_path: Path) -> None:
    # a service user (HOME=/nonexistent) with XDG_CACHE_HOME set: matplotlib warned twice on
    # every plotting run ("mkdir -p failed ...", "created a temporary cache directory ...")
    unmakeable_folder("lfctl-home")
    env = {k: v for k, v in os.environ.items() if k not in ("MPLCONFIGDIR", "XDG_CONFIG_HOME")}
    env |= {"HOME": "/sys/lfctl-home", "XDG_CACHE_HOME": str(tmp_path / "cache")}
    code = "import os; from lfctl.data import pyplot; pyplot().figure(); print(os.environ['MPLCONFIGDIR'])"
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120)
    assert proc.returncode == 0 and proc.stderr == "", proc.stderr
    assert proc.stdout.strip() == str(tmp_path / "cache" / "lfctl" / "matplotlib")


def test_a_folder_name_the_locale_cannot_encode_is_said_not_blamed_on_the_fmu(tmp_path: Path) -> None:
    # LC_ALL=C with Python's UTF-8 mode off, in a folder named outside ASCII: every run failed
    # with "...SkidSteerRover.fmi2.fmu has no valid modelDescription.xml" (exit 2), a fine FMU
    folder = os.path.join(os.fsencode(tmp_path), "d\xfcr".encode())  # (bytes: as the file system has it)
    os.mkdir(folder)
    env = {k: v for k, v in os.environ.items() if not k.startswith(("LC_", "LANG", "PYTHONUTF8", "PYTHONIOENCODING"))}
    env |= {"LC_ALL": "C", "LANG": "C", "PYTHONUTF8": "0"}
    argv = [sys.executable, "-m", "lfctl", "sim", "convoy", "--duration", "0.5", "--sensing", "truth", "--no-record"]
    proc = subprocess.run(argv, cwd=folder, capture_output=True, text=True, env=env, timeout=300)
    assert proc.returncode == 1, proc.stderr
    assert proc.stderr.strip().splitlines()[-1] == (
        "lfctl: error: a file name here is not valid in this system's file name encoding (ascii: surrogates not "
        "allowed): run lfctl under a UTF-8 locale (LANG=C.UTF-8) or with PYTHONUTF8=1"
    )


def test_a_file_as_recording_dir_is_bad_input_named_as_a_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # it was exit 1, a run's failure, with "[Errno 17] File exists"
    taken = tmp_path / "afile"
    taken.write_text("kept")
    for where in (taken, taken / "sub"):
        scenario = tmp_path / "s.toml"
        scenario.write_text((ROOT / "examples" / "convoy.toml").read_text() + f'\n[recording]\ndir = "{where}"\n')
        assert main(["sim", str(scenario), "--duration", "0.5", "--sensing", "truth", "-q"]) == 2
        err = capsys.readouterr().err
        assert f"(recording.dir): {taken} is a file, not a folder" in err and "Errno" not in err, err
    assert taken.read_text() == "kept"
