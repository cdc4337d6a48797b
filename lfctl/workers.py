"""Starting one of lfctl's worker processes: a fresh interpreter running an lfctl module,
talking to this process over a socket pair.

Not ``fork`` (the parent has threads: the link's, a watchdog, the foxglove SDK's), and not
multiprocessing's ``spawn``, which re-imports the caller's ``__main__`` (the ``lfctl`` console
script, or a user's script). The worker finds lfctl where this process found it, whatever
the install (editable, wheel, a source tree on ``PYTHONPATH``).
"""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import threading
import time
from multiprocessing.connection import Connection

__all__ = ["start_worker", "watch_parent", "worker_fds"]

_PACKAGE_ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def start_worker(module: str, *, extra_fds: tuple[int, ...] = ()) -> tuple[subprocess.Popen[bytes], Connection]:
    """Run ``python -P -m module CONN_FD [FD ...]`` and return it with this end of its connection.

    The worker is given its end of the socket pair's file descriptor, then ``extra_fds``
    (kept open in it), as arguments (:func:`worker_fds` takes them); its stdin is closed, its
    stdout and stderr are this process's. It runs in a process group of its own, so a Ctrl-C
    at the terminal or a signal to this process's group (``timeout``, ``kill -- -PGID``)
    reaches this process alone, which ends the run and its workers in order; ``-P`` keeps the
    current folder off its module path (a ``numpy.py`` there is not imported).

    Parameters
    ----------
    module : str
        The module to run, e.g. ``"lfctl.fmu.host"``.
    extra_fds : tuple of int
        More file descriptors the worker inherits (a shared memory file, say).
    """
    ours, theirs = socket.socketpair()
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [_PACKAGE_ROOT, env.get("PYTHONPATH")]))
    try:
        with theirs:
            fds = (theirs.fileno(), *extra_fds)
            proc = subprocess.Popen(
                [sys.executable, "-P", "-m", module, *(str(fd) for fd in fds)],
                pass_fds=fds,
                env=env,
                stdin=subprocess.DEVNULL,
                process_group=0,
            )
    except BaseException:
        ours.close()
        raise
    return proc, Connection(ours.detach())


def worker_fds() -> tuple[int, ...]:
    """In a worker: the file descriptors :func:`start_worker` gave it (its connection's
    first), made non-inheritable, so that a process the worker's code starts (an FMU that
    runs a program) does not hold them open after the worker has gone."""
    fds = tuple(int(a) for a in sys.argv[1:])
    for fd in fds:
        os.set_inheritable(fd, False)
    return fds


def watch_parent(parent: int, every_s: float = 0.5) -> None:
    """In a worker: end this process (exit code 1) once process ``parent`` has ended.

    A daemon thread looks every ``every_s``: it acts even while the worker's main thread is
    stuck in native code that released the interpreter lock (an FMU's ``doStep``), after its
    parent was killed without a chance to end it. (Linux's parent-death signal would fire
    when the thread that started the worker ends, not its process.)

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
