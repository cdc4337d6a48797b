"""Argument types for the commands' options: each checks its value when the command line is
parsed, with the same rules and messages as scenario keys (:mod:`lfctl.checks`), so a bad
option is one line naming it, the value and what was expected, and exit code 2."""

from __future__ import annotations

import argparse
import re
import textwrap
from collections.abc import Callable
from pathlib import Path
from typing import Any

from lfctl.checks import Bound, check_connection, check_name
from lfctl.errors import ConfigError, command

__all__ = [
    "TRACKER_KINDS",
    "OneLineParser",
    "WholePathsFormatter",
    "command",
    "connection",
    "integer",
    "name",
    "number",
    "param_name",
    "whole_path",
]


#: ``--tracker``'s names (``track``, ``replay``) -> the tracker kind: ``hue-only`` as the
#: benchmark tables name the paper's baseline, ``hue`` as the library does
TRACKER_KINDS = {"full": "full", "hs-lbp": "hs-lbp", "hue-only": "hue", "hue": "hue"}


#: stands for a space inside a path in help text until the text is wrapped (not whitespace to
#: ``str.split`` or ``textwrap``, so the path is one word)
_PATH_SPACE = "\0"


def whole_path(path: object) -> str:
    """A path to put in help text: :class:`WholePathsFormatter` keeps it on one line even where
    it holds spaces (a venv under ``~/My Projects``).

    Parameters
    ----------
    path : path-like
        The path.
    """
    return str(path).replace(" ", _PATH_SPACE)


class WholePathsFormatter(argparse.HelpFormatter):
    """argparse's help layout, but a line is never broken inside a word or at its hyphens: a
    path such as ``.../site-packages/lfctl/examples`` stays whole, to be copied (one with
    spaces too, when given through :func:`whole_path`)."""

    def _split_lines(self, text: str, width: int) -> list[str]:
        text = " ".join(text.split())
        lines = textwrap.wrap(text, width, break_on_hyphens=False, break_long_words=False)
        return [line.replace(_PATH_SPACE, " ") for line in lines]

    def _fill_text(self, text: str, width: int, indent: str) -> str:
        text = " ".join(text.split())
        return textwrap.fill(
            text, width, initial_indent=indent, subsequent_indent=indent, break_on_hyphens=False, break_long_words=False
        ).replace(_PATH_SPACE, " ")


class OneLineParser(argparse.ArgumentParser):
    """An argument parser whose usage errors are one line on stderr, exit code 2, and whose
    help keeps paths whole (:class:`WholePathsFormatter`), its sub-commands' too."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("formatter_class", WholePathsFormatter)
        super().__init__(*args, **kwargs)

    def error(self, message: str) -> Any:  # argparse's signature says NoReturn
        """Print ``<prog>: error: <message> (see <prog> --help)`` and exit 2.

        Parameters
        ----------
        message : str
            What argparse found wrong.
        """
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def number(
    lo: float, hi: float, *, lo_open: bool = False, hi_open: bool = False, unit: str = ""
) -> Callable[[str], float]:
    """A finite number within ``[lo, hi]`` (ends open where asked).

    Parameters
    ----------
    lo, hi : float
        The range.
    lo_open, hi_open : bool
        Exclude the end itself.
    unit : str
        For the message.
    """
    return _ranged(Bound(lo, hi, lo_open, hi_open), float, "a number", unit)


def integer(lo: int, hi: int) -> Callable[[str], int]:
    """A whole number within ``lo..hi``.

    Parameters
    ----------
    lo, hi : int
        The range.
    """
    return _ranged(Bound(lo, hi, integer=True), int, "a whole number", "")


def _ranged(bound: Bound, convert: Callable[[str], Any], kind: str, unit: str) -> Callable[[str], Any]:
    def parse(text: str) -> Any:
        try:
            value = convert(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be {kind}, got {text!r}") from None
        if not bound.contains(value):
            raise argparse.ArgumentTypeError(f"must be {bound.text()}{' ' + unit if unit else ''}, got {text}")
        return value

    parse.__name__ = kind.split()[-1]  # argparse names the type in its "invalid ... value" message
    return parse


def _wrap(check: Callable[[str, str], str], what: str) -> Callable[[str], str]:
    def parse(text: str) -> str:
        try:
            return check(what, text)
        except ConfigError as exc:
            raise argparse.ArgumentTypeError(str(exc).removeprefix(f"{what} ")) from None

    parse.__name__ = what
    return parse


#: a pymavlink connection string, checked (udpin:/udpout:/tcp:/tcpin:HOST:PORT, or a serial device)
connection = _wrap(check_connection, "connection")
#: a vehicle name: letters, digits, '-', '_'
name = _wrap(check_name, "name")


def param_name(text: str) -> str:
    """A parameter name as MAVLink carries it: 1-16 letters, digits or ``_``.

    Parameters
    ----------
    text : str
        The name given.
    """
    if not re.fullmatch(r"[A-Za-z0-9_]{1,16}", text):
        raise argparse.ArgumentTypeError(f"must be 1-16 letters, digits or '_', got {text!r}")
    return text


def counted(n: int, word: str) -> str:
    """``n`` and ``word``, plural unless ``n`` is 1 ("1 item", "3 items").

    Parameters
    ----------
    n : int
        How many.
    word : str
        The thing counted, singular.
    """
    return f"{n} {word}{'' if n == 1 else 's'}"


#: the containers an annotated video is written in (OpenCV's writer picks one by extension)
VIDEO_SUFFIXES = (".mp4", ".avi", ".mkv", ".mov")


def video_out(text: str) -> Path:
    """A file to write a video to: a known extension, in a folder that exists.

    Parameters
    ----------
    text : str
        The path given.
    """
    path = Path(text)
    if path.is_dir():
        raise argparse.ArgumentTypeError(f"{text} is a folder: give a file ({', '.join(VIDEO_SUFFIXES)})")
    if path.suffix.lower() not in VIDEO_SUFFIXES:
        raise argparse.ArgumentTypeError(f"must end in {', '.join(VIDEO_SUFFIXES)}, got {text!r}")
    if not path.parent.is_dir():
        raise argparse.ArgumentTypeError(f"the folder {str(path.parent)!r} does not exist")
    return path
