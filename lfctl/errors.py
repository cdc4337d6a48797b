"""One exception hierarchy for lfctl (STYLE.md section 5).

Each class also subclasses the fitting builtin, so callers may catch either.
Messages name the bad value and what was expected.
"""

from __future__ import annotations


class LfctlError(Exception):
    """Base of every error lfctl raises on purpose."""


class ConfigError(LfctlError, ValueError):
    """A scenario file or option is malformed; the message names the key and the value."""


class FmuError(LfctlError, RuntimeError):
    """An FMU could not be built, loaded or stepped.

    Parameters
    ----------
    message : str
        What went wrong, naming the model and the FMI call.
    model : str
        Model identifier or FMU path.
    call : str
        The FMI call or build step that failed ("" when none).
    status : int or None
        The FMI status returned, when there was one.
    log : list of str
        Messages the FMU logged before the failure.
    """

    def __init__(
        self,
        message: str,
        *,
        model: str = "",
        call: str = "",
        status: int | None = None,
        log: list[str] | None = None,
    ) -> None:
        self.model = model
        self.call = call
        self.status = status
        self.log = list(log or [])
        detail = f" (FMU said: {self.log[-1]})" if self.log else ""
        super().__init__(message + detail)


class BuildToolError(FmuError):
    """The C compiler needed to build the FMUs is missing or failed."""


class LinkTimeoutError(LfctlError, TimeoutError):
    """A MAVLink peer did not answer in time."""


class MissionProtocolError(LfctlError):
    """The mission protocol went out of sequence or was refused."""
