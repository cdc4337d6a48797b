"""Vehicle FMUs: building the built-in models from C (:mod:`lfctl.fmu.build`) and loading and
stepping any FMU (:mod:`lfctl.fmu.load`, the only module that runs fmpy)."""

__all__: list[str] = []
