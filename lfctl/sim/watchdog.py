"""Ending a run whose FMU does not return when it is asked to stop (SIGTERM, Ctrl-C).

`lfctl sim` turns SIGTERM and SIGINT into a stop between two steps. That needs the main
thread to come back from the FMU: Python runs signal handlers only between bytecodes of the
main thread, and an FMU stuck in ``doStep`` (an endless loop in C) keeps it inside a ctypes
call for ever. Python's C-level handler does run at once, though, and writes the signal's
number to the file descriptor given to :func:`signal.set_wakeup_fd`; ctypes has released the
GIL, so another thread can act on it.

:class:`BlockedCallWatchdog` is that thread. It sleeps on a socket pair until a signal
arrives; after SIGTERM or SIGINT it polls :func:`lfctl.fmu.load.calls_in_progress` every
:data:`POLL_S`. When one FMI call has lasted :data:`GRACE_S` since the signal (a normal step
takes microseconds, and the stop would have come between steps), it holds the FMU return gate
(:func:`lfctl.fmu.load.hold_returns`: should the call return now, the main thread waits there
and cannot touch the recorder), runs the finishers registered with :func:`finish_on_abandon`
(the runner closes the MCAP log with reason ``error: FMU ... blocked in ...; terminated``),
removes the extracted FMU folders, prints one line to stderr and ends the process with
``os._exit(128 + signal)`` (143 for SIGTERM, 130 for SIGINT). docs/architecture.md,
"Containing FMUs".
"""

from __future__ import annotations

import contextlib
import itertools
import logging
import os
import select
import signal
import socket
import sys
import threading
import time
from collections.abc import Callable, Iterator
from typing import TextIO

from lfctl.fmu.host import end_hosts
from lfctl.fmu.load import calls_in_progress, discard_extractions, hold_returns

__all__ = ["GRACE_S", "POLL_S", "BlockedCallWatchdog", "finish_on_abandon"]

log = logging.getLogger(__name__)

#: how long an FMI call may go on after SIGTERM / SIGINT before the run is abandoned, s
GRACE_S = 0.5
#: how often the calls in progress are looked at once a signal came, s
POLL_S = 0.05
_WATCHED = (signal.SIGINT, signal.SIGTERM)

_finishers: dict[int, Callable[[str], None]] = {}
_ids = itertools.count()


@contextlib.contextmanager
def finish_on_abandon(finish: Callable[[str], None]) -> Iterator[None]:
    """While inside, ``finish(message)`` is called before a watchdog abandons the process.

    It is called from the watchdog's thread while the main thread is stuck in an FMU (and
    held there), with a message such as ``FMU Rover (f1) blocked in fmi2DoStep at t = 3.2 s;
    terminated``. It should be quick and must not call an FMU.

    Parameters
    ----------
    finish : callable
        Told the message; e.g. closes the run's recorder with it.
    """
    key = next(_ids)
    _finishers[key] = finish
    try:
        yield
    finally:
        _finishers.pop(key, None)


class BlockedCallWatchdog:
    """End the process when an FMU call does not return after SIGTERM or SIGINT (see the module).

    Use as a context manager, in the main thread, around a run whose signal handlers are
    installed (the signals must have Python handlers for the wakeup fd to be written); outside
    the main thread it does nothing.

    Parameters
    ----------
    grace_s : float
        How long a call may go on after the signal, s.
    stream : file, optional
        Where the one-line message goes (default ``sys.stderr``).
    """

    def __init__(self, grace_s: float = GRACE_S, stream: TextIO | None = None) -> None:
        self.grace_s = grace_s
        self.stream = stream
        self._thread: threading.Thread | None = None
        self._rsock: socket.socket | None = None
        self._wsock: socket.socket | None = None
        self._old_fd = -1

    def __enter__(self) -> BlockedCallWatchdog:
        if threading.current_thread() is not threading.main_thread():
            return self
        r, w = socket.socketpair()
        w.setblocking(False)
        try:
            self._old_fd = signal.set_wakeup_fd(w.fileno(), warn_on_full_buffer=False)
        except (ValueError, OSError) as exc:  # not the main interpreter / thread
            log.debug("no FMU watchdog: %s", exc)
            r.close()
            w.close()
            return self
        self._rsock, self._wsock = r, w
        self._thread = threading.Thread(target=self._watch, name="lfctl-fmu-watchdog", daemon=True)
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        if self._thread is None:
            return
        assert self._rsock is not None and self._wsock is not None
        signal.set_wakeup_fd(self._old_fd)
        with contextlib.suppress(OSError):
            self._wsock.send(b"\0")  # not a signal number: the thread ends
        self._thread.join(1.0)
        self._rsock.close()
        self._wsock.close()
        self._thread = None

    def _watch(self) -> None:
        assert self._rsock is not None
        signum = 0  # the first SIGTERM / SIGINT seen
        seen: dict[tuple[object, ...], float] = {}  # call key -> when first seen in progress
        while True:
            ready, _, _ = select.select([self._rsock], [], [], POLL_S if signum else None)
            if ready:
                data = self._rsock.recv(256)
                if not data or 0 in data:
                    return
                signum = signum or next((s for s in data if s in _WATCHED), 0)
            if not signum:
                continue
            now = time.monotonic()
            with hold_returns():
                calls = calls_in_progress()
                seen = {key: seen.get(key, now) for _inst, _call, key in calls}
                for inst, call, key in calls:
                    if now - seen[key] >= self.grace_s:
                        self._abandon(inst, call, signum)  # does not return

    def _abandon(self, inst: object, call: str, signum: int) -> None:
        lib = getattr(inst, "lib", None)
        ident = getattr(lib, "identifier", "?")
        name = getattr(inst, "name", "?")
        t_s = getattr(inst, "t_s", float("nan"))
        message = f"FMU {ident} ({name}) blocked in {call} at t = {t_s:.6g} s; terminated"
        for finish in tuple(_finishers.values()):
            try:
                finish(message)
            except Exception as exc:  # the process ends either way; say what was lost
                self._say(f"lfctl: could not finish the run: {type(exc).__name__}: {exc}")
        with contextlib.suppress(Exception):
            end_hosts()  # FMUs in processes of their own
            discard_extractions()
        self._say(f"lfctl: error: {message} by {signal.Signals(signum).name}")
        os._exit(128 + signum)

    def _say(self, line: str) -> None:
        stream = self.stream or sys.stderr
        with contextlib.suppress(Exception):
            stream.write(line + "\n")
            stream.flush()
