"""Shared helpers for the benchmark scripts: table printing, the closing JSON line, free
loopback ports."""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import random
import socket
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

__all__ = ["free_udp_ports", "print_json", "print_table", "run_as_script"]


def print_table(headers: Sequence[str], rows: Sequence[Sequence[object]]) -> None:
    """Print a Markdown table (readable in a terminal and pasteable into notes).

    Parameters
    ----------
    headers : sequence of str
        Column titles.
    rows : sequence of sequences
        One sequence of cells per row, as many as ``headers``; floats get 3 significant
        digits.
    """
    cells = [[str(h) for h in headers], *[[_fmt(c) for c in r] for r in rows]]
    widths = [max(len(r[i]) for r in cells) for i in range(len(headers))]
    print("| " + " | ".join(c.rjust(w) for c, w in zip(cells[0], widths, strict=True)) + " |")
    print("|" + "|".join("-" * (w + 2) for w in widths) + "|")
    for r in cells[1:]:
        print("| " + " | ".join(c.rjust(w) for c, w in zip(r, widths, strict=True)) + " |")


def _fmt(value: object) -> str:
    if isinstance(value, float):
        return f"{value:.3g}" if abs(value) < 1000 else f"{value:.0f}"
    return str(value)


def print_json(benchmark: str, results: object) -> None:
    """The last line of every benchmark: one JSON object (with the machine and Python).

    A figure that could not be measured (NaN, as a median of nothing is) or is infinite is
    written ``null``: JSON has no NaN, and Python's ``json`` would write a bare ``NaN`` that
    strict readers (JavaScript's ``JSON.parse``, Go's, Rust's serde) refuse, losing the whole
    line.

    Parameters
    ----------
    benchmark : str
        The benchmark's name.
    results : object
        Its figures, JSON-serialisable.
    """
    line = {
        "benchmark": benchmark,
        "machine": platform.machine(),
        "python": platform.python_version(),
        "results": results,
    }
    print(json.dumps(_finite_or_null(line), allow_nan=False))


def _finite_or_null(value: object) -> object:
    """``value`` with every NaN or infinite float in it (at any depth of dicts, lists and
    tuples) made None."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _finite_or_null(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite_or_null(v) for v in value]
    return value


def run_as_script(main: Callable[[bool], None], doc: str | None, argv: Sequence[str] | None = None) -> None:
    """``python -m lfctl.bench.NAME [--quick]``: run a benchmark's ``main`` with the command
    line's ``--quick``; ``--help`` says what it measures, anything else is refused (a
    misspelt option used to run the whole benchmark).

    Parameters
    ----------
    main : callable
        The benchmark's ``main(quick)``.
    doc : str or None
        Its module's docstring (the help's description).
    argv : sequence of str, optional
        The arguments (default ``sys.argv[1:]``).
    """
    spec = getattr(sys.modules["__main__"], "__spec__", None)
    prog = f"python3 -m {spec.name}" if spec is not None else None  # (run as a module, as lfctl bench does)
    parser = argparse.ArgumentParser(prog=prog, description=(doc or "").strip().split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="shorter runs (a smoke check)")
    main(parser.parse_args(argv).quick)


#: where :func:`free_udp_ports` looks first: from here up to the kernel's ephemeral ports or
#: PORTS_BELOW, whichever is lower (above MAVLink's fixed ports, 14540-14600, that programs
#: send to without binding; below Kubernetes' node ports, 30000 up)
PORTS_FROM = 15000
PORTS_BELOW = 30000


def free_udp_ports(n: int) -> int:
    """A base port with ``n`` free consecutive UDP ports on 127.0.0.1 (found free, then let
    go, for a program started next to bind).

    They are looked for at random from :data:`PORTS_FROM` up to the kernel's ephemeral range
    (``/proc/sys/net/ipv4/ip_local_port_range``, 32768 up by default) or :data:`PORTS_BELOW`,
    where no socket that another program opens on port 0 meanwhile can take them; among the
    ephemeral ports when there is no room there.

    Parameters
    ----------
    n : int
        How many consecutive ports.

    Raises
    ------
    RuntimeError
        No such run of ports found in 200 tries.
    """
    try:
        ephemeral = int(Path("/proc/sys/net/ipv4/ip_local_port_range").read_text().split()[0])
    except (OSError, ValueError, IndexError):
        ephemeral = 32768
    top = min(ephemeral, PORTS_BELOW)
    below = top - n > PORTS_FROM + 1000
    rnd = random.Random(os.getpid() ^ int.from_bytes(os.urandom(4), "little"))
    for _ in range(200):
        if below:
            base = rnd.randrange(PORTS_FROM, top - n)
        else:
            with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
                probe.bind(("127.0.0.1", 0))
                base = probe.getsockname()[1]
            if base + n > 65536:
                continue
        socks: list[socket.socket] = []
        try:
            for k in range(n):
                socks.append(socket.socket(socket.AF_INET, socket.SOCK_DGRAM))
                socks[-1].bind(("127.0.0.1", base + k))
        except OSError:
            continue
        finally:
            for sock in socks:
                sock.close()
        return base
    raise RuntimeError(f"no {n} free consecutive UDP ports on 127.0.0.1")
