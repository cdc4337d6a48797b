"""MCAP recording of every run, and the tools that read it back (audit, replay)."""

__all__: list[str] = []
