"""Packaging beyond what pyproject.toml can say: the top-level folders ``fmu_models/`` (the
vehicle models' C sources) and ``examples/`` travel inside the package, as
``lfctl/fmu_models`` and ``lfctl/examples``, so a wheel builds its FMUs and runs the
examples by name from any directory (``lfctl.data`` finds them in either place)."""

from setuptools import find_packages, setup

DATA = {"lfctl.fmu_models": "fmu_models", "lfctl.examples": "examples"}

setup(
    packages=[*find_packages(include=["lfctl", "lfctl.*"]), *DATA],
    package_dir=DATA,
    package_data={"lfctl.fmu_models": ["**/*"], "lfctl.examples": ["*"]},
)
