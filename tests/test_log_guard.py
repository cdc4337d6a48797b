"""Log lines that carry a peer's or an FMU's text are tamed before they reach the terminal:
control characters escaped, long lines cut, and a logger that speaks too often held back."""

from __future__ import annotations

import io
import logging
import sys

import pytest

import lfctl.logs
from lfctl.logs import LogGuard


def _logger(guard: LogGuard) -> tuple[logging.Logger, io.StringIO]:
    out = io.StringIO()
    handler = logging.StreamHandler(out)
    handler.setFormatter(logging.Formatter("%(name)s: %(message)s"))
    handler.addFilter(guard)
    log = logging.getLogger(f"test-guard-{id(guard)}")
    log.propagate = False
    log.setLevel(logging.DEBUG)
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


def test_a_warning_said_too_often_is_held_back_and_says_so(monkeypatch: pytest.MonkeyPatch) -> None:
    now = [100.0]
    monkeypatch.setattr(lfctl.logs.time, "monotonic", lambda: now[0])
    log, out = _logger(LogGuard(burst=2, window_s=10.0))
    for k in range(50):
        log.warning("Unknown parameter %s", f"JUNK{k}")  # a peer's flood
        if k == 10:
            log.warning("%s: %s", "leader", "Fence breached")  # the vehicle's own warning is not held back
            log.warning("%s: %s", "leader", "Unknown parameter A")  # (logged as the endpoint logs its texts)
            log.info("Reached waypoint %d", 1)  # nor progress (-v)
    now[0] += 10.0
    log.warning("Unknown parameter %s", "LATER")
    assert [line.split(": ", 1)[1] for line in out.getvalue().splitlines()] == [
        "Unknown parameter JUNK0",
        "Unknown parameter JUNK1",
        "(more like this held back for 10 s) Unknown parameter JUNK2",
        "leader: Fence breached",
        "leader: Unknown parameter A",
        "Reached waypoint 1",
        "(47 more like this held back) Unknown parameter LATER",
    ]
    debug, out = _logger(LogGuard(burst=None))  # --debug: every line
    for k in range(50):
        debug.warning("bad datagram %d", k)
    assert len(out.getvalue().splitlines()) == 50


def test_a_bad_log_call_is_reported_by_logging_as_without_the_guard(capsys: pytest.CaptureFixture[str]) -> None:
    log, out = _logger(LogGuard())
    log.warning("%d items", "not a number")  # the caller goes on; logging says "--- Logging error ---"
    log.warning("after")
    assert out.getvalue().splitlines()[-1].endswith(": after") and "Logging error" in capsys.readouterr().err


def test_kinds_past_the_most_counted_are_held_back_and_said_later(monkeypatch: pytest.MonkeyPatch) -> None:
    now = [100.0]
    monkeypatch.setattr(lfctl.logs.time, "monotonic", lambda: now[0])
    guard = LogGuard(burst=2, window_s=10.0, max_kinds=3)
    log, out = _logger(guard)
    for k in range(3):
        log.warning("kind%s one", chr(ord("a") + k))  # three kinds: every place taken
    log.warning("kinda one")  # a kind already counted is still said
    for k in range(500):
        log.warning("new%s kind", chr(ord("A") + k % 26) * (1 + k // 26))  # a flood of new kinds: held back
    assert len(guard._windows) == 3
    now[0] += 10.0
    log.warning("kinda one")  # a kind already counted, once a place is free: it says what waited
    log.warning("later one")  # and a new kind takes a free place
    assert [line.split(": ", 1)[1] for line in out.getvalue().splitlines()] == [
        "kinda one",
        "kindb one",
        "kindc one",
        "kinda one",
        "(500 more warnings held back) kinda one",
        "later one",
    ]
    assert set(guard._windows) == {(log.name, "kinda one"), (log.name, "later one")}


def test_threads_share_a_full_table_without_an_error_reaching_the_caller() -> None:
    import threading

    guard = LogGuard(burst=1, window_s=0.0005, max_kinds=50)
    log, _out = _logger(guard)
    errors: list[BaseException] = []

    def flood(k: int) -> None:
        try:
            for n in range(3000):
                log.warning("w%s kind", _letters(k * 3000 + n))  # new kinds, windows ending all the time
        except BaseException as exc:  # what reached the caller (a KeyError from the table)
            errors.append(exc)

    threads = [threading.Thread(target=flood, args=(k,)) for k in range(8)]
    switch = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)  # threads switch between any two steps, as under load
    try:
        for t in threads:
            t.start()
        for t in threads:
            t.join()
    finally:
        sys.setswitchinterval(switch)
    assert errors == [] and len(guard._windows) <= 50


def _letters(n: int) -> str:
    """``n`` written in letters (a kind of line ignores digits)."""
    out = ""
    while True:
        n, r = divmod(n, 26)
        out += chr(ord("a") + r)
        if not n:
            return out
