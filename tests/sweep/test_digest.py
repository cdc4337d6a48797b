"""The code digest a sweep's workers are checked by: the same for a source checkout and a wheel
of the same commit, different when one source byte differs."""

from __future__ import annotations

import shutil
from pathlib import Path

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
