"""Shared fixtures: the built-in FMUs, built once per session into the normal cache."""

from __future__ import annotations

import pytest

from lfctl.fmu.build import BuiltModel, build_model


@pytest.fixture(scope="session")
def rover() -> BuiltModel:
    return build_model("SkidSteerRover")


@pytest.fixture(scope="session")
def unicycle() -> BuiltModel:
    return build_model("KinematicUnicycle")
