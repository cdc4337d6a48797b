"""The README's Python example stays true to the API: it compiles, and everything it imports
exists with the arguments it passes (running it takes minutes: the noise sweep)."""

from __future__ import annotations

import ast
import importlib
import inspect
import re
from pathlib import Path

README = Path(__file__).parents[1] / "README.md"


def test_readme_python_example_imports_and_calls_what_exists() -> None:
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(), re.S)
    assert blocks, "the README has no Python example"
    for code in blocks:
        tree = ast.parse(code)
        names = {}
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom):
                module = importlib.import_module(node.module or "")
                for alias in node.names:
                    names[alias.asname or alias.name] = getattr(module, alias.name)  # AttributeError if gone
        for node in ast.walk(tree):
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in names:
                fn = names[node.func.id]
                if inspect.isfunction(fn):
                    params = inspect.signature(fn).parameters
                    assert len(node.args) <= len(params), f"{node.func.id}: too many arguments"
                    for kw in node.keywords:
                        assert kw.arg in params, f"{node.func.id}() has no argument {kw.arg!r}"


def test_readme_tracker_example_runs_and_tracks_the_cyclist_after_the_vans(capsys) -> None:
    # the example on shipped footage is quick: run it as written
    code = next(b for b in re.findall(r"```python\n(.*?)```", README.read_text(), re.S) if "load_sequence" in b)
    exec(compile(code, "README.md", "exec"), {})
    lines = capsys.readouterr().out.splitlines()
    assert [line.split()[1] for line in lines[:6]] == ["occluded", "occluded", *["tracking"] * 4]  # hidden 10-25
    assert lines[-1] == "TrackStatus.LOST 0.0 0.0"  # a bearing alone starts no formation filter


def _anchor(heading: str) -> str:
    """A heading's anchor as GitHub makes it: lower case, punctuation dropped, spaces to ``-``."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def test_every_relative_link_in_the_readme_and_docs_leads_somewhere() -> None:
    root = README.parent
    pages = [README, *sorted((root / "docs").glob("*.md"))]
    anchors = {}
    for page in pages:
        prose = re.sub(r"```.*?```", "", page.read_text(), flags=re.S)  # a shell comment is no heading
        anchors[page.resolve()] = {_anchor(h) for h in re.findall(r"^#+\s+(.*)$", prose, re.M)}
    broken = []
    for page in pages:
        for link in re.findall(r"\]\(([^)\s]+)\)", page.read_text()):
            if re.match(r"[a-z]+:", link):
                continue  # https: and the like
            path, _, fragment = link.partition("#")
            target = (page.parent / path).resolve() if path else page.resolve()
            if not target.exists():
                broken.append(f"{page.name}: {link} (no file {target})")
            elif fragment and fragment not in anchors.get(target, set()):
                broken.append(f"{page.name}: {link} (no heading with that anchor)")
    assert not broken, broken


def test_the_readme_scenario_table_names_every_scenario_key() -> None:
    from lfctl.config import reference

    text = README.read_text()
    section = text[text.index("## Scenario files") : text.index("## Conventions")]
    named = " ".join(re.findall(r"`([^`]*)`", section))
    # named by a range or a pattern there: `fx_px` .. `cy_px`, `vel_*_mps`
    by_pattern = {"camera.fy_px", "camera.cx_px", "scene.props.vel_north_mps", "scene.props.vel_east_mps"}
    missing = []
    for row in reference().splitlines()[2:]:
        if not row.startswith("| `"):
            continue
        key = row.split("|")[1].strip().strip("`")
        leaf = re.escape(key.rsplit(".", 1)[-1])
        if key not in by_pattern and not re.search(rf"(^|[\s.\[(/]){leaf}($|[\s\]`=,)])", named):
            missing.append(key)
    assert not missing, f"README's 'Scenario files' does not name {missing}"
