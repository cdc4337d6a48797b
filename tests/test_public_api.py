"""Every public module says what it exports (``__all__``), and every exported function,
class and public method is documented, each of its arguments by name (numpydoc
``Parameters``, or the class docstring for a constructor; a dataclass field may instead
carry a comment on its line or a ``#:`` line above it)."""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import pkgutil
import re
from collections.abc import Iterator
from types import ModuleType

import lfctl

SKIP_PARAMS = {"self", "cls", "args", "kwargs"}


def modules() -> Iterator[ModuleType]:
    for info in pkgutil.walk_packages(lfctl.__path__, "lfctl."):
        name = info.name
        if any(part.startswith("_") for part in name.split(".")[1:]) or name.startswith("lfctl.cli."):
            continue  # private modules; CLI command modules are entry points, not an API
        yield importlib.import_module(name)


def _mentions(doc: str, name: str) -> bool:
    return re.search(rf"(?<![\w]){re.escape(name)}(?![\w])", doc) is not None


def _commented_fields(cls: type) -> set[str]:
    """Dataclass fields with a comment on their line or a ``#:`` line just above."""
    try:
        src = inspect.getsource(cls).splitlines()
    except (OSError, TypeError):
        return set()
    out = set()
    for i, line in enumerate(src):
        m = re.match(r"\s+(\w+)\s*:", line)
        if m and ("#" in line.split(":", 1)[1] or (i > 0 and src[i - 1].strip().startswith("#:"))):
            out.add(m.group(1))
    return out


def problems_of_callable(qual: str, fn: object, doc_extra: str = "", fields: set[str] = frozenset()) -> list[str]:
    doc = (inspect.getdoc(fn) or "") + "\n" + doc_extra
    if not doc.strip():
        return [f"{qual}: no docstring"]
    try:
        sig = inspect.signature(fn)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return []
    return [
        f"{qual}: argument {p} not documented"
        for p in sig.parameters
        if p not in SKIP_PARAMS and p not in fields and not _mentions(doc, p)
    ]


def api_problems() -> list[str]:
    out: list[str] = []
    for mod in modules():
        if not mod.__doc__:
            out.append(f"{mod.__name__}: no module docstring")
        names = getattr(mod, "__all__", None)
        if names is None:
            out.append(f"{mod.__name__}: no __all__")
            continue
        for name in names:
            obj = getattr(mod, name, None)
            if obj is None:
                out.append(f"{mod.__name__}.{name}: in __all__ but not defined")
                continue
            qual = f"{mod.__name__}.{name}"
            if inspect.isclass(obj):
                if getattr(obj, "__module__", "") != mod.__name__:
                    continue  # re-exported: checked where it is defined
                class_doc = inspect.getdoc(obj) or ""
                if not class_doc:
                    out.append(f"{qual}: no docstring")
                if issubclass(obj, BaseException) or getattr(obj, "_is_protocol", False) or issubclass(obj, tuple):
                    init_doc_needed = not issubclass(obj, tuple) and "__init__" in vars(obj)
                else:
                    init_doc_needed = "__init__" in vars(obj) or dataclasses.is_dataclass(obj)
                if init_doc_needed:
                    fields = _commented_fields(obj) if dataclasses.is_dataclass(obj) else set()
                    out += problems_of_callable(f"{qual}()", obj.__init__, class_doc, fields)
                for mname, member in vars(obj).items():
                    if mname.startswith("_"):
                        continue
                    fn = member.__func__ if isinstance(member, (staticmethod, classmethod)) else member
                    if isinstance(fn, property):
                        if not inspect.getdoc(fn):
                            out.append(f"{qual}.{mname}: no docstring")
                    elif inspect.isfunction(fn):
                        out += problems_of_callable(f"{qual}.{mname}", fn)
            elif inspect.isfunction(obj) and obj.__module__ == mod.__name__:
                out += problems_of_callable(qual, obj)
    return out


def test_every_public_function_and_argument_is_documented() -> None:
    problems = api_problems()
    assert not problems, f"{len(problems)} problems:\n" + "\n".join(problems)
