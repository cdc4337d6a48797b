"""lfctl: vision-guided leader-follower ground robots, co-simulated with FMUs."""

__all__ = ["__version__"]

__version__ = "0.1.0"
