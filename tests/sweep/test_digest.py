"""The code digest a sweep's workers are checked by: the same for a source checkout and a wheel
of the same commit, different when one source byte differs."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from lfctl import data
from lfctl.data import _PACKAGE_DIR as _PACKAGE
from lfctl.data import code_digest, models_dir


def _wheel_layout(root: Path) -> tuple[Path, Path]:
    """The package's Python sources with the models inside it, as a wheel installs them."""
    package = root / "lfctl"
    for p in _PACKAGE.rglob("*.py"):
        dest = package / p.relative_to(_PACKAGE)
        dest.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(p, dest)
    shutil.copytree(models_dir(), package / "fmu_models")
    return package, package / "fmu_models"


def test_a_wheel_layout_has_the_checkouts_digest(tmp_path: Path) -> None:
    package, models = _wheel_layout(tmp_path)
    assert code_digest(package, models) == code_digest()


def test_one_changed_model_byte_changes_the_digest(tmp_path: Path) -> None:
    package, models = _wheel_layout(tmp_path)
    source = models / "common" / "model_core.c"
    source.write_bytes(source.read_bytes() + b"\n")
    assert code_digest(package, models) != code_digest()


def test_a_renamed_source_changes_the_digest(tmp_path: Path) -> None:
    package, models = _wheel_layout(tmp_path)
    (package / "frames.py").rename(package / "frames2.py")
    assert code_digest(package, models) != code_digest()


def test_the_command_line_and_benchmarks_are_not_in_it(tmp_path: Path) -> None:
    package, models = _wheel_layout(tmp_path)
    (package / "cli" / "sim.py").write_text("# changed\n")
    (package / "bench" / "e2e.py").write_text("# changed\n")
    assert code_digest(package, models) == code_digest()


def test_an_editors_lock_and_backup_files_are_not_code(tmp_path: Path) -> None:
    # Emacs leaves `.#config.py`, a link to nowhere, while config.py is open: reading it made
    # every recorded run fail ("bad input") and `lfctl --version` print a traceback
    package, models = _wheel_layout(tmp_path)
    (package / ".#config.py").symlink_to(tmp_path / "nowhere")
    (package / "vision" / ".tracker.py.swp.py").write_text("not code")
    (models / "common" / ".#model_core.c").symlink_to(tmp_path / "nowhere")
    assert code_digest(package, models) == code_digest()


def test_a_source_that_cannot_be_read_is_an_unknown_identity_not_a_failure(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    package, models = _wheel_layout(tmp_path)
    monkeypatch.setattr(data, "_PACKAGE_DIR", package)
    monkeypatch.setattr(data, "models_dir", lambda: models)
    assert data.code_identity() == code_digest()
    read_bytes = Path.read_bytes

    def refused(self: Path) -> bytes:
        if self.name == "frames.py":
            raise PermissionError(13, "Permission denied", str(self))
        return read_bytes(self)

    monkeypatch.setattr(Path, "read_bytes", refused)
    assert data.code_identity() == f"unknown (Permission denied: {package / 'frames.py'})"
