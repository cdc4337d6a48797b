"""FMUs stepped in a process of their own, so that one that crashes cannot end lfctl's.

An FMU is native code. In lfctl's own process, one that dereferences a bad pointer, aborts
or calls C's ``exit()`` ends the run there and then: no error, no closed log. :class:`FmuHost`
runs FMU instances in a worker process (a fresh interpreter, :mod:`lfctl.workers`) instead;
the run sees a :class:`HostedInstance` for each, used as an :class:`~lfctl.fmu.load.FmuInstance`
is. When the worker dies, or a step overruns ``timeout_s``, the run ends with an
:class:`~lfctl.errors.FmuError` naming the FMU, the vehicle, the FMI call it was in and the
simulation time, and its log is closed as after any other error.

How a step goes: the command and output rows live in a block of memory both processes map
(the co-simulation master reads and writes them as its own arrays). The main process sends
the step size (9 bytes); the worker steps each of its instances in turn and answers with an
empty message, or with the error its FMU gave; the main process checks the outputs as for
any FMU. Before each FMI call the worker writes which instance and which call into the
shared block, so a crash, a hang or a stop while an FMU is stuck is reported as precisely as
in one process, and a watchdog (:func:`~lfctl.fmu.load.calls_in_progress`) sees the call.

The archive is extracted once, by the main process; the worker loads the library from that
folder. A worker ends with the main process: when its connection closes, when it finds its
parent gone (:func:`lfctl.workers.watch_parent`, even while an FMU call is stuck), or by
:func:`end_hosts`. It runs in a process group of its own, so Ctrl-C and a signal to lfctl's
group reach lfctl alone, which stops the run between steps and then ends the worker.
"""

from __future__ import annotations

import contextlib
import ctypes
import functools
import logging
import mmap
import os
import pickle
import signal
import struct
import subprocess
import sys
import tempfile
import time
import traceback
from collections import deque
from collections.abc import Mapping
from multiprocessing.connection import Connection
from typing import IO, Any, NoReturn

import numpy as np

from lfctl.errors import ConfigError, FmuError
from lfctl.fmu.load import (
    INPUT_ROLES,
    KEPT_MESSAGES,
    OUTPUT_ROLES,
    FmuInstance,
    FmuLibrary,
    check_output_row,
    returned_from_call,
    unwatch_calls,
    watch_calls,
)
from lfctl.logs import guard_log
from lfctl.workers import start_worker, watch_parent, worker_fds

__all__ = ["SETUP_TIMEOUT_S", "STOP_GRACE_S", "FmuHost", "HostedInstance", "end_hosts"]

log = logging.getLogger(__name__)

#: how long a request other than a step (instantiate and initialise, close) may take at
#: least, s: a large model's setup can take seconds where its steps take microseconds
SETUP_TIMEOUT_S = 60.0
#: after Ctrl-C or SIGTERM mid-step, how long the step may go on before the FMU counts as
#: stuck and its process is ended, s (a step takes microseconds). Longer than the watchdog's
#: grace (:mod:`lfctl.sim.watchdog`, 0.5 s): under ``lfctl sim`` the watchdog, which sees the
#: worker's call, ends the run as it ends one whose FMU is stuck in this process
STOP_GRACE_S = 1.0

_NIN, _NOUT = len(INPUT_ROLES), len(OUTPUT_ROLES)
_ROW_BYTES = 8 * (_NIN + _NOUT)  # one vehicle's command and output rows, float64
_CALL_BYTES = 64  # the FMI call being made, NUL-terminated
_STEP, _REQUEST = b"s", b"p"  # what the main process sends: a step, or a pickled request
_ERROR, _VALUE = b"e", b"v"  # what the worker answers besides an empty message (a step done)

_HOSTS: dict[int, FmuHost] = {}


def end_hosts() -> None:
    """Kill every FMU worker of this process at once (a process about to ``os._exit``)."""
    for host in tuple(_HOSTS.values()):
        with contextlib.suppress(OSError):
            host._proc.kill()


class _Block:
    """The memory both processes map: the rows, then the instance (its slot + 1, 0 for none)
    and the FMI call the worker is inside."""

    def __init__(self, buffer: mmap.mmap, rows: int) -> None:
        self.cmd = np.ndarray((rows, _NIN), np.float64, buffer=buffer, offset=0)
        self.out = np.ndarray((rows, _NOUT), np.float64, buffer=buffer, offset=8 * _NIN * rows)
        self.slot = ctypes.c_int32.from_buffer(buffer, _ROW_BYTES * rows)
        self.call = (ctypes.c_char * _CALL_BYTES).from_buffer(buffer, _ROW_BYTES * rows + 8)
        self._encoded: dict[str, bytes] = {}

    @staticmethod
    def size(rows: int) -> int:
        return _ROW_BYTES * rows + 8 + _CALL_BYTES

    def enter(self, slot: int, call: str | None) -> None:
        """The worker is entering ``call`` of the instance in ``slot`` (None: leaving it)."""
        if call is None:
            self.slot.value = 0
            return
        raw = self._encoded.get(call)
        if raw is None:
            raw = self._encoded[call] = call.encode("ascii", "replace")[: _CALL_BYTES - 1]
        self.call.value = raw
        self.slot.value = slot + 1

    def where(self) -> tuple[int, str]:
        """(slot, call) the worker last entered and has not left; slot -1 when none."""
        return self.slot.value - 1, self.call.value.decode("ascii", "replace")


class HostedInstance:
    """One vehicle's FMU instance stepped by an :class:`FmuHost`'s worker (see the module).

    Its rows are the host's (``host.cmd[slot]``, ``host.out[slot]``); the host steps every
    instance it has at once (:meth:`FmuHost.start_step`, :meth:`FmuHost.finish_step`).

    Parameters
    ----------
    host : FmuHost
        The host whose worker runs it.
    slot : int
        Its row in the host's arrays.
    lib : FmuLibrary
        The FMU file it is an instance of (as loaded in this process, for names and scales).
    name : str
        The instance's name (the vehicle's).
    start_time_s : float
        The simulation's start time, s.
    """

    def __init__(self, host: FmuHost, slot: int, lib: FmuLibrary, name: str, start_time_s: float) -> None:
        self.host = host
        self.slot = slot
        self.lib = lib
        self.name = name
        self.t_s = start_time_s
        self.calls = 0
        #: what its FMU logged before an error (with the error)
        self.messages: deque[str] = deque(maxlen=KEPT_MESSAGES)

    @property
    def busy(self) -> str | None:
        """The FMI call its worker is inside for it while this process waits; None otherwise."""
        return self.host.busy_of(self.slot)

    def check_outputs(self) -> None:
        """Raise FmuError if an output read last is not finite or beyond the bounds
        (:func:`~lfctl.fmu.load.check_output_row`)."""
        check_output_row(self.lib, self.name, self.host.out[self.slot], self.t_s)


def _shared_file(size: int) -> tuple[int, IO[bytes] | None]:
    """A file of ``size`` zero bytes to map, that only its descriptors keep (memory on Linux)."""
    if hasattr(os, "memfd_create"):
        fd = os.memfd_create("lfctl-fmu-rows")
        os.ftruncate(fd, size)
        return fd, None
    f = tempfile.TemporaryFile()  # noqa: SIM115 (kept open for the host's life; closed in _release)
    os.ftruncate(f.fileno(), size)
    return f.fileno(), f


class FmuHost:
    """A worker process that runs FMU instances for this one (see the module).

    Use as a context manager, or call :meth:`close`.

    Parameters
    ----------
    rows : int
        Rows of the shared command and output arrays (:attr:`cmd`, :attr:`out`): one per
        vehicle of the run, hosted here or not.
    timeout_s : float
        The longest one step of every hosted instance may take, s; past it the worker is
        killed and FmuError raised. Other requests get at least :data:`SETUP_TIMEOUT_S`.

    Raises
    ------
    FmuError
        The worker could not be started.
    """

    def __init__(self, rows: int, timeout_s: float = 10.0) -> None:
        if rows < 1 or not timeout_s > 0:
            raise ValueError(f"FmuHost needs rows >= 1 and timeout_s > 0, got {rows!r}, {timeout_s!r}")
        self.timeout_s = timeout_s
        self._instances: dict[int, HostedInstance] = {}  # by slot
        self._waiting = False  # a reply is awaited: the worker's call is in progress for a watchdog
        self._dt_s = 0.0  # the step in flight
        self._in_flight = False
        self._closed = False
        self._fd, self._file = _shared_file(_Block.size(rows))
        self._buffer = mmap.mmap(self._fd, _Block.size(rows))
        self._block = _Block(self._buffer, rows)
        #: the command and output rows, FMU units (the co-simulation master's own arrays)
        self.cmd, self.out = self._block.cmd, self._block.out
        self._proc: subprocess.Popen[bytes]
        try:
            self._proc, self._conn = start_worker("lfctl.fmu.host", extra_fds=(self._fd,))
        except OSError as exc:
            self._release()
            raise FmuError(f"cannot start a process for FMUs: {exc}", call="host") from exc
        _HOSTS[id(self)] = self
        try:
            level = logging.getLogger("lfctl").getEffectiveLevel()
            self._request(("hello", rows, os.getpid(), level), (SETUP_TIMEOUT_S, "the setup's limit, SETUP_TIMEOUT_S"))
        except BaseException:
            self.close()
            raise

    # -- instances ----------------------------------------------------------------------
    def add(
        self,
        slot: int,
        lib: FmuLibrary,
        name: str,
        parameters: Mapping[str, float],
        pose: tuple[float, float, float],
        start_time_s: float = 0.0,
    ) -> HostedInstance:
        """Create, parameterise and initialise one instance in the worker.

        Parameters
        ----------
        slot : int
            Its row in :attr:`cmd` and :attr:`out`.
        lib : FmuLibrary
            Its FMU file, loaded (and extracted) in this process.
        name : str
            The instance's name (the vehicle's).
        parameters : Mapping[str, float]
            FMU parameter name -> value, FMU units.
        pose : (north_m, east_m, yaw_rad)
            The initial pose, SI (as :meth:`FmuLibrary.instantiate` takes it).
        start_time_s : float
            The simulation's start time, s.

        Raises
        ------
        FmuError, ConfigError
            As :meth:`FmuLibrary.instantiate` raises them in the worker, or the worker died.
        """
        if self._closed:
            raise FmuError("FmuHost.add after close()", model=lib.identifier, call="host")
        if slot in self._instances or not 0 <= slot < len(self.cmd):
            raise ValueError(f"slot {slot!r} is taken or outside 0..{len(self.cmd) - 1}")
        if lib.extraction is None:
            raise FmuError(f"{lib.path}: library is closed", model=lib.identifier, call="instantiate")
        inst = HostedInstance(self, slot, lib, name, start_time_s)
        self._instances[slot] = inst  # (its name in an error while it is set up)
        watch_calls(inst)  # (a watchdog sees its setup calls too)
        request = (
            "add",
            slot,
            str(lib.path),
            lib.role_map,
            lib.extraction,
            name,
            dict(parameters),
            tuple(pose),
            start_time_s,
        )
        try:
            self._request(request, self._setup_timeout())
        except BaseException:
            unwatch_calls(inst)
            del self._instances[slot]
            raise
        return inst

    def _setup_timeout(self) -> tuple[float, str]:
        if self.timeout_s >= SETUP_TIMEOUT_S:
            return self.timeout_s, "sim.fmu_step_timeout_s"
        return SETUP_TIMEOUT_S, "the setup's limit, SETUP_TIMEOUT_S"

    @property
    def pid(self) -> int:
        """The worker's process id."""
        return self._proc.pid

    def busy_of(self, slot: int) -> str | None:
        """The FMI call the worker is inside for the instance in ``slot`` while this process
        waits for it; None otherwise.

        Parameters
        ----------
        slot : int
            The instance's row.
        """
        if not self._waiting:
            return None
        busy_slot, call = self._block.where()
        return call if busy_slot == slot and call else None

    # -- stepping -----------------------------------------------------------------------
    def start_step(self, dt_s: float) -> None:
        """Send the worker a step of ``dt_s`` for every instance (the command rows as they
        are now); :meth:`finish_step` waits for it. This process is free meanwhile.

        Parameters
        ----------
        dt_s : float
            The communication step, s.
        """
        if self._closed or self._in_flight:
            raise RuntimeError("FmuHost.start_step " + ("after close()" if self._closed else "before finish_step()"))
        self._dt_s = dt_s
        self._send(_STEP + struct.pack("<d", dt_s))
        self._in_flight = True

    def finish_step(self) -> None:
        """Wait for the step :meth:`start_step` sent; the output rows then hold its outputs
        (unchecked, as :meth:`FmuInstance.step` leaves them).

        Raises
        ------
        FmuError
            An FMU's call failed, its worker died, or the step overran :attr:`timeout_s`.
        KeyboardInterrupt
            Ctrl-C or SIGTERM came while waiting, and the step ended within
            :data:`STOP_GRACE_S` (else FmuError: the FMU is stuck, and was ended).
        """
        if not self._in_flight:
            raise RuntimeError("FmuHost.finish_step without start_step()")
        data = self._reply((self.timeout_s, "sim.fmu_step_timeout_s"))
        self._in_flight = False
        if data:
            self._raise(data)
        for inst in self._instances.values():
            inst.t_s += self._dt_s

    # -- the connection -----------------------------------------------------------------
    def _send(self, data: bytes) -> None:
        try:
            self._conn.send_bytes(data)
        except OSError:  # broken pipe: the worker is gone
            raise self._failure("died", None) from None

    def _request(self, request: tuple[Any, ...], limit: tuple[float, str]) -> Any:
        """Send a request and return its answer (FmuError, ConfigError as the worker raised)."""
        self._send(_REQUEST + pickle.dumps(request))
        data = self._reply(limit)
        if data[:1] != _VALUE:
            self._raise(data)
        return pickle.loads(data[1:])

    def _reply(self, limit: tuple[float, str]) -> bytes:
        """The worker's answer, within ``limit`` (seconds, and the setting they come from)."""
        self._waiting = True
        try:
            try:
                ready = self._conn.poll(limit[0])
            except KeyboardInterrupt:
                self._stop()
            if not ready:
                raise self._failure("timeout", limit)
            return self._conn.recv_bytes()
        except (EOFError, OSError):
            raise self._failure("died") from None
        finally:
            self._waiting = False
            returned_from_call()

    def _stop(self) -> NoReturn:
        """Ctrl-C or SIGTERM came while the worker was in a call: a stop comes between steps,
        so let the call end (microseconds) and raise KeyboardInterrupt, unless it goes on for
        :data:`STOP_GRACE_S` (FmuError: stuck in an FMU's call; the worker is killed; outside
        any FMU's call, the worker is killed and the stop goes on). Further stops meanwhile
        are the same stop; a worker that dies meanwhile is reported (EOFError)."""
        deadline = time.monotonic() + STOP_GRACE_S
        while True:
            try:
                if self._conn.poll(max(0.0, deadline - time.monotonic())):
                    self._conn.recv_bytes()
                    break
                if time.monotonic() >= deadline:
                    if self._block.where()[0] in self._instances:
                        raise self._failure("stuck") from None
                    self._kill()  # in no FMU's call (still starting, say): a plain stop
                    break
            except KeyboardInterrupt:
                continue
        self._in_flight = False
        raise KeyboardInterrupt

    def _raise(self, data: bytes) -> None:
        """Raise the error the worker sent."""
        kind, message, model, call, status, messages, slot = pickle.loads(data[1:])
        if kind == "ConfigError":
            raise ConfigError(message)
        if kind == "FmuError":
            if slot in self._instances:
                self._instances[slot].messages.extend(messages)
            raise FmuError(message, model=model, call=call, status=status, log=messages)
        raise FmuError(f"the process stepping FMUs failed: {message}", model=model, call="host")

    def _failure(self, what: str, limit: tuple[float, str] | None = None) -> FmuError:
        """The worker died, overran a step, or is stuck after a stop: kill it, and say
        which FMU was in which call at what time, and how its process ended."""
        slot, call = self._block.where()
        stuck_in = call if slot in self._instances else ""
        self._kill()
        self._in_flight = False
        timeout_s, setting = limit or (0.0, "")
        code = self._proc.returncode
        if code is None or what != "died":
            how = ""
        elif code < 0:
            how = f"killed by {signal.Signals(-code).name}" if -code in signal.valid_signals() else f"signal {-code}"
        else:
            how = f"exit code {code}"
        if stuck_in:
            inst = self._instances[slot]
            model, t_s = inst.lib.identifier, inst.t_s
            who = f"FMU {model} ({inst.name})"
            if what == "died":
                message = f"{who} ended its process in {stuck_in} at t = {t_s:.6g} s ({how})"
            elif what == "timeout":
                message = (
                    f"{who} did not return from {stuck_in} within {timeout_s:g} s at t = {t_s:.6g} s "
                    f"({setting}); its process was ended"
                )
            else:
                message = f"{who} blocked in {stuck_in} at t = {t_s:.6g} s; terminated"
            return FmuError(message, model=model, call=stuck_in)
        names = ", ".join(f"{i.name} ({i.lib.identifier})" for i in self._instances.values()) or "no FMU yet"
        if what == "died":
            return FmuError(f"the process stepping FMUs for {names} ended ({how})", call="host")
        return FmuError(
            f"the process stepping FMUs for {names} did not answer within {timeout_s:g} s ({setting})", call="host"
        )

    # -- lifetime -----------------------------------------------------------------------
    def _kill(self) -> None:
        if self._proc.poll() is None:
            with contextlib.suppress(OSError):
                self._proc.kill()
        with contextlib.suppress(subprocess.TimeoutExpired):
            self._proc.wait(5.0)

    def close(self) -> None:
        """Free every instance in the worker and end it (killed if it does not end); safe to
        call twice. A step still under way (an error elsewhere, a stop) is given
        :data:`STOP_GRACE_S` to end first, so that its FMUs are terminated and freed."""
        if self._closed:
            return
        self._closed = True
        _HOSTS.pop(id(self), None)
        for inst in self._instances.values():
            unwatch_calls(inst)
        proc = getattr(self, "_proc", None)
        if proc is not None and proc.poll() is None:
            if self._in_flight:
                with contextlib.suppress(EOFError, OSError, KeyboardInterrupt):
                    if self._conn.poll(STOP_GRACE_S):
                        self._conn.recv_bytes()
                        self._in_flight = False
            if self._in_flight:  # stuck: no waiting on it
                self._kill()
            else:
                with contextlib.suppress(OSError):
                    self._conn.send_bytes(_REQUEST + pickle.dumps(("close",)))
                try:
                    proc.wait(5.0)
                except subprocess.TimeoutExpired:
                    log.warning("the process stepping FMUs did not end within 5 s of close(): killed")
                    self._kill()
        if proc is not None:
            self._conn.close()
        self._instances.clear()  # (they refer to this host: no cycle left to the collector)
        self._release()

    def _release(self) -> None:
        with contextlib.suppress(BufferError):  # views still held elsewhere: freed with them
            self._buffer.close()
        if self._file is not None:
            self._file.close()
        else:
            with contextlib.suppress(OSError):
                os.close(self._fd)
        self._fd = -1

    def __enter__(self) -> FmuHost:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


# -- the worker -------------------------------------------------------------------------
class _Reported(FmuInstance):
    """An instance in the worker that writes each FMI call it enters into the shared block."""

    def __init__(self, block: _Block, slot: int, *args: Any) -> None:
        self._block = block
        self._slot = slot
        self._busy: str | None = None
        super().__init__(*args)

    @property  # type: ignore[override]
    def busy(self) -> str | None:
        return self._busy

    @busy.setter
    def busy(self, call: str | None) -> None:
        self._busy = call
        self._block.enter(self._slot, call)


class _Worker:
    """What the worker process holds: the shared block, the libraries and the instances."""

    def __init__(self, fd: int) -> None:
        self.fd = fd
        self.block: _Block | None = None
        self.libraries: dict[str, FmuLibrary] = {}
        self.instances: list[_Reported] = []
        self.slot = -1  # the instance a request or step is about

    def handle(self, request: tuple[Any, ...]) -> Any:
        kind = request[0]
        if kind == "hello":
            _kind, rows, parent, level = request
            watch_parent(parent)
            logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")
            guard_log(debug=level <= logging.DEBUG)  # an FMU's own messages, as many as it likes
            self.block = _Block(mmap.mmap(self.fd, _Block.size(rows)), rows)
            return None
        if kind == "add":
            _kind, slot, path, role_map, folder, name, parameters, pose, start_time_s = request
            assert self.block is not None
            self.slot = slot
            lib = self.libraries.get(path)
            if lib is None:
                lib = self.libraries[path] = FmuLibrary(path, role_map, extracted=folder)
            make = functools.partial(_Reported, self.block, slot)
            inst = lib.instantiate(
                name, parameters, pose, self.block.cmd[slot], self.block.out[slot], start_time_s, make
            )
            assert isinstance(inst, _Reported)
            self.instances.append(inst)
            return None
        raise ValueError(f"unknown request {kind!r}")

    def step(self, dt_s: float) -> None:
        for inst in self.instances:
            self.slot = inst._slot
            inst.step(dt_s)

    def close(self) -> None:
        for lib in self.libraries.values():
            lib.close()


def _error_reply(exc: BaseException, slot: int) -> bytes:
    """An error for the main process: its kind, message, FMU fields, and the instance's slot."""
    if isinstance(exc, FmuError):
        fields = ("FmuError", exc.message, exc.model, exc.call, exc.status, list(exc.log), slot)
    elif isinstance(exc, ConfigError):
        fields = ("ConfigError", str(exc), "", "", None, [], slot)
    else:
        fields = ("bug", "".join(traceback.format_exception(exc)), "", "", None, [], slot)
    return _ERROR + pickle.dumps(fields)


def _unraisable(u: Any) -> None:
    """An FMU that closes the worker's descriptors makes their objects fail as they are
    collected: a debug line for each, not Python's traceback (the run's error says the rest).
    Anything else is Python's to report."""
    if issubclass(u.exc_type, OSError) and u.object is not None and "__del__" in repr(u.object):
        log.debug("worker: %s: %s", u.exc_type.__name__, u.exc_value)
        return
    sys.__unraisablehook__(u)


def _worker_main(conn: Connection, fd: int) -> None:
    """The worker: serve requests and steps until told to close or the connection ends."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the main process decides when a run ends
    sys.unraisablehook = _unraisable
    worker = _Worker(fd)
    try:
        while True:
            data = conn.recv_bytes()
            if data[:1] == _STEP:
                try:
                    worker.step(struct.unpack("<d", data[1:])[0])
                except Exception as exc:
                    conn.send_bytes(_error_reply(exc, worker.slot))
                else:
                    conn.send_bytes(b"")
                continue
            request = pickle.loads(data[1:])
            if request[0] == "close":
                break
            try:
                value = worker.handle(request)
            except Exception as exc:
                conn.send_bytes(_error_reply(exc, worker.slot))
            else:
                conn.send_bytes(_VALUE + pickle.dumps(value))
    except (EOFError, OSError):
        pass  # the main process went away
    finally:
        worker.close()


if __name__ == "__main__":
    # run from the module under its real name, so that what it unpickles names lfctl.fmu.host
    from lfctl.fmu import host

    conn_fd, rows_fd = worker_fds()
    host._worker_main(Connection(conn_fd), rows_fd)
