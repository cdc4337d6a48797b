"""Extracted FMU folders go with their process: removed on close and on errors, and the
folders of processes that were killed (SIGKILL) are removed by the next load, never those
of a process that still lives."""

from __future__ import annotations

import fcntl
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest

from lfctl.errors import ConfigError
from lfctl.fmu.archive import remove_stale_extractions
from lfctl.fmu.build import BuiltModel
from lfctl.fmu.load import FmuLibrary, RoleMap

pytestmark = pytest.mark.fmu

HOLDER = """
import sys, time
from lfctl.fmu.load import FmuLibrary
lib = FmuLibrary(sys.argv[1])
print(lib._unzipdir, flush=True)
time.sleep(120)
"""


def hold(fmu: Path, tmpdir: Path) -> tuple[subprocess.Popen[str], Path]:
    """A process that loads an FMU and waits; and the folder it made."""
    env = dict(os.environ, TMPDIR=str(tmpdir))
    proc = subprocess.Popen([sys.executable, "-c", HOLDER, str(fmu)], stdout=subprocess.PIPE, text=True, env=env)
    assert proc.stdout is not None
    line = proc.stdout.readline().strip()
    assert line, "the holder did not load the FMU"
    return proc, Path(line).parent


def dead_pid() -> int:
    proc = subprocess.Popen(["true"])
    proc.wait()
    return proc.pid


@pytest.fixture
def where(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    d = tmp_path / "tmp"
    d.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(d))
    return d


def test_folder_is_named_for_model_and_process_and_removed_on_close(faulty: BuiltModel, where: Path) -> None:
    with FmuLibrary(faulty.fmi2) as lib:
        root = Path(lib._unzipdir).parent
        assert root.parent == where and root.name.startswith(f"lfctl-FaultyRover-{os.getpid()}-")
        assert (root / "fmu" / "modelDescription.xml").is_file() and (root / "owner.lock").is_file()
    assert not root.exists()


def test_folder_is_removed_when_loading_fails_after_extraction(faulty: BuiltModel, where: Path) -> None:
    with pytest.raises(ConfigError), FmuLibrary(faulty.fmi2, RoleMap()) as lib:
        lib.instantiate("v", {"no_such_parameter": 1.0}, (0.0, 0.0, 0.0), np.zeros(2), np.zeros(5))
    assert list(where.iterdir()) == []


@pytest.mark.integration
def test_a_killed_process_leaves_a_folder_the_next_load_removes(faulty: BuiltModel, where: Path) -> None:
    killed, killed_dir = hold(faulty.fmi2, where)
    alive, alive_dir = hold(faulty.fmi3, where)
    try:
        killed.send_signal(signal.SIGKILL)
        killed.wait(timeout=10)
        assert killed_dir.is_dir()  # SIGKILL: nothing ran to remove it
        # the next process that loads an FMU removes it, and leaves the live one's
        env = dict(os.environ, TMPDIR=str(where))
        code = f"from lfctl.fmu.load import FmuLibrary\nFmuLibrary({str(faulty.fmi2)!r}).close()"
        subprocess.run([sys.executable, "-c", code], check=True, env=env, timeout=60)
        assert not killed_dir.exists()
        assert alive_dir.is_dir() and (alive_dir / "fmu" / "modelDescription.xml").is_file()
    finally:
        for proc in (killed, alive):
            if proc.poll() is None:
                proc.kill()
                proc.wait()
    assert remove_stale_extractions(where) == [alive_dir]  # now it is gone too


def test_a_live_owner_in_another_pid_namespace_keeps_its_folder(where: Path) -> None:
    # its pid means nothing here (dead), but its lock is held: it lives elsewhere
    root = where / f"lfctl-Model-{dead_pid()}-abcd1234"
    root.mkdir()
    fd = os.open(root / "owner.lock", os.O_WRONLY | os.O_CREAT)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        assert remove_stale_extractions(where) == []
        assert root.is_dir()
    finally:
        os.close(fd)
    assert remove_stale_extractions(where) == [root]


def test_only_our_own_dead_processes_folders_go(where: Path) -> None:
    gone = dead_pid()
    parent = where / f"lfctl-Model-{os.getppid()}-abcd1234"  # alive
    mine = where / f"lfctl-Model-{os.getpid()}-abcd1234"  # this process
    other_name = where / f"lfctl-{gone}-abcd1234"  # not our pattern
    young = where / f"lfctl-Model-{gone}-young123"  # no lock file yet, just made
    old = where / f"lfctl-Model-{gone}-old12345"  # no lock file, for minutes
    for d in (parent, mine, other_name, young, old):
        d.mkdir()
    os.utime(old, (time.time() - 600, time.time() - 600))
    assert remove_stale_extractions(where) == [old]
    assert all(d.is_dir() for d in (parent, mine, other_name, young))


@pytest.mark.skipif(os.getuid() != 0, reason="needs root to make another user's folder")
def test_another_users_folder_is_left_alone(where: Path) -> None:
    theirs = where / f"lfctl-Model-{dead_pid()}-abcd1234"
    theirs.mkdir()
    (theirs / "owner.lock").touch()
    os.chown(theirs, 12345, 12345)
    assert remove_stale_extractions(where) == []
    assert theirs.is_dir()
