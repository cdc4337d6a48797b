"""Co-simulation: FMU build and load (the only package that imports fmpy), lockstep master, world state."""

__all__: list[str] = []
