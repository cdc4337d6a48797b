"""Build the built-in vehicle FMUs (FMI 2.0 and 3.0 Co-Simulation) from fmu_models/.

A model folder holds ``config.h`` (identity and the variable table as an X-macro) and
``model.c``; ``fmu_models/common`` holds the model core and the two FMI wrappers. The variable
table is the single source: the C core compiles it, and this module parses it to write both
``modelDescription.xml`` files. Builds land in a content-hashed cache (sources, compiler
version, flags), so a second call costs only the hash; without a compiler on PATH, a build
of the same sources by any compiler is taken from it.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import logging
import os
import re
import shutil
import stat
import subprocess
import sysconfig
import tempfile
import time
import xml.etree.ElementTree as ET
import zipfile
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import fmpy

from lfctl.data import builtin_models, cache_error, models_dir, user_cache
from lfctl.errors import BuildToolError, ConfigError, FmuError
from lfctl.fmu.archive import pid_alive

__all__ = [
    "BuiltModel",
    "ModelSource",
    "ModelVariable",
    "available_models",
    "build_model",
    "build_model_folder",
    "parse_model_source",
]

log = logging.getLogger(__name__)

CFLAGS = ("-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-fvisibility=hidden", "-fPIC", "-shared")
#: Bump when the generated XML or archive layout changes, to invalidate old caches.
GENERATOR_VERSION = "3"

_UNIT_BASE = {  # unit name -> SI base-unit exponents for <BaseUnit>
    "m": {"m": 1},
    "s": {"s": 1},
    "rad": {"rad": 1},
    "m/s": {"m": 1, "s": -1},
    "m/s2": {"m": 1, "s": -2},
    "rad/s": {"rad": 1, "s": -1},
}

_VAR_RE = re.compile(
    r"X\(\s*(\w+)\s*,\s*(INPUT|OUTPUT|PARAMETER)\s*,\s*(FIXED|TUNABLE|CONTINUOUS)\s*,\s*"
    r'([-+0-9.eE]+)\s*,\s*"([^"]*)"\s*,\s*"([^"]*)"\s*\)'
)


@dataclass(frozen=True)
class ModelVariable:
    """One variable of a built-in model, as declared in its config.h."""

    value_reference: int  # its FMI value reference: its place in the table, 0 for time
    name: str  # the variable's name in the FMU
    causality: str  # "input" | "output" | "parameter" | "independent"
    variability: str  # "fixed" | "tunable" | "continuous"
    start: float  # start value (inputs and parameters)
    unit: str  # e.g. "m/s"; m, s, rad and their rates are declared with a <BaseUnit>
    description: str  # the variable's description in the XML


@dataclass(frozen=True)
class ModelSource:
    """A built-in model's identity and variable table, parsed from config.h."""

    identifier: str  # MODEL_IDENTIFIER: the FMU's model identifier and library name
    token: str  # INSTANTIATION_TOKEN: FMI 2 guid, FMI 3 instantiationToken
    description: str  # MODEL_DESCRIPTION_TEXT
    n_states: int  # N_STATES: continuous states of the model
    variables: tuple[ModelVariable, ...]  # time first, then the X(...) table in order
    folder: Path  # the model's source folder


@dataclass(frozen=True)
class BuiltModel:
    """Paths of one model's built FMUs."""

    identifier: str  # the model identifier
    fmi2: Path  # the FMI 2.0 Co-Simulation FMU
    fmi3: Path  # the FMI 3.0 Co-Simulation FMU

    def path(self, fmi_version: int) -> Path:
        """The FMU for one FMI version.

        Parameters
        ----------
        fmi_version : int
            2 or 3 (FmuError for another).
        """
        if fmi_version == 2:
            return self.fmi2
        if fmi_version == 3:
            return self.fmi3
        raise FmuError(f"FMI version must be 2 or 3, got {fmi_version!r}", model=self.identifier)


def _define(text: str, name: str, config: Path) -> str:
    m = re.search(rf"#define\s+{name}\s+(.+)", text)
    if not m:
        raise FmuError(f"{config}: missing #define {name}", model=str(config.parent.name))
    return m.group(1).strip().strip('"')


def parse_model_source(folder: Path) -> ModelSource:
    """Parse a model folder's config.h into a :class:`ModelSource`.

    Parameters
    ----------
    folder : Path
        A model folder of fmu_models/ (``config.h``, ``model.c``).

    Raises
    ------
    FmuError
        config.h unreadable, a ``#define`` missing, or no ``X(...)`` variables.
    """
    config = folder / "config.h"
    try:
        text = config.read_text()
    except OSError as exc:
        raise FmuError(f"cannot read {config}: {exc}", model=folder.name) from exc
    variables = [ModelVariable(0, "time", "independent", "continuous", 0.0, "s", "Simulation time")]
    for i, m in enumerate(_VAR_RE.finditer(text), start=1):
        name, caus, var, start, unit, desc = m.groups()
        variables.append(ModelVariable(i, name, caus.lower(), var.lower(), float(start), unit, desc))
    if len(variables) == 1:
        raise FmuError(f"{config}: no X(...) variables in MODEL_VARIABLES", model=folder.name)
    return ModelSource(
        identifier=_define(text, "MODEL_IDENTIFIER", config),
        token=_define(text, "INSTANTIATION_TOKEN", config),
        description=_define(text, "MODEL_DESCRIPTION_TEXT", config),
        n_states=int(_define(text, "N_STATES", config)),
        variables=tuple(variables),
        folder=folder,
    )


#: names of the built-in models (folders of fmu_models/ with a config.h)
available_models = builtin_models


def _units_element(parent: ET.Element, units: set[str], fmi_version: int) -> None:
    defs = ET.SubElement(parent, "UnitDefinitions")
    for unit in sorted(u for u in units if u in _UNIT_BASE):
        el = ET.SubElement(defs, "Unit", name=unit)
        ET.SubElement(el, "BaseUnit", {k: str(v) for k, v in _UNIT_BASE[unit].items()})


def _fmt(value: float) -> str:
    return repr(float(value))


def model_description_xml(src: ModelSource, fmi_version: int) -> bytes:
    """The modelDescription.xml of ``src`` for FMI ``fmi_version`` (2 or 3)."""
    units = {v.unit for v in src.variables if v.unit in _UNIT_BASE}
    sources = ["model_core.c", f"fmi{fmi_version}_wrapper.c", "model.c"]
    if fmi_version == 2:
        root = ET.Element(
            "fmiModelDescription",
            fmiVersion="2.0",
            modelName=src.identifier,
            guid=src.token,
            description=src.description,
            generationTool=f"lfctl FMU generator {GENERATOR_VERSION}",
            variableNamingConvention="flat",
            numberOfEventIndicators="0",
        )
        cs = ET.SubElement(
            root,
            "CoSimulation",
            modelIdentifier=src.identifier,
            canHandleVariableCommunicationStepSize="true",
            canGetAndSetFMUstate="true",
            canSerializeFMUstate="true",
            canNotUseMemoryManagementFunctions="true",
        )
        files = ET.SubElement(cs, "SourceFiles")
        for name in sources:
            ET.SubElement(files, "File", name=name)
        _units_element(root, units, 2)
        ET.SubElement(root, "DefaultExperiment", startTime="0", stopTime="10", stepSize="0.01")
        mvars = ET.SubElement(root, "ModelVariables")
        for v in src.variables:
            attrs, real, initial = _variable_attributes(v)
            sv = ET.SubElement(mvars, "ScalarVariable", attrs | initial)  # FMI 2: unit and start on <Real>
            ET.SubElement(sv, "Real", real)
        ms = ET.SubElement(root, "ModelStructure")
        outputs = ET.SubElement(ms, "Outputs")
        initial = ET.SubElement(ms, "InitialUnknowns")
        for index, v in enumerate(src.variables, start=1):  # 1-based ScalarVariable index
            if v.causality == "output":
                ET.SubElement(outputs, "Unknown", index=str(index))
                ET.SubElement(initial, "Unknown", index=str(index))
    else:
        root = ET.Element(
            "fmiModelDescription",
            fmiVersion="3.0",
            modelName=src.identifier,
            instantiationToken=src.token,
            description=src.description,
            generationTool=f"lfctl FMU generator {GENERATOR_VERSION}",
            variableNamingConvention="flat",
        )
        ET.SubElement(
            root,
            "CoSimulation",
            modelIdentifier=src.identifier,
            canHandleVariableCommunicationStepSize="true",
            canGetAndSetFMUState="true",
            canSerializeFMUState="true",
            hasEventMode="false",
            providesIntermediateUpdate="false",
        )
        _units_element(root, units, 3)
        ET.SubElement(root, "DefaultExperiment", startTime="0", stopTime="10", stepSize="0.01")
        mvars = ET.SubElement(root, "ModelVariables")
        for v in src.variables:
            attrs, real, initial = _variable_attributes(v)
            ET.SubElement(mvars, "Float64", attrs | real | initial)  # FMI 3: all on the variable
        ms = ET.SubElement(root, "ModelStructure")
        for v in src.variables:
            if v.causality == "output":
                ET.SubElement(ms, "Output", valueReference=str(v.value_reference))
        for v in src.variables:
            if v.causality == "output":
                ET.SubElement(ms, "InitialUnknown", valueReference=str(v.value_reference))
    ET.indent(root)
    return b'<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="utf-8")


def _variable_attributes(v: ModelVariable) -> tuple[dict[str, str], dict[str, str], dict[str, str]]:
    """A model variable's XML attributes, its type's (``unit``, ``start``: FMI 2 puts them on
    a ``<Real>`` child, FMI 3 on the variable itself) and ``initial`` (outputs)."""
    attrs = {
        "name": v.name,
        "valueReference": str(v.value_reference),
        "causality": v.causality,
        "variability": v.variability,
        "description": v.description,
    }
    real = {"unit": v.unit} if v.unit in _UNIT_BASE else {}
    if v.causality in ("input", "parameter"):
        real["start"] = _fmt(v.start)
    return attrs, real, {"initial": "calculated"} if v.causality == "output" else {}


def build_description_xml(src: ModelSource) -> bytes:
    """FMI 3 ``sources/buildDescription.xml`` so importers can rebuild the binary."""
    root = ET.Element("fmiBuildDescription", fmiVersion="3.0")
    cfg = ET.SubElement(root, "BuildConfiguration", modelIdentifier=src.identifier)
    fileset = ET.SubElement(cfg, "SourceFileSet", language="C99")
    for name in ("model_core.c", "fmi3_wrapper.c", "model.c"):
        ET.SubElement(fileset, "SourceFile", name=name)
    ET.indent(root)
    return b'<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="utf-8")


def find_compiler() -> str:
    """Path of the system C compiler (cc, gcc or clang), or a :class:`BuildToolError`."""
    for name in ("cc", "gcc", "clang"):
        path = shutil.which(name)
        if path:
            return path
    raise BuildToolError(
        "no C compiler on PATH (looked for cc, gcc, clang): the vehicle FMUs are built from C; "
        "install one, e.g. `apt-get install gcc` on Debian/Ubuntu",
        call="build",
    )


def _compiler_version(compiler: str) -> str:
    try:
        out = subprocess.run([compiler, "--version"], capture_output=True, text=True, timeout=30, check=True)
    except (OSError, subprocess.SubprocessError) as exc:
        raise BuildToolError(f"C compiler {compiler} does not run: {exc}", call="build") from exc
    return out.stdout.splitlines()[0] if out.stdout else compiler


def _source_files(src_folder: Path, fmi_version: int) -> list[Path]:
    return [
        models_dir() / "common" / "model_core.h",
        models_dir() / "common" / "model_core.c",
        models_dir() / "common" / f"fmi{fmi_version}_wrapper.c",
        src_folder / "config.h",
        src_folder / "model.c",
    ]


def cache_key(src: ModelSource, compiler_version: str) -> str:
    """Content hash of everything that determines the built FMUs."""
    h = hashlib.sha256()
    for part in (GENERATOR_VERSION, compiler_version, " ".join(CFLAGS), fmpy.__version__):
        h.update(part.encode() + b"\0")
    for fmi in (2, 3):
        for f in _source_files(src.folder, fmi):
            h.update(f.name.encode() + b"\0" + f.read_bytes() + b"\0")
    return h.hexdigest()[:16]


#: in each cache entry: the cache key of its sources without the compiler's version, so that
#: a machine whose compiler has gone (a rover's computer, a slimmed image) still finds them
SOURCES_KEY_FILE = "sources.key"


def _sources_key(src: ModelSource) -> str:
    """The cache key of ``src``'s sources without the compiler's version, on this machine's
    platform (a cache copied from another architecture never matches)."""
    return cache_key(src, f"any compiler, {sysconfig.get_platform()}")


def _built_from_same_sources(src: ModelSource, cache_root: Path) -> BuiltModel | None:
    """The newest cache entry built from ``src``'s sources (and this generator, flags and
    fmpy) by any compiler, or None: what runs when no compiler is on PATH."""
    want = _sources_key(src)
    found: list[tuple[int, BuiltModel]] = []
    for entry in cache_root.glob(f"{src.identifier}-*"):
        built = BuiltModel(src.identifier, entry / f"{src.identifier}.fmi2.fmu", entry / f"{src.identifier}.fmi3.fmu")
        try:
            if (entry / SOURCES_KEY_FILE).read_text().strip() == want and built.fmi2.is_file() and built.fmi3.is_file():
                found.append(((entry / SOURCES_KEY_FILE).stat().st_mtime_ns, built))
        except OSError:
            continue  # an entry from before the file, or one being replaced
    return max(found, key=lambda f: f[0])[1] if found else None


def default_cache_dir() -> Path:
    """Where built FMUs are kept: the user cache directory (``~/.cache/lfctl/fmu`` on Linux)."""
    return user_cache("fmu")


def _compile(compiler: str, sources: list[Path], include_dirs: list[Path], out: Path, model: str) -> None:
    cmd = [compiler, *CFLAGS, *(f"-I{d}" for d in include_dirs), *(str(s) for s in sources), "-lm", "-o", str(out)]
    try:
        res = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    except (OSError, subprocess.SubprocessError) as exc:
        raise BuildToolError(f"compiling {model} failed to start: {exc}", model=model, call="compile") from exc
    if res.returncode != 0:
        raise BuildToolError(
            f"compiling {model} failed (exit {res.returncode}):\n{res.stderr.strip()}", model=model, call="compile"
        )


def _package(src: ModelSource, fmi_version: int, compiler: str, work: Path, out: Path) -> None:
    stage = work / f"fmi{fmi_version}"
    sources_dir = stage / "sources"
    sources_dir.mkdir(parents=True)
    for f in _source_files(src.folder, fmi_version):
        shutil.copy2(f, sources_dir / f.name)
    platform = fmpy.platform if fmi_version == 2 else fmpy.platform_tuple
    bin_dir = stage / "binaries" / platform
    bin_dir.mkdir(parents=True)
    c_sources = [sources_dir / n for n in ("model_core.c", f"fmi{fmi_version}_wrapper.c", "model.c")]
    fmi_headers = Path(fmpy.__file__).parent / "c-code"
    _compile(compiler, c_sources, [sources_dir, fmi_headers], bin_dir / f"{src.identifier}.so", src.identifier)
    (stage / "modelDescription.xml").write_bytes(model_description_xml(src, fmi_version))
    if fmi_version == 3:
        (sources_dir / "buildDescription.xml").write_bytes(build_description_xml(src))
    readme = src.folder / "readme.md"
    if readme.is_file():
        (stage / "documentation").mkdir()
        shutil.copy2(readme, stage / "documentation" / "readme.md")
    with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as zf:
        for f in sorted(stage.rglob("*")):
            if f.is_file():
                zf.write(f, f.relative_to(stage).as_posix())


def build_model(name: str, cache_dir: Path | None = None, *, force: bool = False) -> BuiltModel:
    """Build (or fetch from the cache) FMI 2 and FMI 3 FMUs of built-in model ``name``.

    Parameters
    ----------
    name : str
        A folder of fmu_models/, e.g. ``"SkidSteerRover"``.
    cache_dir : Path, optional
        Cache root; default :func:`default_cache_dir`.
    force : bool
        Rebuild even when the cache has this content hash.
    """
    known = available_models()
    if name not in known:  # a plain folder name: never a path out of the models folder
        where = f"known: {', '.join(known)}" if known else f"none found in {models_dir()}"
        raise FmuError(f"unknown built-in model {name!r} ({where})", model=name, call="build")
    return build_model_folder(models_dir() / name, cache_dir, force=force)


def build_model_folder(folder: Path, cache_dir: Path | None = None, *, force: bool = False) -> BuiltModel:
    """Build (or fetch from the cache) FMI 2 and FMI 3 FMUs of the model in any folder.

    The folder holds ``config.h`` and ``model.c`` as a folder of fmu_models/ does; the
    shared core and wrappers come from fmu_models/common. :func:`build_model` calls this
    for the built-in models; the tests build their own models with it (a model whose
    outputs go NaN, one whose doStep never returns).

    Parameters
    ----------
    folder : Path
        The model's folder.
    cache_dir : Path, optional
        Cache root; default :func:`default_cache_dir`.
    force : bool
        Rebuild even when the cache has this content hash.
    """
    src = parse_model_source(folder)
    cache_root = cache_dir or default_cache_dir()
    try:
        compiler = find_compiler()
    except BuildToolError:
        earlier = None if force else _built_from_same_sources(src, cache_root)
        if earlier is None:
            raise
        log.info("no C compiler on PATH: the %s FMUs built earlier from these sources run", src.identifier)
        return earlier
    key = cache_key(src, _compiler_version(compiler))
    root = cache_root / f"{src.identifier}-{key}"
    built = BuiltModel(src.identifier, root / f"{src.identifier}.fmi2.fmu", root / f"{src.identifier}.fmi3.fmu")
    if not force and built.fmi2.is_file() and built.fmi3.is_file():
        if not (root / SOURCES_KEY_FILE).is_file():  # an entry built before the file was kept
            with contextlib.suppress(OSError):
                (root / SOURCES_KEY_FILE).write_text(_sources_key(src) + "\n")
        return built
    try:
        root.parent.mkdir(parents=True, exist_ok=True)
    except (FileExistsError, NotADirectoryError):
        raise ConfigError(f"the FMU cache {root.parent} is not a folder") from None
    except OSError as exc:  # no home, or one that is not this user's
        raise cache_error(root.parent, exc, given=cache_dir is not None) from None
    try:
        # one builder at a time per entry: the workers of a sweep on a cold cache start together,
        # and a second build replacing the first would pull the files from under its readers
        with _locked(root.parent / f".{root.name}.lock"):
            if not force and built.fmi2.is_file() and built.fmi3.is_file():
                return built  # built by another process while this one waited
            log.info("building %s FMUs into %s", src.identifier, root)
            _remove_dead_builds(root.parent)
            with tempfile.TemporaryDirectory(dir=root.parent, prefix=f".build-{os.getpid()}-") as tmp:
                work = Path(tmp)
                out_dir = work / "out"
                out_dir.mkdir()
                for fmi in (2, 3):
                    _package(src, fmi, compiler, work, out_dir / built.path(fmi).name)
                (out_dir / SOURCES_KEY_FILE).write_text(_sources_key(src) + "\n")
                if root.exists():
                    shutil.rmtree(root)
                os.replace(out_dir, root)  # atomic: a half-built cache entry is never visible
    except PermissionError as exc:  # a cache another user made: its entries read, but none added
        raise cache_error(root.parent, exc, given=cache_dir is not None) from None
    return built


#: a build folder older than this whose process is gone was left by a build that was killed, s
#: (a build takes seconds, each compile at most 300 s; the age keeps a build on another machine
#: or in another PID namespace that shares the cache, whose process id means nothing here)
STALE_BUILD_S = 3600.0


def _remove_dead_builds(cache: Path) -> list[Path]:
    """Remove the build folders (``.build-<pid>-...``) in ``cache`` that this user's builds
    left when they were killed: older than :data:`STALE_BUILD_S` and their process gone
    (folders from before the process id was in the name: by age alone); the folders removed.
    Another user's, or a live process's, are left alone."""
    removed = []
    now = time.time()
    for folder in cache.glob(".build-*"):
        pid = folder.name.split("-")[1] if folder.name.count("-") >= 2 else ""
        try:
            st = folder.lstat()
        except OSError:
            continue
        if not stat.S_ISDIR(st.st_mode) or st.st_uid != os.getuid() or now - st.st_mtime < STALE_BUILD_S:
            continue
        if pid.isdigit() and (int(pid) == os.getpid() or pid_alive(int(pid))):
            continue
        shutil.rmtree(folder, ignore_errors=True)
        removed.append(folder)
        log.info("removed %s, left by a build that was killed", folder)
    return removed


@contextlib.contextmanager
def _locked(path: Path) -> Iterator[None]:
    """An exclusive ``flock`` on ``path`` (created if need be) while the block runs, across
    processes. Opened read-only: a lock file another user made in a shared cache still
    locks. Waiters wait as long as the build takes (each compile is bounded by its timeout);
    if it fails, the next one tries in turn."""
    fd = os.open(path, os.O_RDONLY | os.O_CREAT, 0o666)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)  # closing releases the lock
