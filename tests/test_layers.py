"""The layering of docs/architecture.md, checked on every module's imports (those inside
functions too): what each layer may import from lfctl, and which libraries it may not use."""

from __future__ import annotations

import ast
from pathlib import Path

import lfctl

ROOT = Path(lfctl.__file__).parent
EVERYTHING = {
    "errors", "checks", "frames", "config", "data", "schedule", "video", "metrics", "vision", "guidance", "render", "fmu",
    "link", "follower", "record", "sim", "sweep", "bench", "cli", "workers", "logs",
}  # fmt: skip

#: layer -> what it may import from lfctl (a package, or one module of it)
ALLOWED = {
    "__init__": set(),
    "__main__": {"cli"},
    "errors": set(),
    "workers": set(),
    "checks": {"errors"},
    "logs": {"checks"},
    "frames": set(),
    "config": {"checks", "data", "errors", "link.params"},
    "data": {"errors"},
    "schedule": set(),
    "video": {"checks", "errors"},
    "vision": {"config", "errors", "frames", "vision"},
    "guidance": {"errors", "frames", "guidance", "vision.track_state"},
    "metrics": {"vision.track_state"},
    "render": {"config", "data", "errors", "frames", "vision", "render"},
    "fmu": {"data", "errors", "fmu", "logs", "workers"},
    "link": {"checks", "errors", "frames", "link"},
    "follower": {"config", "frames", "guidance", "link", "schedule", "video", "vision", "follower"},
    "record": {"checks", "config", "data", "errors", "frames", "metrics", "video", "vision", "record"},
    "sim": EVERYTHING - {"sweep", "bench", "cli"},
    "sweep": EVERYTHING - {"bench", "cli"},
    "bench": EVERYTHING - {"cli"},
    "cli": EVERYTHING,
}
PURE = {"socket", "subprocess", "threading", "time", "fmpy", "pymavlink", "mcap"}
#: layer -> libraries it may not import
FORBIDDEN = {
    "vision": PURE,
    "guidance": PURE,
    "metrics": PURE,
    "render": PURE,
    "frames": PURE,
    "schedule": PURE,
    "checks": PURE | {"cv2"},
    "config": {"fmpy", "pymavlink", "mcap", "cv2"},
    "fmu": {"pymavlink", "mcap"},
    "link": {"fmpy", "mcap", "cv2"},
    "follower": {"fmpy", "mcap"},
    "record": {"fmpy", "pymavlink"},
    "sweep": {"fmpy", "pymavlink"},  # runs go through sim.runner
    "cli": {"fmpy", "pymavlink"},  # commands call the library; only link/ speaks MAVLink
}


def imports(path: Path) -> set[str]:
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            out.add(node.module)
    return out


def layer_of(path: Path) -> str:
    rel = path.relative_to(ROOT)
    return rel.parts[0] if len(rel.parts) > 1 else rel.stem


def test_every_module_imports_only_what_its_layer_may() -> None:
    problems = []
    for path in sorted(ROOT.rglob("*.py")):
        layer = layer_of(path)
        assert layer in ALLOWED, f"{path}: layer {layer!r} is not in docs/architecture.md's table"
        for name in sorted(imports(path)):
            top = name.split(".")[0]
            if top == "lfctl":
                parts = name.split(".")[1:]
                if not parts:
                    continue
                if parts[0] != layer and not ({parts[0], ".".join(parts[:2])} & ALLOWED[layer]):
                    problems.append(f"{path.relative_to(ROOT)}: {layer} imports {name}")
            elif top in FORBIDDEN.get(layer, set()):
                problems.append(f"{path.relative_to(ROOT)}: {layer} imports {name}")
    assert not problems, "\n".join(problems)
