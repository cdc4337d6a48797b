"""The co-simulation master: lockstep FMU stepping and its scheduler, the world truth, the
closed loop of typed tasks, and the simulated sensors and links (docs/architecture.md)."""

__all__: list[str] = []
