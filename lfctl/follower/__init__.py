"""The follower stack, the same code in the simulation and on a real rover (see
:mod:`lfctl.follower.stack`), and what runs it on a real rover (:mod:`lfctl.follower.rover`)."""

__all__: list[str] = []
