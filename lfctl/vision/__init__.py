"""Perception for real or rendered frames (pure: no sockets, files, clocks or FMU handles)."""

__all__: list[str] = []
