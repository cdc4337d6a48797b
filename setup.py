"""Packaging beyond what pyproject.toml can say: the top-level folders ``fmu_models/`` (the
vehicle models' C sources), ``examples/`` and ``footage/`` (labelled real video for the vision
benchmark) travel inside the package, as ``lfctl/fmu_models``, ``lfctl/examples`` and ``lfctl/footage``, so a wheel builds its FMUs and runs the
examples by name from any directory (``lfctl.data`` finds them in either place)."""

from setuptools import find_packages, setup

DATA = {"lfctl.fmu_models": "fmu_models", "lfctl.examples": "examples", "lfctl.footage": "footage"}

setup(
    packages=[*find_packages(include=["lfctl", "lfctl.*"]), *DATA],
    package_dir=DATA,
    package_data={
        "lfctl.fmu_models": ["**/*"],
        "lfctl.examples": ["*", "sweeps/*", "sweeps/scenarios/*"],
        "lfctl.footage": ["**/*"],
    },
)
