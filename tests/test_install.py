"""lfctl as a user installs it: a wheel into a fresh virtual environment, used from an empty
directory (no checkout on the path), builds its FMUs, runs a shipped example by name and
audits the log. The sdist carries the C sources and the examples too, and no tests."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tarfile
import zipfile
from pathlib import Path

import pytest

from lfctl import __version__
from lfctl.data import code_digest

REPO = Path(__file__).resolve().parents[1]


def _source_copy(dest: Path) -> Path:
    """The repository's files as git sees them (tracked, and new ones not ignored), without
    build leftovers that could slip into a wheel."""
    listed = subprocess.run(
        ["git", "ls-files", "--cached", "--others", "--exclude-standard", "-z"],
        cwd=REPO,
        capture_output=True,
        check=True,
    ).stdout.decode()
    for name in filter(None, listed.split("\0")):
        src = REPO / name
        if src.is_file():
            (dest / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, dest / name)
    return dest


def _run(cmd: list[str], cwd: Path, env: dict[str, str] | None = None, timeout: float = 600) -> str:
    proc = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)
    assert proc.returncode == 0, (
        f"{' '.join(cmd)} exited {proc.returncode}:\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
    )
    return proc.stdout


@pytest.mark.slow
@pytest.mark.integration
def test_wheel_in_a_fresh_venv_builds_fmus_and_runs_an_example_from_an_empty_directory(tmp_path: Path) -> None:
    dist = tmp_path / "dist"
    src = _source_copy(tmp_path / "src")
    # an earlier build's leftovers, newer than the sources (a tree copied without its times):
    # neither an old copy of a module nor one since deleted may reach the wheel
    old = src / "build" / "lib" / "lfctl"
    old.mkdir(parents=True)
    (old / "config.py").write_text("STALE = True\n")
    (old / "deleted_since.py").write_text("STALE = True\n")
    (src / os.fsdecode(b"examples/b\xffd.toml")).write_text("x")  # a name that is not UTF-8 failed the build
    _run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", str(src), "-w", str(dist)], tmp_path)
    (wheel,) = dist.glob("lfctl-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    assert zipfile.ZipFile(wheel).read("lfctl/config.py") == (src / "lfctl" / "config.py").read_bytes()
    assert "lfctl/deleted_since.py" not in names
    assert not [n for n in names if n.startswith("lfctl/examples/b") and n.endswith("d.toml")]
    assert "lfctl/fmu_models/common/model_core.c" in names and "lfctl/examples/convoy.toml" in names
    assert "lfctl/bench/cosim.py" in names and not any(n.startswith("tests/") for n in names)
    assert "lfctl/examples/sweeps/noise.toml" in names and "lfctl/examples/sweeps/scenarios/ablation.toml" in names
    assert "lfctl/docs/audit.md" in names and "lfctl/footage/labels/vtest_blackcoat.json" in names

    venv = tmp_path / "venv"
    _run([sys.executable, "-m", "venv", str(venv)], tmp_path)
    py = venv / "bin" / "python"
    _run([str(py), "-m", "pip", "install", "-q", str(wheel)], tmp_path, timeout=900)

    empty = tmp_path / "empty"
    empty.mkdir()
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    env["PATH"] = f"{venv / 'bin'}{os.pathsep}{env.get('PATH', '')}"
    env["XDG_CACHE_HOME"] = str(tmp_path / "cache")  # a real build, not the test session's cache
    where = _run([str(py), "-c", "import lfctl; print(lfctl.__file__)"], empty, env)
    assert where.strip().startswith(str(venv)), where

    built = _run(["lfctl", "fmu", "build"], empty, env)
    assert "SkidSteerRover" in built and (tmp_path / "cache").is_dir()
    out = _run(["lfctl", "sim", "convoy", "--duration", "2", "-q"], empty, env)
    assert "sim time     2.00 s" in out
    (log,) = (empty / "logs").glob("*.mcap")
    audit = _run(["lfctl", "audit", str(log)], empty, env)
    # the installed simulation sources are the checkout's, not an older build's: the code's
    # digest (lfctl's Python but the CLI and benchmarks, and the models' C) in the log and in
    # --version is the checkout's
    code = code_digest()[:12]
    assert "integrity: OK" in audit and f"(installed; code {code})" in audit
    assert _run(["lfctl", "--version"], empty, env).strip() == f"lfctl {__version__} (code {code})"
    # the page its help names is there, inside the installed package
    helped = _run(["lfctl", "audit", "--help"], empty, env)
    # (a path is never broken across lines: the line breaks before it)
    page = Path(" ".join(helped.split()).split("Reading is bounded (", 1)[1].split(")", 1)[0])
    assert str(page).startswith(str(venv)) and page.is_file(), page


@pytest.mark.slow
@pytest.mark.parametrize("checkout", [False, True], ids=["a tree", "a git checkout"])
def test_sdist_carries_the_c_sources_and_the_examples_and_nothing_a_user_left_there(
    tmp_path: Path, checkout: bool
) -> None:
    src = _source_copy(tmp_path / "src")
    # what a user leaves in the shipped folders (a run from examples/, a sweep run there, an
    # editor, a compiler, lfctl bench) went into every sdist and wheel; a new example of
    # their own still goes
    junk = ["examples/logs/20261207T000000Z-convoy-1.mcap", "examples/convoy.toml~", "examples/bench-results.md",
            "fmu_models/SkidSteerRover/a.out", "docs/.#audit.md", "examples/sweeps/noise/sweep.json",
            "examples/sweeps/noise/runs.csv", "examples/sweeps/noise/plots/seed.png"]  # fmt: skip
    for name in [*junk, "examples/mine.toml", "examples/private.toml"]:
        (src / name).parent.mkdir(parents=True, exist_ok=True)
        (src / name).write_text("x")
    (src / os.fsdecode(b"examples/b\xffd.toml")).write_text("x")  # a name that is not UTF-8 failed the build
    if checkout:  # what git ignores stays out too
        with open(src / ".gitignore", "a") as f:
            f.write("examples/private.toml\n")
        _run(["git", "init", "-q"], src)
        junk.append("examples/private.toml")
    _run(
        [sys.executable, "-c", f"from setuptools import build_meta; build_meta.build_sdist({str(tmp_path)!r})"],
        src,
    )
    (sdist,) = tmp_path.glob("lfctl-*.tar.gz")
    with tarfile.open(sdist) as tf:
        names = {n.split("/", 1)[1] for n in tf.getnames() if "/" in n}
    assert {
        "fmu_models/common/model_core.c",
        "fmu_models/SkidSteerRover/model.c",
        "examples/convoy.toml",
        "examples/mine.toml",
        "setup.py",
    } <= names
    assert not set(junk) & names
    assert not [n for n in names if n.startswith("examples/b") and n.endswith("d.toml")]  # (not UTF-8: left out)
    assert not any(n.startswith("tests/") for n in names)  # (the tests run from a checkout: their fixtures are there)
