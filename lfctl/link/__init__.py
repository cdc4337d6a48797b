"""MAVLink: ArduPilot-Rover-compatible vehicle endpoints, mission protocol, parameters, modes,
failsafes, the companion's setpoints and the ground-station client. The only package that
knows MAVLink names, ids and units (degE7, cdeg, mm)."""

__all__: list[str] = []
