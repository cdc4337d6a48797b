"""Packaging beyond what pyproject.toml can say: the top-level folders ``fmu_models/`` (the
vehicle models' C sources), ``examples/`` and ``footage/`` (labelled real video for the vision
benchmark) and ``docs/`` travel inside the package, as ``lfctl/fmu_models``, ``lfctl/examples``,
``lfctl/footage`` and ``lfctl/docs``, so a wheel builds its FMUs, runs the examples by name
from any directory and has the pages its help names (``lfctl.data`` finds them in either place). Each of their folders is named as a package of
its own (``lfctl.examples.sweeps``), as setuptools wants every folder of package data to be.

Every build copies the package afresh: setuptools' ``build_py`` keeps a file already in
``build/lib`` unless the source is newer, so a tree copied without its times (``cp -r``,
``scp -r``) over an old ``build/`` would ship the old code, and a deleted module would stay."""

import shutil
from pathlib import Path

from setuptools import find_packages, setup
from setuptools.command.build_py import build_py

ROOTS = {
    "lfctl.fmu_models": "fmu_models",
    "lfctl.examples": "examples",
    "lfctl.footage": "footage",
    "lfctl.docs": "docs",
}


def _data_packages() -> dict[str, str]:
    """Every folder under the data roots as a package name -> its folder."""
    out = {}
    for package, root in ROOTS.items():
        for folder in [Path(root), *sorted(p for p in Path(root).rglob("*") if p.is_dir())]:
            if "__pycache__" in folder.parts:
                continue
            rel = folder.relative_to(root).parts
            out[".".join((package, *rel))] = folder.as_posix()
    return out


class FreshBuildPy(build_py):
    """``build_py`` from an empty ``build/lib/lfctl``: nothing of an earlier build is kept."""

    def run(self) -> None:
        old = Path(self.build_lib).resolve() / "lfctl"
        if old != (Path(__file__).resolve().parent / "lfctl") and old.is_dir():  # (never the sources: --build-lib .)
            shutil.rmtree(old)  # a failure is the build's: stale files must not ship quietly
        super().run()


DATA = _data_packages()

setup(
    packages=[*find_packages(include=["lfctl", "lfctl.*"]), *DATA],
    package_dir=DATA,
    package_data={package: ["*"] for package in DATA},
    cmdclass={"build_py": FreshBuildPy},
)
