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
from multiprocessing.connection import Connection

__all__ = ["start_worker"]

_PACKAGE_ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def start_worker(module: str, *, extra_fds: tuple[int, ...] = ()) -> tuple[subprocess.Popen[bytes], Connection]:
    """Run ``python -m module CONN_FD [FD ...]`` and return it with this end of its connection.

    The worker is given its end of the socket pair's file descriptor, then ``extra_fds``
    (kept open in it), as arguments; its stdin is closed, its stdout and stderr are this
    process's.

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
                [sys.executable, "-m", module, *(str(fd) for fd in fds)],
                pass_fds=fds,
                env=env,
                stdin=subprocess.DEVNULL,
            )
    except BaseException:
        ours.close()
        raise
    return proc, Connection(ours.detach())
