"""Where a worker process finds lfctl: where this process found it."""

from __future__ import annotations

import subprocess
import sysconfig
from pathlib import Path

import pytest

from lfctl import workers

#: prints where the worker's lfctl is, and whether site-packages comes before the standard library
PROBE = (
    "import json, os, sys, sysconfig, lfctl\n"
    "site = os.path.realpath(sysconfig.get_paths()['purelib'])\n"
    "paths = [os.path.realpath(p) for p in sys.path]\n"
    "std = os.path.realpath(sysconfig.get_paths()['stdlib'])\n"
    "print(json.dumps([lfctl.__file__, site in paths and paths.index(site) < paths.index(std)]))\n"
)


def _run_probe(module_dir: Path, *flags: str, env: dict[str, str] | None = None) -> list:
    """The worker's command line for a probe module in ``module_dir``, run (its output)."""
    (module_dir / "lfctl_probe_mod.py").write_text(PROBE)
    cmd = workers.worker_command("lfctl_probe_mod", ())
    cmd[1:1] = list(flags)
    cmd = [a if a != workers._PACKAGE_ROOT else str(module_dir) for a in cmd]  # the probe's folder too
    out = subprocess.run(cmd, capture_output=True, text=True, timeout=60, env=env)
    assert out.returncode == 0, out.stderr
    import json

    return json.loads(out.stdout)


def test_a_source_tree_is_put_first_and_site_packages_is_left_after_the_standard_library(tmp_path: Path) -> None:
    lfctl_file, site_first = _run_probe(tmp_path)  # a folder the interpreter does not look in
    assert not site_first and lfctl_file.startswith(str(Path(workers.__file__).parents[1]))
    purelib = Path(sysconfig.get_paths()["purelib"])
    cmd = workers.worker_command("json.tool", ())
    cmd[cmd.index(workers._PACKAGE_ROOT)] = str(purelib)  # as from a wheel
    boot = cmd[cmd.index("-c") + 1].replace(
        "runpy.run_module(module, run_name='__main__', alter_sys=True)",
        "import sysconfig as s; p=[os.path.realpath(x) for x in sys.path];"
        " print(p.index(os.path.realpath(root)) > p.index(os.path.realpath(s.get_paths()['stdlib'])))",
    )
    cmd[cmd.index("-c") + 1] = boot
    out = subprocess.run(cmd, capture_output=True, text=True, timeout=60)
    assert out.stdout.strip() == "True", out


def test_the_interpreters_flags_are_passed_on(monkeypatch: pytest.MonkeyPatch) -> None:
    class Flags:
        isolated, ignore_environment, no_user_site, no_site = 0, 1, 1, 0

    monkeypatch.setattr(workers.sys, "flags", Flags)
    cmd = workers.worker_command("lfctl.fmu.host", (7,))
    assert cmd[1:4] == ["-P", "-E", "-s"] and cmd[-2:] == ["lfctl.fmu.host", "7"]
    Flags.isolated = 1
    assert workers.worker_command("m", ())[1:3] == ["-P", "-I"]
