"""The simulated camera: the scene, its textures and the renderer (a sensor, not part of the
co-simulation master), and the rendered test sequences of the vision benchmark."""

__all__: list[str] = []
