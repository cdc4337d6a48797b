"""Guidance and control (pure functions + thin stateful classes): LOS waypoint guidance,
sliding-mode range and bearing control, leader autopilot, formation controller."""

__all__: list[str] = []
