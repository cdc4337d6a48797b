"""Log lines that carry a peer's or an FMU's text are tamed before they reach the terminal:
control characters escaped, long lines cut, and a logger that speaks too often held back."""

from __future__ import annotations

import io
import logging

import pytest

import lfctl.checks
from lfctl.checks import LogGuard


def _logger(guard: LogGuard) -> tuple[logging.Logger, io.StringIO]:
    out = io.StringIO()
    handler = logging.StreamHandler(out)
    handler.setFormatter(logging.Formatter("%(name)s: %(message)s"))
    handler.addFilter(guard)
    log = logging.getLogger(f"test-guard-{id(guard)}")
    log.propagate = False
    log.handlers = [handler]
    return log, out


def test_a_peers_escape_sequences_are_escaped_and_a_long_line_cut() -> None:
    log, out = _logger(LogGuard(max_chars=40))
    log.error("Invalid message from %s: %s", "127.0.0.1:9", "\x1b[2J\x1b]0;PWNED\x07\nFAKE lfctl: ok")
    log.error("B" * 100)
    lines = out.getvalue().splitlines()
    assert "\x1b" not in out.getvalue() and len(lines) == 2  # the peer's newline is escaped too
    assert lines[0].endswith(r": Invalid message from 127.0.0.1:9: \x1b[2... (33 more characters)")
    assert lines[1].endswith("B" * 40 + "... (60 more characters)")


def test_a_logger_that_speaks_too_often_is_held_back_and_says_how_much(monkeypatch: pytest.MonkeyPatch) -> None:
    now = [100.0]
    monkeypatch.setattr(lfctl.checks.time, "monotonic", lambda: now[0])
    log, out = _logger(LogGuard(burst=3, window_s=10.0))
    for k in range(50):
        log.warning("bad datagram %d", k)
    now[0] += 10.0
    log.warning("later")
    assert out.getvalue().splitlines()[-4:] == [
        f"{log.name}: bad datagram 0",
        f"{log.name}: bad datagram 1",
        f"{log.name}: bad datagram 2",
        f"{log.name}: (47 more lines of {log.name} left out) later",
    ]
    debug, out = _logger(LogGuard(burst=None))  # --debug: every line
    for k in range(50):
        debug.warning("bad datagram %d", k)
    assert len(out.getvalue().splitlines()) == 50
