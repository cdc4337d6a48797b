"""Starting one of lfctl's worker processes: a fresh interpreter running an lfctl module,
talking to this process over a socket pair.

Not ``fork`` (the parent has threads: the link's, a watchdog, the foxglove SDK's), and not
multiprocessing's ``spawn``, which re-imports the caller's ``__main__`` (the ``lfctl`` console
script, or a user's script). The worker finds lfctl where this process found it, whatever
the install (editable, wheel, a source tree on ``PYTHONPATH``).
"""

from __future__ import annotations

import ctypes
import os
import queue
import signal
import socket
import subprocess
import sys
import threading
import time
from multiprocessing.connection import Connection
from typing import Any

__all__ = ["start_worker", "watch_parent", "worker_command", "worker_fds"]

_PACKAGE_ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
#: the worker's parent, for the worker to check (environment variable)
_PARENT_ENV = "LFCTL_WORKER_PARENT"
#: Linux's prctl option for the signal a process gets when its parent goes
_PR_SET_PDEATHSIG = 1
# Workers are started by one daemon thread that lives as long as the process (never joined,
# not even at exit): Linux's parent-death signal (below) fires when the *thread* that started
# a process ends, and the threads that open simulations come and go. Made on first use in each
# process: a forked child has the parent's queue but not its thread.
_spawner_lock = threading.Lock()
_spawner_jobs: queue.SimpleQueue[Any] | None = None


def _forget_spawner() -> None:
    global _spawner_lock, _spawner_jobs
    _spawner_lock, _spawner_jobs = threading.Lock(), None


os.register_at_fork(after_in_child=_forget_spawner)


def _spawner() -> queue.SimpleQueue[Any]:
    global _spawner_jobs
    with _spawner_lock:
        if _spawner_jobs is None:
            _spawner_jobs = queue.SimpleQueue()
            threading.Thread(target=_spawn_jobs, args=(_spawner_jobs,), name="lfctl-spawner", daemon=True).start()
        return _spawner_jobs


def _spawn_jobs(jobs: queue.SimpleQueue[Any]) -> None:
    while True:
        args, kwargs, box, done = jobs.get()
        try:
            box["proc"] = subprocess.Popen(args, **kwargs)
        except BaseException as exc:  # given to the caller
            box["error"] = exc
        finally:
            done.set()


def _popen(args: list[str], **kwargs: Any) -> subprocess.Popen[bytes]:
    """``subprocess.Popen(args, **kwargs)`` run by the spawner thread. A Ctrl-C while it runs
    waits for it and ends the process it started before going on up (its descriptors are the
    caller's to close, and must not be closed while it still passes them on)."""
    box: dict[str, Any] = {}
    done = threading.Event()
    _spawner().put((args, kwargs, box, done))
    interrupted = False
    while not done.is_set():
        try:
            done.wait()
        except KeyboardInterrupt:
            interrupted = True
    if "error" in box:
        raise box["error"]
    proc: subprocess.Popen[bytes] = box["proc"]
    if interrupted:
        proc.kill()
        proc.wait()
        raise KeyboardInterrupt
    return proc


#: what a worker's interpreter runs first: lfctl's folder on its module path where it is
#: not already (a source tree; a wheel's site-packages is, after the standard library),
#: then the worker's module as ``-m`` would run it
_BOOT = (
    "import os, runpy, sys\n"
    "root, module = sys.argv[1], sys.argv[2]\n"
    "del sys.argv[1:3]\n"
    "if os.path.realpath(root) not in {os.path.realpath(p) for p in sys.path}:\n"
    "    sys.path.insert(0, root)\n"
    "runpy.run_module(module, run_name='__main__', alter_sys=True)\n"
)


def _interpreter_flags() -> list[str]:
    """This interpreter's flags that decide where modules come from, for a worker's: a
    parent run with ``-E`` (``PYTHONPATH`` ignored), ``-s``, ``-S`` or ``-I`` finds its
    packages where its worker then does."""
    f = sys.flags
    if f.isolated:
        return ["-I"]
    return [flag for flag, on in (("-E", f.ignore_environment), ("-s", f.no_user_site), ("-S", f.no_site)) if on]


def worker_command(module: str, fds: tuple[int, ...]) -> list[str]:
    """The command line of a worker running ``module`` with ``fds``: this interpreter, with
    its flags and ``-P`` (the current folder kept off the module path: a ``numpy.py`` there
    is not imported), importing lfctl from where this process did.

    Parameters
    ----------
    module : str
        The module to run, e.g. ``"lfctl.fmu.host"``.
    fds : tuple of int
        The file descriptors it is given, as arguments.
    """
    return [sys.executable, "-P", *_interpreter_flags(), "-c", _BOOT, _PACKAGE_ROOT, module, *(str(fd) for fd in fds)]


def start_worker(module: str, *, extra_fds: tuple[int, ...] = ()) -> tuple[subprocess.Popen[bytes], Connection]:
    """Run ``module`` in a fresh interpreter (:func:`worker_command`) and return it with this
    end of its connection.

    The worker is given its end of the socket pair's file descriptor, then ``extra_fds``
    (kept open in it), as arguments (:func:`worker_fds` takes them); its stdin is closed, its
    stdout and stderr are this process's. It runs in a process group of its own, so a Ctrl-C
    at the terminal or a signal to this process's group (``timeout``, ``kill -- -PGID``)
    reaches this process alone, which ends the run and its workers in order.

    Parameters
    ----------
    module : str
        The module to run, e.g. ``"lfctl.fmu.host"``.
    extra_fds : tuple of int
        More file descriptors the worker inherits (a shared memory file, say).
    """
    ours, theirs = socket.socketpair()
    env = dict(os.environ)
    env[_PARENT_ENV] = str(os.getpid())
    try:
        with theirs:
            fds = (theirs.fileno(), *extra_fds)
            proc = _popen(worker_command(module, fds), pass_fds=fds, env=env, stdin=subprocess.DEVNULL, process_group=0)
    except BaseException:
        ours.close()
        raise
    return proc, Connection(ours.detach())


def worker_fds() -> tuple[int, ...]:
    """In a worker: the file descriptors :func:`start_worker` gave it (its connection's
    first), made non-inheritable, so that a process the worker's code starts (an FMU that
    runs a program) does not hold them open after the worker has gone."""
    _die_with_parent()
    fds = tuple(int(a) for a in sys.argv[1:])
    for fd in fds:
        os.set_inheritable(fd, False)
    return fds


def _die_with_parent() -> None:
    """On Linux, have the kernel kill this worker when its parent ends (``PR_SET_PDEATHSIG``):
    unlike :func:`watch_parent`'s thread, it acts while native code holds the interpreter's
    lock (an FMU library whose constructor never returns, as ``dlopen`` runs it)."""
    parent = os.environ.pop(_PARENT_ENV, None)
    if not sys.platform.startswith("linux") or parent is None:
        return
    libc = ctypes.CDLL(None, use_errno=True)
    if libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0) == 0 and os.getppid() != int(parent):
        os._exit(1)  # the parent had already gone


def watch_parent(parent: int, every_s: float = 0.5) -> None:
    """In a worker: end this process (exit code 1) once process ``parent`` has ended.

    A daemon thread looks every ``every_s``: it acts even while the worker's main thread is
    stuck in native code that released the interpreter lock (an FMU's ``doStep``), after its
    parent was killed without a chance to end it. On Linux the parent-death signal
    (:func:`worker_fds`) also covers native code that holds the lock.

    Parameters
    ----------
    parent : int
        The process id of the process that started this one.
    every_s : float
        How often to look, s.
    """
    if os.getppid() != parent:
        os._exit(1)

    def watch() -> None:
        while True:
            time.sleep(every_s)
            if os.getppid() != parent:
                os._exit(1)

    threading.Thread(target=watch, name="lfctl-watch-parent", daemon=True).start()
