"""Sweep files: a base scenario and its variations, expanded into validated runs.

A sweep file is TOML::

    name = "noise"                      # default: the file's stem
    scenario = "convoy"                 # a file (relative to the sweep file) or a shipped example
    seeds = 20                          # seeds 1..20, or a list: [3, 7, 11]
    repetitions = 1                     # runs of each (variant, seed): > 1 repeats identical runs
    images = false                      # camera frames in the runs' logs (`--logs`)

    [set]                               # every run
    "sim.duration_s" = 30
    "sim.sensing" = "truth"

    [grid]                              # every combination of these values
    "sensing.range_noise_m" = [0.0, 0.05, 0.1]
    "guidance.controller" = ["smc", "p"]

    [random]                            # samples drawn with their own seed, crossed with the grid
    seed = 7
    samples = 10
    "sensing.bearing_noise_deg" = { uniform = [0.0, 3.0] }

A key is a dotted path into the scenario's tables: ``sensing.range_noise_m``,
``scene.lighting[1].gain`` (the second ``[[scene.lighting]]``), ``vehicles[1].range_m`` or
``vehicles[follower1].range_m`` (by position or by name). Keys are set on the scenario's
TOML tables, so ``_deg`` keys work as in a scenario file; a table that is missing is made,
an array entry that is missing is an error. Quote keys with brackets or dots
(``"scene.lighting[1].gain"``); unquoted dotted keys nest and mean the same.

Distributions for ``[random]``: ``uniform = [lo, hi]``, ``loguniform = [lo, hi]``,
``normal = [mean, sigma]``, ``integers = [lo, hi]`` (both ends included), ``choice = [...]``.

Variants are the grid's combinations (first key slowest) crossed with the samples; runs are
the variants crossed with the seeds and repetitions. :func:`plan` builds and validates every
variant before anything runs; an error names the variant, its values and the key.
"""

from __future__ import annotations

import copy
import dataclasses
import datetime
import hashlib
import itertools
import json
import math
import re
import tomllib
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path, PurePath
from typing import Any

import numpy as np
import tomli_w

from lfctl.config import Config, config_from_table, read_toml, resolve_paths
from lfctl.data import example_names, examples_dir, resolve_scenario
from lfctl.errors import ConfigError

__all__ = [
    "DISTRIBUTIONS",
    "MAX_RUNS",
    "MAX_VARIANTS",
    "Run",
    "SweepPlan",
    "SweepSpec",
    "Variant",
    "find_sweep",
    "load_sweep",
    "parse_key",
    "parse_sweep",
    "plan",
    "set_key",
    "sweep_names",
    "sweeps_dir",
    "with_keys",
]

#: the distributions ``[random]`` draws from, and their two parameters
DISTRIBUTIONS = {
    "uniform": "[lo, hi]",
    "loguniform": "[lo, hi] (both > 0)",
    "normal": "[mean, sigma]",
    "integers": "[lo, hi] (both ends included)",
    "choice": "[value, ...]",
}
_TOP_KEYS = ("name", "scenario", "seeds", "repetitions", "images", "set", "grid", "random", "description")
#: keys a sweep may not vary: the seed comes from ``seeds``; runs in parallel cannot share UDP ports
_RESERVED = {"sim.seed": "seeds", "name": "the sweep's name"}
#: most variants (grid combinations x samples) one sweep may have: each is built and checked
#: before anything runs, and written to the sweep's folder
MAX_VARIANTS = 10_000
#: most runs (variants x seeds x repetitions) one sweep may have
MAX_RUNS = 100_000
#: the largest scenario seed (``sim.seed``'s range)
_MAX_SEED = 2**63 - 1
#: the largest integer [random] may draw (numpy's int64, with hi + 1)
_MAX_INT = 2**63 - 2


@dataclass(frozen=True)
class SweepSpec:
    """A sweep file, read and checked (its variants are built by :func:`plan`).

    Parameters
    ----------
    name : str
        The sweep's name (the file's stem unless the file sets ``name``).
    scenario : Path
        The base scenario file.
    base : dict
        The base scenario's tables as read from ``scenario``.
    fixed : tuple of (key, value)
        ``[set]``: keys every run changes.
    grid : tuple of (key, tuple of values)
        ``[grid]``: the axes, in file order.
    random : tuple of (key, distribution, parameters)
        ``[random]``: what each sample draws, in file order.
    samples : int
        Samples drawn (0 without ``[random]``).
    sample_seed : int
        Seed of the samples' random stream.
    seeds : tuple of int
        The scenario seeds every variant runs with.
    repetitions : int
        Runs of each (variant, seed).
    images : bool
        Camera frames in the runs' logs.
    source : str
        The sweep file's text.
    description : str
        What the sweep is for (free text).
    path : Path or None
        The sweep file (None when parsed from text); errors name it.
    base_dir : Path or None
        Where a relative ``scenario`` path started when the source was read.
    """

    name: str
    scenario: Path
    base: dict[str, Any]
    fixed: tuple[tuple[str, Any], ...] = ()
    grid: tuple[tuple[str, tuple[Any, ...]], ...] = ()
    random: tuple[tuple[str, str, tuple[Any, ...]], ...] = ()
    samples: int = 0
    sample_seed: int = 0
    seeds: tuple[int, ...] = (0,)
    repetitions: int = 1
    images: bool = False
    source: str = ""
    description: str = ""
    path: Path | None = None
    base_dir: Path | None = None

    @property
    def keys(self) -> list[str]:
        """The swept keys: the grid's, then the sampled ones."""
        return [k for k, _ in self.grid] + [k for k, _, _ in self.random]


@dataclass(frozen=True)
class Variant:
    """One combination of the swept keys' values, built into a scenario."""

    index: int  # 0-based, in plan order
    values: dict[str, Any]  # swept key -> its value here, in SweepSpec.keys order
    config: Config  # the scenario with [set] and these values, validated
    source: str  # the scenario's TOML text (Config.source): `lfctl sim` runs it as it is

    @property
    def label(self) -> str:
        """``variant 3 (key = value, ...)``, for messages."""
        return _label(self.index, self.values)


def _label(index: int, values: Mapping[str, Any]) -> str:
    inner = ", ".join(f"{k} = {v!r}" for k, v in values.items())
    return f"variant {index}" + (f" ({inner})" if inner else "")


@dataclass(frozen=True)
class Run:
    """One run of a sweep: a variant at a seed, one of its repetitions."""

    run: int  # 0-based, in plan order: the row's identity
    variant: int  # the variant's index
    seed: int  # the scenario seed (sim.seed)
    repetition: int  # 0-based
    values: dict[str, Any]  # the variant's swept values
    config: Config  # the variant's scenario with sim.seed = seed


@dataclass(frozen=True)
class SweepPlan:
    """Every variant and run of a sweep, and a digest of what they are."""

    spec: SweepSpec  # the sweep
    variants: list[Variant]  # in plan order
    runs: list[Run]  # variants x seeds x repetitions, variant slowest
    digest: str  # SHA-256 over the base scenario, [set], the variants, seeds, repetitions, images

    @property
    def followers(self) -> list[str]:
        """The followers' names (those of the first variant)."""
        return [v.name for v in self.variants[0].config.followers] if self.variants else []


# ----------------------------------------------------------------------------------------
# Keys

_KEY_PART = re.compile(r"([A-Za-z_][A-Za-z0-9_\-]*)((?:\[[^\[\]]+\])*)")


def parse_key(key: str) -> list[tuple[str, str | int]]:
    """A dotted key as its steps: ``("table", name)`` into a table, ``("item", i)`` into an
    array by position, ``("item", name)`` by an entry's ``name``.

    Parameters
    ----------
    key : str
        For example ``scene.lighting[1].gain`` or ``vehicles[follower1].range_m``.

    Raises
    ------
    ConfigError
        Not a dotted path of names with optional ``[index]`` parts.
    """
    steps: list[tuple[str, str | int]] = []
    for part in key.split("."):
        m = _KEY_PART.fullmatch(part.strip())
        if m is None:
            raise ConfigError(f"key {key!r}: {part!r} is not a name with optional [index] parts")
        steps.append(("table", m.group(1)))
        for idx in re.findall(r"\[([^\[\]]+)\]", m.group(2)):
            idx = idx.strip()
            steps.append(("item", int(idx) if re.fullmatch(r"-?\d+", idx) else idx))
    return steps


def _where(steps: list[tuple[str, str | int]]) -> str:
    out = ""
    for kind, name in steps:
        out += f"[{name}]" if kind == "item" else (f".{name}" if out else str(name))
    return out


def set_key(table: dict[str, Any], key: str, value: Any) -> None:
    """Set a dotted key in a scenario's TOML tables, in place.

    Parameters
    ----------
    table : dict
        The scenario's top-level table (as :mod:`tomllib` reads it).
    key : str
        A dotted path (see :func:`parse_key`); missing tables are made.
    value : object
        The TOML value to set.

    Raises
    ------
    ConfigError
        The path runs into a value that is not a table or array, or names an array entry
        the scenario does not have.
    """
    steps = parse_key(key)
    node: Any = table
    for i, (kind, name) in enumerate(steps):
        last = i == len(steps) - 1
        here = _where(steps[: i + 1])
        if kind == "table":
            if not isinstance(node, dict):
                raise ConfigError(f"key {key!r}: {_where(steps[:i])} is not a table")
            if last:
                node[name] = value
                return
            if name not in node:
                if steps[i + 1][0] == "item":
                    raise ConfigError(f"key {key!r}: the scenario has no {here} entries to index")
                node[name] = {}
            node = node[name]
        else:
            if not isinstance(node, list):
                raise ConfigError(f"key {key!r}: {_where(steps[:i])} is not an array")
            index = _item_index(node, name, key, _where(steps[:i]))
            if last:
                node[index] = value
                return
            node = node[index]


def _item_index(items: list[Any], name: str | int, key: str, where: str) -> int:
    if isinstance(name, int):
        if not -len(items) <= name < len(items):
            raise ConfigError(
                f"key {key!r}: the scenario has {len(items)} {where} entries (indices 0..{len(items) - 1}), no [{name}]"
            )
        return name
    named = [i for i, it in enumerate(items) if isinstance(it, dict) and it.get("name") == name]
    if not named:
        known = [it.get("name") for it in items if isinstance(it, dict) and "name" in it]
        raise ConfigError(f"key {key!r}: no {where} entry named {name!r} (named: {known})")
    return named[0]


def _place(key: str, table: dict[str, Any]) -> tuple[tuple[str, str | int], ...]:
    """Where a key leads in the scenario's tables, an array entry by its position however the
    key names it (``vehicles[1]``, ``vehicles[-1]`` and ``vehicles[follower1]`` alike); a step
    the scenario does not have stays as written (building the variants names it)."""
    node: Any = table
    place: list[tuple[str, str | int]] = []
    for kind, name in parse_key(key):
        if kind == "item" and isinstance(node, list) and node:
            try:
                name = _item_index(node, name, key, "") % len(node)
            except ConfigError:
                node = None
            else:
                node = node[name]
        else:
            node = node.get(name) if isinstance(node, dict) else None
        place.append((kind, name))
    return tuple(place)


def _flatten(table: Mapping[str, Any], prefix: str, leaf: Any) -> list[tuple[str, Any]]:
    """Dotted keys of a table's leaves (``leaf(value)`` says whether a table is a leaf)."""
    out = []
    for k, v in table.items():
        key = f"{prefix}.{k}" if prefix else k
        if isinstance(v, dict) and not leaf(v):
            out += _flatten(v, key, leaf)
        else:
            out.append((key, v))
    return out


# ----------------------------------------------------------------------------------------
# Sweep files


def sweeps_dir() -> Path:
    """The shipped example sweeps (``examples/sweeps/``)."""
    return examples_dir() / "sweeps"


def sweep_names() -> list[str]:
    """Names of the shipped example sweeps (file stems), sorted."""
    return example_names(".toml", "sweeps")


def find_sweep(arg: str | Path) -> Path:
    """A sweep argument as a path: an existing file, else a shipped example sweep by name.

    Parameters
    ----------
    arg : str or Path
        A sweep file, or the name of one in ``examples/sweeps`` (``noise-robustness``).

    Raises
    ------
    ConfigError
        Neither; the message lists the shipped sweeps.
    """
    p = Path(arg)
    if p.is_file():
        return p
    if p.name == str(arg):
        for candidate in (sweeps_dir() / str(arg), sweeps_dir() / f"{arg}.toml"):
            if candidate.is_file():
                return candidate
    raise ConfigError(
        f"sweep {str(arg)!r} is neither a file nor a shipped sweep (shipped: {', '.join(sweep_names()) or 'none'})"
    )


def load_sweep(path: str | Path) -> SweepSpec:
    """Read and check a sweep file (a path, or a shipped sweep's name).

    Parameters
    ----------
    path : str or Path
        The sweep TOML; its ``scenario`` is found relative to it.

    Raises
    ------
    ConfigError
        Unreadable file, bad TOML, unknown key, a bad axis or distribution; the message
        starts with the file.
    """
    p = find_sweep(path)
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"cannot read sweep {p}: {exc}") from exc
    try:
        return dataclasses.replace(parse_sweep(text, name=p.stem, base_dir=p.parent), path=p)
    except ConfigError as exc:
        raise ConfigError(f"{p}: {exc}") from None


def parse_sweep(text: str, name: str = "sweep", base_dir: Path | None = None) -> SweepSpec:
    """Parse and check sweep TOML text; see :func:`load_sweep` and the module docstring.

    Parameters
    ----------
    text : str
        The sweep TOML.
    name : str
        The sweep's name when the text sets none.
    base_dir : Path, optional
        Where a relative ``scenario`` path starts (default the working directory).

    Raises
    ------
    ConfigError
        Bad TOML, unknown key, a bad axis, distribution, seed list or scenario.
    """
    data = read_toml(text)
    unknown = sorted(set(data) - set(_TOP_KEYS))
    sections = sorted(set(unknown) & {f.name for f in dataclasses.fields(Config)})
    if sections:
        raise ConfigError(
            f"unknown key {sections[0]!r}: this is a scenario, not a sweep; run it with `lfctl sim` "
            "(a sweep names its scenario in `scenario = ...`)"
        )
    if unknown:
        raise ConfigError(f"unknown key {unknown[0]!r} (allowed here: {', '.join(_TOP_KEYS)})")
    if "scenario" not in data or not isinstance(data["scenario"], str):
        raise ConfigError(
            f"scenario must name the base scenario (a file or a shipped example), got {data.get('scenario')!r}"
        )
    scen = Path(data["scenario"]).expanduser()
    candidate = (base_dir / scen) if base_dir is not None and not scen.is_absolute() else scen
    scenario = candidate if candidate.is_file() else resolve_scenario(data["scenario"])
    try:
        base = read_toml(scenario.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ConfigError) as exc:
        raise ConfigError(f"scenario {scenario}: cannot read it: {exc}") from exc
    sweep_name = data.get("name", name)
    if (
        not isinstance(sweep_name, str)
        or not re.fullmatch(r"[A-Za-z0-9_.\-]+", sweep_name)
        or not sweep_name.strip(".")  # "." and "..": folders already there, not a sweep's own
    ):
        raise ConfigError(f"name must be letters, digits, '.', '-' or '_' (not dots alone), got {sweep_name!r}")
    fixed = _section(data, "set", lambda v: False)
    grid = []
    for key, values in _section(data, "grid", lambda v: False):
        if not isinstance(values, list) or not values:
            raise ConfigError(f"grid.{key!r} must be a non-empty array of values, got {values!r}")
        _unrepeated(key, values)
        grid.append((key, tuple(values)))
    random, samples, sample_seed = _random(data.get("random", {}))
    seeds = _seeds(data.get("seeds"), base)
    repetitions = data.get("repetitions", 1)
    if isinstance(repetitions, bool) or not isinstance(repetitions, int) or not 1 <= repetitions <= MAX_RUNS:
        raise ConfigError(f"repetitions must be an integer within 1..{MAX_RUNS}, got {repetitions!r}")
    variants = math.prod(len(v) for _, v in grid) * max(1, samples)
    runs = variants * len(seeds) * repetitions
    if variants > MAX_VARIANTS or runs > MAX_RUNS:
        raise ConfigError(
            f"the sweep has {variants} variant{'s' * (variants != 1)} (grid combinations x samples) and {runs} runs (x seeds x "
            f"repetitions); at most {MAX_VARIANTS} variants and {MAX_RUNS} runs: split it into several sweeps"
        )
    images = data.get("images", False)
    if not isinstance(images, bool):
        raise ConfigError(f"images must be true or false, got {images!r}")
    description = data.get("description", "")
    if not isinstance(description, str):
        raise ConfigError(f"description must be a string, got {description!r}")
    keys = [k for k, _ in fixed] + [k for k, _ in grid] + [k for k, _, _ in random]
    for key in keys:
        where = _where(parse_key(key))  # "sim. seed" is sim.seed
        if where in _RESERVED:
            raise ConfigError(f"{key!r} cannot be varied by a sweep: it is set by {_RESERVED[where]}")
    first: dict[tuple[tuple[str, str | int], ...], int] = {}  # where each key leads -> the first key's index
    for i, key in enumerate(keys):
        j = first.setdefault(_place(key, base), i)
        if j != i:
            also = f" (as {keys[j]!r})" if keys[j] != key else ""
            raise ConfigError(f"key {key!r} appears more than once in [set], [grid] and [random]{also}")
    return SweepSpec(
        name=sweep_name,
        scenario=scenario,
        base=base,
        fixed=tuple(fixed),
        grid=tuple(grid),
        random=tuple(random),
        samples=samples,
        sample_seed=sample_seed,
        seeds=seeds,
        repetitions=repetitions,
        images=images,
        source=text,
        description=description,
        base_dir=base_dir if base_dir is not None else Path.cwd(),  # where a relative path started
    )


def _section(data: dict[str, Any], name: str, leaf: Any) -> list[tuple[str, Any]]:
    table = data.get(name, {})
    if not isinstance(table, dict):
        raise ConfigError(f"{name} must be a table ([{name}]), got {table!r}")
    return _flatten(table, "", leaf)


def _same_as(value: Any) -> Any:
    """A grid value as a set compares it: equal numbers alike (``0`` and ``0.0`` make the same
    scenario), a Boolean apart from the number it equals, arrays and tables by their items."""
    if isinstance(value, bool):
        return ("bool", value)
    if isinstance(value, list):
        return ("array", tuple(_same_as(v) for v in value))
    if isinstance(value, dict):
        return ("table", tuple(sorted((k, _same_as(v)) for k, v in value.items())))
    return value


def _unrepeated(key: str, values: list[Any]) -> None:
    """ConfigError naming a value ``grid.key`` gives twice: two variants the same, their runs
    the same runs again under another variant number."""
    seen: dict[Any, int] = {}
    for i, value in enumerate(values):
        first = seen.setdefault(_same_as(value), i)
        if first != i:
            raise ConfigError(
                f"grid.{key!r} gives {values[first]!r} twice (places {first + 1} and {i + 1} of its array): "
                f"each variant once; more runs of one come from seeds or repetitions"
            )


def _random(table: Any) -> tuple[list[tuple[str, str, tuple[Any, ...]]], int, int]:
    if not isinstance(table, dict):
        raise ConfigError(f"random must be a table ([random]), got {table!r}")
    table = dict(table)
    samples = table.pop("samples", None)
    seed = table.pop("seed", 0)
    if not table:
        if samples is not None:
            raise ConfigError("random.samples is given but [random] names no key to sample")
        return [], 0, 0
    if isinstance(samples, bool) or not isinstance(samples, int) or not 1 <= samples <= MAX_VARIANTS:
        raise ConfigError(f"random.samples must be an integer within 1..{MAX_VARIANTS}, got {samples!r}")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ConfigError(f"random.seed must be an integer >= 0, got {seed!r}")
    out = []
    for key, dist in _flatten(table, "", lambda v: not any(isinstance(x, dict) for x in v.values())):
        if not isinstance(dist, dict) or len(dist) != 1 or next(iter(dist)) not in DISTRIBUTIONS:
            allowed = ", ".join(f"{k} = {v}" for k, v in DISTRIBUTIONS.items())
            raise ConfigError(f"random.{key!r} must be one distribution ({allowed}), got {dist!r}")
        kind, params = next(iter(dist.items()))
        out.append((key, kind, _distribution(key, kind, params)))
    return out, samples, seed


def _distribution(key: str, kind: str, params: Any) -> tuple[Any, ...]:
    where = f"random.{key!r}: {kind}"
    if not isinstance(params, list):
        raise ConfigError(f"{where} must be {DISTRIBUTIONS[kind]}, got {params!r}")
    if kind == "choice":
        if not params:
            raise ConfigError(f"{where} needs at least one value")
        return tuple(params)
    if len(params) != 2 or not all(isinstance(p, (int, float)) and not isinstance(p, bool) for p in params):
        raise ConfigError(f"{where} must be {DISTRIBUTIONS[kind]}, got {params!r}")
    a, b = params
    if not (math.isfinite(a) and math.isfinite(b)):
        raise ConfigError(f"{where} parameters must be finite, got {params!r}")
    if kind == "uniform" and not math.isfinite(b - a):
        raise ConfigError(f"{where}: hi - lo must be a finite number, got {params!r}")
    if kind == "normal":
        if b < 0:
            raise ConfigError(f"{where} sigma must be >= 0, got {b!r}")
    elif a > b:
        raise ConfigError(f"{where} needs lo <= hi, got {params!r}")
    if kind == "loguniform" and a <= 0:
        raise ConfigError(f"{where} needs lo > 0, got {params!r}")
    if kind == "integers" and not (isinstance(a, int) and isinstance(b, int)):
        raise ConfigError(f"{where} needs integer bounds, got {params!r}")
    if kind == "integers" and not -_MAX_INT <= a <= b <= _MAX_INT:
        raise ConfigError(f"{where} bounds must be within +-{_MAX_INT} (64-bit integers), got {params!r}")
    return (a, b)


def _seeds(value: Any, base: dict[str, Any]) -> tuple[int, ...]:
    if value is None:
        sim = base.get("sim", {})
        seed = sim.get("seed", 0) if isinstance(sim, dict) else 0
        return (seed if isinstance(seed, int) and not isinstance(seed, bool) else 0,)
    if isinstance(value, int) and not isinstance(value, bool):
        if not 1 <= value <= MAX_RUNS:
            raise ConfigError(
                f"seeds must be a count within 1..{MAX_RUNS} (seeds 1..n) or a list of seeds, got {value!r}"
            )
        return tuple(range(1, value + 1))
    if (
        isinstance(value, list)
        and value
        and all(isinstance(s, int) and not isinstance(s, bool) and 0 <= s <= _MAX_SEED for s in value)
    ):
        if len(set(value)) != len(value):
            raise ConfigError(f"seeds must not repeat (use repetitions), got {value!r}")
        return tuple(value)
    raise ConfigError(
        f"seeds must be a count >= 1 or a non-empty list of integers within 0..{_MAX_SEED}, got {value!r}"
    )


# ----------------------------------------------------------------------------------------
# Expansion


def _draw(rng: np.random.Generator, kind: str, params: tuple[Any, ...]) -> Any:
    if kind == "uniform":
        return float(rng.uniform(params[0], params[1]))
    if kind == "loguniform":
        return float(math.exp(rng.uniform(math.log(params[0]), math.log(params[1]))))
    if kind == "normal":
        return float(rng.normal(params[0], params[1]))
    if kind == "integers":
        return int(rng.integers(params[0], params[1] + 1))
    return params[int(rng.integers(len(params)))]


def _combinations(spec: SweepSpec) -> list[dict[str, Any]]:
    """The swept values of every variant: grid combinations (first key slowest) x samples."""
    grid = [
        dict(zip([k for k, _ in spec.grid], combo, strict=True))
        for combo in itertools.product(*(v for _, v in spec.grid))
    ]
    if not spec.random:
        return grid
    rng = np.random.default_rng(spec.sample_seed)
    samples = [{key: _draw(rng, kind, params) for key, kind, params in spec.random} for _ in range(spec.samples)]
    return [g | s for g in grid for s in samples]


def _with_keys(base: dict[str, Any], keys: Iterable[tuple[str, Any]], name: str) -> Config:
    table = copy.deepcopy(base)
    for key, value in keys:
        set_key(table, key, value)
    return config_from_table(table, name, tomli_w.dumps(table))


def _toml_value(key: str, value: Any) -> Any:
    """``value`` as TOML holds it: numpy numbers and arrays, tuples and paths as their plain
    Python forms; ConfigError naming ``key`` for a value TOML has no form for (None among them:
    a key left out takes its default)."""
    if isinstance(value, bool | int | float | str | datetime.date | datetime.time):
        return value
    if isinstance(value, np.generic | np.ndarray):
        return _toml_value(key, value.tolist())
    if isinstance(value, PurePath):
        return str(value)
    if isinstance(value, list | tuple):
        return [_toml_value(key, v) for v in value]
    if isinstance(value, Mapping):
        return {str(k): _toml_value(key, v) for k, v in value.items()}
    what = "None" if value is None else f"a value of type {type(value).__name__}"
    raise ConfigError(
        f"{key}: {what} is not a TOML value (a number, string, bool, array or table){' (leave the key out for its default)' if value is None else ''}"
    )


def with_keys(cfg: Config, keys: Mapping[str, Any]) -> Config:
    """A scenario with keys changed as a sweep changes them: dotted keys set on the tables
    of its TOML (:attr:`Config.source`), then built and validated as a scenario file is, so
    ``_deg`` keys and every check work as in a file. The result's ``source`` is its TOML.

    Parameters
    ----------
    cfg : Config
        A scenario as :func:`lfctl.config.load_config` read it (changes made to the
        dataclasses since are not in its ``source`` and are not kept).
    keys : mapping of str to value
        Dotted key (see :func:`set_key`) -> TOML value, for example
        ``{"sensing.bearing_noise_deg": 2.0, "vehicles[follower1].range_m": 2.0}``.

    Raises
    ------
    ConfigError
        A key that does not reach into the scenario, or a value it rejects.
    """
    try:
        base = tomllib.loads(cfg.source)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{cfg.name}: its source is not TOML ({exc}): was it built by load_config?") from None
    out = _with_keys(base, ((key, _toml_value(key, value)) for key, value in keys.items()), cfg.name)
    # paths load_config resolved beside the scenario stay so, unless a key changes them
    if "mission.file" not in keys and out.mission.file is not None:
        out = dataclasses.replace(out, mission=dataclasses.replace(out.mission, file=cfg.mission.file))
    fmus = {v.name: v.fmu for v in cfg.vehicles}
    vehicles = tuple(
        dataclasses.replace(v, fmu=fmus[v.name])
        if v.fmu is not None and v.name in fmus and f"vehicles[{v.name}].fmu" not in keys
        else v
        for v in out.vehicles
    )
    return dataclasses.replace(out, vehicles=vehicles)


#: the fields of a SweepSpec its source TOML sets
_SOURCE_FIELDS = ("name", "scenario", "fixed", "grid", "random", "samples", "sample_seed", "seeds", "repetitions",
                  "images", "description")  # fmt: skip


def _check_source(spec: SweepSpec) -> None:
    """ConfigError when ``spec``'s fields are not what its source says (changed after it was
    read, with ``dataclasses.replace``): the sweep's folder keeps the source as its record."""
    if not spec.source:  # built in Python, not read: there is no record to contradict
        return
    again = parse_sweep(spec.source, spec.name, spec.base_dir)

    def same(a: Any, b: Any) -> bool:  # NaN in a grid equals itself here
        return json.dumps(a, sort_keys=True, default=repr) == json.dumps(b, sort_keys=True, default=repr)

    changed = [f for f in _SOURCE_FIELDS if not same(getattr(again, f), getattr(spec, f))]
    if changed:
        raise ConfigError(
            f"sweep {spec.name!r}: its {', '.join(changed)} {'differs' if len(changed) == 1 else 'differ'} from its "
            "source TOML (changed after it was read): "
            "write the change into the TOML text and read that with parse_sweep(text, name, base_dir), so that "
            "the sweep's folder records what ran"
        )


def plan(spec: SweepSpec) -> SweepPlan:
    """Build and validate every variant and list every run, before anything runs.

    Each variant is the base scenario with ``[set]`` and its swept values applied to the
    TOML tables, then built as a scenario file is; runs are the variants at each seed and
    repetition. Logs leave the frames out unless the sweep sets ``images = true``.

    Parameters
    ----------
    spec : SweepSpec
        The sweep.

    Raises
    ------
    ConfigError
        A variant that does not build: the message names the variant, its values and the key;
        or a spec whose fields were changed after it was read, so that its source (the
        ``sweep.toml`` its folder keeps) no longer says what runs.
    """
    _check_source(spec)
    variants = []
    missions: dict[str, str] = {}  # each mission file the variants fly -> its SHA-256
    for index, values in enumerate(_combinations(spec)):
        try:
            keys = [*spec.fixed, *values.items(), ("recording.images", spec.images)]
            # file paths (a user FMU, a mission file) are the scenario's: beside it, as lfctl sim reads them
            cfg = resolve_paths(_with_keys(spec.base, keys, spec.scenario.stem), spec.scenario.parent)
            if cfg.sim.clock != "lockstep":
                raise ConfigError(
                    f"sim.clock must be 'lockstep' in a sweep (runs side by side cannot share UDP ports), got {cfg.sim.clock!r}"
                )
            if cfg.mission.file is not None and cfg.mission.file not in missions:
                from lfctl.sim.links import scenario_mission

                found = scenario_mission(cfg)  # a bad mission file: one line now, not a failed row a run
                missions[cfg.mission.file] = hashlib.sha256(found.data).hexdigest() if found is not None else ""
            for veh in cfg.vehicles:  # a user FMU that is no file: one line now, not a failed row a run
                if veh.fmu is not None and not Path(veh.fmu).is_file():
                    why = "does not exist" if not Path(veh.fmu).exists() else "is not a regular file"
                    raise ConfigError(f"vehicles[{veh.name}].fmu {veh.fmu} {why}")
        except ConfigError as exc:
            where = f"{spec.path}: " if spec.path is not None else ""
            raise ConfigError(f"{where}{_label(index, values)}: {exc}") from None
        variants.append(Variant(index, values, cfg, cfg.source))
    runs = [
        Run(
            n,
            v.index,
            seed,
            rep,
            v.values,
            dataclasses.replace(v.config, sim=dataclasses.replace(v.config.sim, seed=seed)),
        )
        for n, (v, seed, rep) in enumerate(
            (v, s, r) for v in variants for s in spec.seeds for r in range(spec.repetitions)
        )
    ]
    what = {
        "scenario": tomli_w.dumps(spec.base),
        "set": [[k, v] for k, v in spec.fixed],
        "variants": [v.values for v in variants],
        "seeds": list(spec.seeds),
        "repetitions": spec.repetitions,
        "images": spec.images,
        "mission_files": missions,  # a plan edited since is another sweep
    }
    digest = hashlib.sha256(json.dumps(what, sort_keys=True, default=repr).encode()).hexdigest()
    return SweepPlan(spec, variants, runs, digest)
