"""Log lines bound for a terminal, tamed (:class:`LogGuard`): what a network peer or an FMU
makes lfctl log is escaped, cut and, when it comes too often, held back."""

from __future__ import annotations

import logging
import re
import threading
import time

from lfctl.checks import printable

__all__ = ["LogGuard", "guard_log"]


class LogGuard(logging.Filter):
    """Log lines bound for a terminal, tamed: a network peer (a Foxglove client sending
    garbage, a ground station's bad requests) or an FMU can make a logger speak with its own
    text as often as it likes. Each line's control characters are escaped (a peer's escape
    sequences do not reach the terminal) and it is cut to ``max_chars``. Unless ``burst`` is
    None, one kind of warning or error (a logger's lines that start with the same two words,
    numbers aside: :func:`_kind`) is said at most ``burst`` times in ``window_s`` seconds: the
    next says that more like it are held back, and the first after the window how many were.
    Other lines of the same logger, and lines below WARNING (``-v``'s progress), are not held
    back. At most ``max_kinds`` kinds are counted at once (a peer that makes every line a new
    kind grows neither the count nor the output without end): a new kind takes the place of
    kinds whose window has ended; with none ended, its lines are held back too. Those, and the
    lines held back of a kind whose place was taken, are counted on the first line let
    through once a place has come free ("(N more warnings held back)"). Threads may share one.

    Attach it to the handler that writes to the terminal (``handler.addFilter``).

    Parameters
    ----------
    burst : int or None
        Lines of one kind per window (None: no limit, as with ``--debug``).
    window_s : float
        The window, s.
    max_chars : int
        The longest line kept; the rest is cut, saying how much.
    max_kinds : int
        The most kinds of line counted at once.
    """

    def __init__(
        self, burst: int | None = 20, window_s: float = 10.0, max_chars: int = 1000, max_kinds: int = 1000
    ) -> None:
        super().__init__()
        self.burst, self.window_s, self.max_chars, self.max_kinds = burst, window_s, max_chars, max_kinds
        # (logger, kind of line) -> (the window's start, lines said in it, lines held back)
        self._windows: dict[tuple[str, str], tuple[float, int, int]] = {}
        self._unplaced = 0  # lines held back for want of a place (max_kinds), not yet said
        self._full_until = 0.0  # with every place taken: no kind's window ends before this
        self._lock = threading.Lock()

    def filter(self, record: logging.LogRecord) -> bool:
        try:
            text = record.getMessage()
        except Exception:  # a bad log call: logging reports it as it would without the guard
            return True
        note = ""
        if self.burst is not None and record.levelno >= logging.WARNING:
            with self._lock:  # (logging runs filters outside its handler's lock: threads share the table)
                passed = self._count((record.name, _kind(text)), time.monotonic())
            if passed is None:
                return False
            note = passed
        text = printable(text)
        if len(text) > self.max_chars:
            text = f"{text[: self.max_chars]}... ({len(text) - self.max_chars} more characters)"
        record.msg, record.args = note + text, None
        return True

    def _count(self, key: tuple[str, str], now: float) -> str | None:
        """Count a line of kind ``key``: None to hold it back, else the note it goes out with."""
        note, burst = "", self.burst or 0  # (called with a burst only)
        if key not in self._windows and len(self._windows) >= self.max_kinds and not self._make_room(now):
            self._unplaced += 1
            return None
        if self._unplaced and now >= self._full_until:  # a place has come free: say what waited
            note, self._unplaced = f"({self._unplaced} more warnings held back) ", 0
        start, said, held = self._windows.get(key, (now, 0, 0))
        if now - start >= self.window_s:
            note += f"({held} more like this held back) " if held else ""
            start, said, held = now, 0, 0
        if said > burst:
            self._windows[key] = (start, said, held + 1)
            return None
        if said == burst:
            note += f"(more like this held back for {self.window_s:g} s) "
        self._windows[key] = (start, said + 1, held)
        return note

    def _make_room(self, now: float) -> bool:
        """Forget the kinds whose window has ended (the lines they held back join those said
        with the next line let through); whether there is room for a new kind now. Between
        the windows' ends the kinds are not looked through again (a flood of new kinds costs
        no more a line)."""
        if now < self._full_until:
            return False
        ended = [k for k, (start, _said, _held) in self._windows.items() if now - start >= self.window_s]
        for k in ended:
            self._unplaced += self._windows.pop(k)[2]
        if not ended:
            self._full_until = min(start for start, _said, _held in self._windows.values()) + self.window_s
        return bool(ended)


def _kind(text: str) -> str:
    """What kind of line a log line is: its first two words, numbers as ``#`` (a peer's text
    comes after the words that say what happened: "Unknown parameter JUNK7", "v: Unknown
    parameter JUNK7", "Invalid message from 127.0.0.1:5000: ...")."""
    return " ".join(re.sub(r"\d+", "#", text).split()[:2])


def guard_log(debug: bool = False) -> None:
    """Put a :class:`LogGuard` on the root logger's stream handlers (after
    ``logging.basicConfig``); with ``debug``, lines are escaped and cut but not limited.

    Parameters
    ----------
    debug : bool
        Every line is wanted (``--debug``).
    """
    for handler in logging.getLogger().handlers:
        # basicConfig's own (not a test harness's capture handlers), once
        if type(handler) is logging.StreamHandler and not any(isinstance(f, LogGuard) for f in handler.filters):
            handler.addFilter(LogGuard(burst=None if debug else 20))
