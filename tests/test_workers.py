"""The environment a worker process starts with."""

from __future__ import annotations

import os
import sysconfig

import pytest

from lfctl import workers


def test_a_source_tree_goes_first_on_the_workers_path(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(workers, "_PACKAGE_ROOT", "/home/someone/lfctl-checkout")
    monkeypatch.setenv("PYTHONPATH", "/elsewhere")
    env = workers._worker_environment()
    assert env["PYTHONPATH"] == os.pathsep.join(["/home/someone/lfctl-checkout", "/elsewhere"])
    assert env["LFCTL_WORKER_PARENT"] == str(os.getpid())


def test_site_packages_is_not_put_before_the_standard_library(monkeypatch: pytest.MonkeyPatch) -> None:
    # a wheel's lfctl sits in site-packages, which the worker's interpreter looks in anyway:
    # on PYTHONPATH it would come before the standard library (a package's `typing.py` first)
    monkeypatch.setattr(workers, "_PACKAGE_ROOT", sysconfig.get_paths()["purelib"])
    monkeypatch.delenv("PYTHONPATH", raising=False)
    assert "PYTHONPATH" not in workers._worker_environment()
    monkeypatch.setenv("PYTHONPATH", "/elsewhere")
    assert workers._worker_environment()["PYTHONPATH"] == "/elsewhere"
