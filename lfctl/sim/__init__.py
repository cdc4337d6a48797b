"""Co-simulation: FMU build and load (the only package that imports fmpy), lockstep master, world state."""
