"""The test-only FaultyRover FMU (its C sources in FaultyRover/), built once per session."""

from __future__ import annotations

from pathlib import Path

import pytest

from lfctl.fmu.build import BuiltModel, build_model_folder

HERE = Path(__file__).parent


@pytest.fixture(scope="session")
def faulty() -> BuiltModel:
    return build_model_folder(HERE / "FaultyRover")
