"""Packaging beyond what pyproject.toml can say: the top-level folders ``fmu_models/`` (the
vehicle models' C sources), ``examples/`` and ``footage/`` (labelled real video for the vision
benchmark) and ``docs/`` travel inside the package, as ``lfctl/fmu_models``, ``lfctl/examples``,
``lfctl/footage`` and ``lfctl/docs``, so a wheel builds its FMUs, runs the examples by name
from any directory and has the pages its help names (``lfctl.data`` finds them in either place). Each of their folders is named as a package of
its own (``lfctl.examples.sweeps``), as setuptools wants every folder of package data to be.

Only the project's own files travel: in a git checkout, those git lists (tracked, or new and
not ignored: a run's ``logs/``, ``bench-results.*``), and anywhere, none that is a build
product or an editor's leftover (:data:`SKIP`). Without that, ``pip install .`` shipped
whatever a user had left in those folders (a log of 10 MB, ``convoy.toml~``, ``a.out``).

Every build copies the package afresh: setuptools' ``build_py`` keeps a file already in
``build/lib`` unless the source is newer, so a tree copied without its times (``cp -r``,
``scp -r``) over an old ``build/`` would ship the old code, and a deleted module would stay."""

import fnmatch
import glob
import shutil
import subprocess
import sys
from pathlib import Path

from setuptools import find_packages, setup
from setuptools.command.build_py import build_py

ROOTS = {
    "lfctl.fmu_models": "fmu_models",
    "lfctl.examples": "examples",
    "lfctl.footage": "footage",
    "lfctl.docs": "docs",
}


#: files and folders under the data roots that never ship: build products, logs, benchmark
#: tables and editors' leftovers (what ``.gitignore`` says, for a tree that is not a checkout)
SKIP = ("*~", ".#*", "#*#", "*.swp", "*.swo", "*.orig", "*.rej", "*.o", "*.so", "*.fmu", "*.pyc", "a.out",
        "*.mcap", "bench-results.*", ".DS_Store")  # fmt: skip
SKIP_FOLDERS = ("__pycache__", "logs", ".build-*")


def _git_files() -> set[str] | None:
    """The files git lists in this checkout (tracked, and new ones it does not ignore), as
    paths from setup.py's folder; None outside a checkout (an sdist) or without git."""
    here = Path(__file__).resolve().parent
    if not (here / ".git").exists():
        return None
    try:
        listed = subprocess.run(
            ["git", "ls-files", "--cached", "--others", "--exclude-standard", "-z"],
            cwd=here,
            capture_output=True,
            check=True,
            timeout=120,
        ).stdout
    except (OSError, subprocess.SubprocessError) as exc:  # no git, or one refusing the folder (another owner's)
        why = exc.stderr.decode(errors="replace").strip() if isinstance(exc, subprocess.CalledProcessError) else exc
        print(f"setup.py: git ls-files failed ({why}): packaging every file not in SKIP", file=sys.stderr)
        return None
    return set(filter(None, listed.decode("utf-8", "surrogateescape").split("\0")))


def _shipped(path: Path, listed: set[str] | None) -> bool:
    """A file under a data root that travels with the package (not one whose name is not
    UTF-8: a wheel's file list cannot hold it, and setuptools failed the build on it)."""
    try:
        path.as_posix().encode("utf-8")
    except UnicodeEncodeError:
        print(f"setup.py: {path.as_posix()!r}: a file name that is not UTF-8 is left out", file=sys.stderr)
        return False
    if any(fnmatch.fnmatch(path.name, pattern) for pattern in SKIP):
        return False
    if any(fnmatch.fnmatch(part, pattern) for part in path.parts[:-1] for pattern in SKIP_FOLDERS):
        return False
    return listed is None or path.as_posix() in listed


def _data_packages() -> tuple[dict[str, str], dict[str, list[str]]]:
    """Every folder under the data roots that has files to ship, as a package name -> its
    folder, and each package's files. A sweep's output (a folder holding ``sweep.json``:
    ``lfctl sweep`` run inside ``examples/``) never ships."""
    listed = _git_files()
    folders, files = {}, {}
    for package, root in ROOTS.items():
        sweeps = {f.parent for f in Path(root).rglob("sweep.json")}
        for folder in [Path(root), *sorted(p for p in Path(root).rglob("*") if p.is_dir())]:
            if sweeps & {folder, *folder.parents}:
                continue
            names = sorted(f.name for f in folder.iterdir() if f.is_file() and _shipped(f, listed))
            if names and any(c in folder.as_posix() for c in "[]*?"):  # package_data's patterns start with it
                raise SystemExit(f"setup.py: {folder}: a folder whose name has [, ], * or ? cannot be packaged")
            if names:
                name = ".".join((package, *folder.relative_to(root).parts))
                folders[name] = folder.as_posix()
                files[name] = [glob.escape(n) for n in names]  # (package_data takes patterns)
    return folders, files


class FreshBuildPy(build_py):
    """``build_py`` from an empty ``build/lib/lfctl``: nothing of an earlier build is kept."""

    def run(self) -> None:
        old = Path(self.build_lib).resolve() / "lfctl"
        if old != (Path(__file__).resolve().parent / "lfctl") and old.is_dir():  # (never the sources: --build-lib .)
            shutil.rmtree(old)  # a failure is the build's: stale files must not ship quietly
        super().run()


DATA, FILES = _data_packages()

setup(
    packages=[*find_packages(include=["lfctl", "lfctl.*"]), *DATA],
    package_dir=DATA,
    package_data=FILES,
    cmdclass={"build_py": FreshBuildPy},
)
