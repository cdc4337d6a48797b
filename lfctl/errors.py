"""One exception hierarchy for lfctl (docs/architecture.md, "Errors").

Each class also subclasses the fitting builtin, so callers may catch either.
Messages name the bad value and what was expected. Five more live beside the code that
raises them, each a subclass of one here: ``lfctl.vision.frames.FrameError`` (a bad frame
or window), ``lfctl.record.writer.RecordError`` (a log that cannot be written),
``lfctl.sim.camera_pool.CameraWorkerError`` (a camera worker process that failed),
``lfctl.link.params.ParamFileError`` (a bad parameter file) and
``lfctl.video.SourceNotReady`` (a camera or stream not there yet); ``except LfctlError``
takes them all.
"""

from __future__ import annotations

import shlex

__all__ = [
    "BuildToolError",
    "ConfigError",
    "FmuError",
    "LfctlError",
    "LinkError",
    "LinkTimeoutError",
    "MissionProtocolError",
    "command",
    "file_name_encoding_error",
]


def command(*words: object) -> str:
    """A command line to copy and paste, as messages name one: each word quoted as a POSIX
    shell needs it (a path with a space, a name with a quote), e.g.
    ``lfctl audit 'my runs/x.mcap'``.

    Parameters
    ----------
    *words : object
        The command's words (paths and numbers as their text).
    """
    return " ".join(shlex.quote(str(w)) for w in words)


class LfctlError(Exception):
    """Base of every error lfctl raises on purpose."""


def file_name_encoding_error(exc: UnicodeError) -> LfctlError:
    """The error for a file name Python cannot encode: a name outside ASCII (the working
    folder's, a scenario's) under the C locale with Python's UTF-8 mode off
    (``PYTHONUTF8=0``), where the name reaches Python as surrogates.

    Parameters
    ----------
    exc : UnicodeError
        What failed.
    """
    import sys

    return LfctlError(
        f"a file name here is not valid in this system's file name encoding ({sys.getfilesystemencoding()}: "
        f"{exc.reason}): run lfctl under a UTF-8 locale (LANG=C.UTF-8) or with PYTHONUTF8=1"
    )


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
        self.message = message  # what went wrong, without the FMU's last word
        self.model = model
        self.call = call
        self.status = status
        self.log = list(log or [])
        detail = f" (FMU said: {self.log[-1]})" if self.log else ""
        super().__init__(message + detail)


class BuildToolError(FmuError):
    """The C compiler needed to build the FMUs is missing or failed."""


class LinkError(LfctlError, OSError):
    """A MAVLink connection could not be opened.

    Parameters
    ----------
    connect : str
        The connection string.
    reason : str
        What the operating system or pymavlink said.
    """

    def __init__(self, connect: str, reason: str) -> None:
        self.connect = connect
        self.reason = reason
        super().__init__(f"cannot open MAVLink connection {connect!r}: {reason}")


class LinkTimeoutError(LfctlError, TimeoutError):
    """A MAVLink peer did not answer in time.

    Parameters
    ----------
    expected : str
        What was awaited (a message name, or a description of it).
    sysid : int or None
        The system it was awaited from.
    timeout_s : float or None
        How long was waited, s.
    detail : str
        A hint for the user (what to check).
    """

    def __init__(
        self, expected: str, *, sysid: int | None = None, timeout_s: float | None = None, detail: str = ""
    ) -> None:
        self.expected = expected
        self.sysid = sysid
        self.timeout_s = timeout_s
        self.detail = detail
        who = f" from system {sysid}" if sysid is not None else ""
        within = f" within {timeout_s:g} s" if timeout_s is not None else ""
        super().__init__(f"no {expected}{who}{within}" + (f" ({detail})" if detail else ""))


class VehicleKindError(LfctlError):
    """The vehicle on the link is not one lfctl may command (not an ArduPilot Rover or boat:
    another vehicle's custom mode numbers mean other modes).

    Parameters
    ----------
    sysid : int
        Its system id.
    kind : str
        What its HEARTBEAT says it is (its MAV_TYPE and MAV_AUTOPILOT).
    """

    def __init__(self, sysid: int, kind: str) -> None:
        self.sysid = sysid
        self.kind = kind
        super().__init__(
            f"system {sysid} is {kind}, not an ArduPilot Rover: lfctl follow commands only Rovers (and boats), "
            "whose mode 15 is GUIDED (on a Copter it is AUTOTUNE): --target another system?"
        )


class MissionProtocolError(LfctlError):
    """The mission protocol went out of sequence or was refused.

    Parameters
    ----------
    message : str
        What happened.
    expected_seq, received_seq : int or None
        The item sequence number that was expected and the one that came, where that is
        what went wrong.
    result : str or None
        The vehicle's MAV_MISSION_RESULT name, when it refused.
    """

    def __init__(
        self,
        message: str,
        *,
        expected_seq: int | None = None,
        received_seq: int | None = None,
        result: str | None = None,
    ) -> None:
        self.expected_seq = expected_seq
        self.received_seq = received_seq
        self.result = result
        super().__init__(message)
