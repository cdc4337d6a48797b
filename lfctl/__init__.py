"""lfctl: vision-guided leader-follower ground robots, co-simulated with FMUs."""

__version__ = "0.1.0"
