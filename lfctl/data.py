"""Files that travel with lfctl: the vehicle models' C sources (``fmu_models/``), the
example scenarios (``examples/``), labelled real video (``footage/``) and the docs
(``docs/``); and the digest of lfctl's code, which tells two builds of one version apart.

They live at the top of the source tree, where a reader looks for them; the wheel and the
sdist carry them inside the package (``lfctl/fmu_models``, ``lfctl/examples``, see
``setup.py``). These functions find them in either place, so a source checkout, an editable
install, ``pip install .`` and a wheel behave alike.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import os
from pathlib import Path
from typing import Any

from lfctl.errors import ConfigError, LfctlError

__all__ = [
    "cache_error",
    "code_digest",
    "code_identity",
    "docs_dir",
    "example_names",
    "examples_dir",
    "find_example",
    "footage_dir",
    "loaded_code",
    "models_dir",
    "pyplot",
    "resolve_footage",
    "resolve_mission",
    "resolve_scenario",
    "user_cache",
]

_PACKAGE_DIR = Path(__file__).resolve().parent


def _folder(name: str) -> Path:
    inside = _PACKAGE_DIR / name  # installed from a wheel or sdist
    if inside.is_dir():
        return inside
    return _PACKAGE_DIR.parent / name  # a source checkout (editable install)


def user_cache(sub: str) -> Path:
    """``sub`` in the user cache directory (``~/.cache/lfctl/<sub>`` on Linux): what lfctl
    makes on first use and keeps (built FMUs, cut texture plates, Foxglove layouts).

    Parameters
    ----------
    sub : str
        The folder's name.
    """
    import platformdirs

    return Path(platformdirs.user_cache_dir("lfctl")) / sub


def cache_error(folder: Path, exc: OSError, given: bool = False) -> LfctlError:
    """The error for a cache folder this user cannot make or write in (no home, a home
    that is not theirs, a cache another user made): which folder, why, whose it is when it
    is another user's, and how to put the cache elsewhere.

    Parameters
    ----------
    folder : Path
        The cache folder.
    exc : OSError
        What failed.
    given : bool
        The folder was given on the command line (``--cache-dir``), not lfctl's default.
    """
    owner = ""
    for place in (folder, *folder.parents):  # the nearest part that exists
        try:
            uid = place.stat().st_uid
        except OSError:
            continue
        if uid != os.getuid():
            try:
                import pwd

                name = pwd.getpwuid(uid).pw_name
            except (ImportError, KeyError):
                name = f"uid {uid}"
            owner = f"; {place} belongs to {name}"
        break
    how = (
        "give a folder this user can write"
        if given
        else "set XDG_CACHE_HOME to a folder this user can write (lfctl's cache is then $XDG_CACHE_HOME/lfctl)"
    )
    return LfctlError(f"cannot write lfctl's cache {folder} ({exc.strerror or exc}{owner}): {how}")


def pyplot() -> Any:
    """matplotlib's pyplot on the Agg backend (files, no display). Where matplotlib's own
    folder cannot be made (a user without a writable home: a service, a container), it is
    put in lfctl's cache when that one can be (``XDG_CACHE_HOME``): matplotlib otherwise
    warned twice on every plotting run and built its font cache afresh each time."""
    if "MPLCONFIGDIR" not in os.environ:
        try:
            home = Path(os.environ.get("XDG_CONFIG_HOME") or Path.home() / ".config") / "matplotlib"
            home.mkdir(parents=True, exist_ok=True)
            usable = os.access(home, os.W_OK)
        except (OSError, RuntimeError):  # (RuntimeError: no home at all)
            usable = False
        if not usable:
            with contextlib.suppress(OSError):
                mine = user_cache("matplotlib")
                mine.mkdir(parents=True, exist_ok=True)
                os.environ["MPLCONFIGDIR"] = str(mine)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def models_dir() -> Path:
    """The folder of vehicle model C sources: one sub-folder per model, plus ``common/``."""
    return _folder("fmu_models")


@functools.cache
def builtin_models() -> tuple[str, ...]:
    """Names of the built-in vehicle models (folders of :func:`models_dir` with a ``config.h``),
    read once: every scenario's vehicles (a sweep's hundreds of variants) are checked against it."""
    folder = models_dir()
    if not folder.is_dir():
        return ()
    return tuple(sorted(p.name for p in folder.iterdir() if (p / "config.h").is_file()))


def examples_dir() -> Path:
    """The folder of shipped example scenarios (``convoy.toml``, ...) and missions."""
    return _folder("examples")


def docs_dir() -> Path:
    """The folder of the documentation pages (``audit.md``, ``architecture.md``, ...)."""
    return _folder("docs")


def footage_dir() -> Path:
    """The folder of labelled real video (its ``README.md`` says where each file comes from)."""
    return _folder("footage")


def code_digest(package: Path | None = None, models: Path | None = None) -> str:
    """SHA-256 over lfctl's Python sources (but the command line and the benchmarks) and the
    vehicle models' C sources: two processes with the same digest run the same simulation.

    Each file is named in the digest by its path inside the package, or inside the models
    folder (under ``fmu_models/``), whichever holds it: a source checkout (the models beside
    the package) and a wheel of the same commit (the models inside it) give the same digest.

    Parameters
    ----------
    package : Path, optional
        The ``lfctl`` package folder (default: this one).
    models : Path, optional
        The vehicle models' folder (default :func:`~lfctl.data.models_dir`).
    """
    package = _PACKAGE_DIR if package is None else package
    models = models_dir() if models is None else models

    def source(p: Path, root: Path) -> bool:
        # an editor's lock or backup (.#config.py, a dangling link) is not the code
        return p.is_file() and not any(part.startswith(".") for part in p.relative_to(root).parts)

    sources = [
        p
        for p in sorted(package.rglob("*.py"))
        if p.relative_to(package).parts[0] not in ("cli", "bench") and source(p, package)
    ]
    named = [(p.relative_to(package).as_posix(), p) for p in sources]
    named += [
        ("fmu_models/" + p.relative_to(models).as_posix(), p)
        for p in sorted(models.rglob("*"))
        if p.suffix in (".c", ".h") and source(p, models)
    ]
    h = hashlib.sha256()
    for name, p in named:
        h.update(name.encode())
        h.update(p.read_bytes())
    return h.hexdigest()


def code_identity() -> str:
    """:func:`code_digest`, or ``unknown (why)`` when a source cannot be read: what a log's
    provenance and ``lfctl --version`` say, never a reason for them to fail."""
    try:
        return code_digest()
    except OSError as exc:
        return f"unknown ({exc.strerror or exc}: {exc.filename})"


@functools.cache
def loaded_code() -> str:
    """:func:`code_identity` once per process, at its first use (the sweep's engine asks at
    import): the code this process runs, which the files may no longer be, worked out once
    however many runs it records."""
    return code_identity()


def example_names(suffix: str = ".toml", sub: str = "") -> list[str]:
    """Names of the shipped example files (file stems), sorted.

    Parameters
    ----------
    suffix : str
        The kind of file: ``.toml`` scenarios, ``.waypoints`` missions.
    sub : str
        A folder of the examples (``sweeps``: the shipped sweeps); default the examples' own.
    """
    folder = examples_dir() / sub
    return sorted(p.stem for p in folder.glob(f"*{suffix}")) if folder.is_dir() else []


def find_example(name: str, suffix: str = ".toml") -> Path | None:
    """The shipped example file called ``name`` (``convoy``, ``convoy.toml``,
    ``square.waypoints``), or None.

    Parameters
    ----------
    name : str
        A file name in the examples folder, with or without ``suffix``.
    suffix : str
        The suffix a bare name is tried with.
    """
    folder = examples_dir()
    for candidate in (name, f"{name}{suffix}"):
        p = folder / candidate
        if "/" not in candidate and p.is_file():
            return p
    return None


def _shipped_path(p: Path) -> bool:
    """``examples/NAME`` where there is no such file: the README's commands, run from a
    wheel's install (no ``examples`` folder here), name the shipped file."""
    return len(p.parts) == 2 and p.parts[0] == "examples" and not p.exists()


def resolve_scenario(arg: str | Path) -> Path:
    """A scenario argument as a path: an existing file, else a shipped example by name.

    Parameters
    ----------
    arg : str or Path
        A path to a TOML file, or an example's name (``convoy``; ``examples/convoy.toml``
        too where there is no such file, as the README writes it).

    Raises
    ------
    ConfigError
        Neither an existing file nor a shipped example; the message lists the examples.
    """
    p = Path(arg)
    if p.is_file():
        return p
    found = find_example(p.name) if p.name == str(arg) or _shipped_path(p) else None
    if found is not None:
        return found
    known = ", ".join(example_names()) or "none found"
    raise ConfigError(f"scenario {str(arg)!r} is neither a file nor a shipped example (examples: {known})")


def resolve_footage(arg: str) -> str:
    """A video argument with shipped footage found by name: ``bikes.mp4`` or
    ``footage/bikes.mp4`` where there is no such file here is the shipped clip (a wheel's
    user has no ``footage`` folder); anything else (a file here, a camera index, a URL, a
    path with other folders) as it is, for the video source to judge.

    Parameters
    ----------
    arg : str
        What was given as the video source.
    """
    p = Path(arg)
    if "://" in arg or arg.isdigit() or p.exists():
        return arg
    if len(p.parts) == 1 or (len(p.parts) == 2 and p.parts[0] == "footage"):
        shipped = footage_dir() / p.name
        if shipped.is_file():
            return str(shipped)
    return arg


def resolve_mission(arg: str | Path) -> Path:
    """A mission file argument as a path: an existing file, else a shipped mission by its file
    name (``square.waypoints``, or ``square``), so a wheel's user can upload the examples.

    Parameters
    ----------
    arg : str or Path
        A path to a QGC WPL file, or a shipped mission's name (``examples/square.waypoints``
        too where there is no such file, as the README writes it).

    Raises
    ------
    ConfigError
        A bare name that is neither a file here nor a shipped mission; the message lists the
        shipped ones. A path with a folder is returned as it is, for the reader to judge.
    """
    p = Path(arg)
    if p.exists() or (p.name != str(arg) and not _shipped_path(p)):
        return p  # a file here (a pipe, a folder: its reader says so), or a path with a folder: the user's
    found = find_example(p.name, ".waypoints")
    if found is not None:
        return found
    if p.name != str(arg):
        return p
    known = ", ".join(f"{n}.waypoints" for n in example_names(".waypoints"))
    raise ConfigError(
        f"cannot read mission {str(arg)!r}: no such file here, nor a shipped mission (shipped: {known or 'none found'})"
    )
