"""The `lfctl` command line: one module per command, each parsing its arguments, calling the
library and printing; nothing else. Exit codes: 0 success, 1 the run or check failed, 2 bad
input (usage, scenario, mission, parameter or FMU file), 130 stopped by Ctrl-C (SIGINT), 143
by SIGTERM. Errors print as one line naming the bad input; ``--debug``
shows tracebacks."""

from __future__ import annotations

import argparse
import contextlib
import faulthandler
import importlib
import logging
import os
import signal
import sys
from collections.abc import Sequence

from lfctl import __version__
from lfctl.cli.options import OneLineParser
from lfctl.data import code_identity
from lfctl.errors import ConfigError, FmuError, LfctlError, file_name_encoding_error
from lfctl.logs import guard_log

__all__ = ["build_parser", "main", "quiet_stdout", "stop_exit_code", "stopped_by"]

#: FmuError.call values that mean the FMU file itself is unusable (exit 2, like a bad scenario)
FMU_FILE_CALLS = ("load", "extract")
#: the commands, in the order `lfctl --help` lists them; each is a module here
COMMANDS = ("sim", "sweep", "gcs", "follow", "audit", "replay", "track", "fmu", "bench")


#: the signal that last asked the command to stop (SIGINT: Ctrl-C, or a KeyboardInterrupt of
#: Python's own)
_stop_signal = [int(signal.SIGINT)]


def stopped_by(signum: int) -> None:
    """Note the signal (SIGINT or SIGTERM) that asks the command to stop: its exit code is
    128 + that signal's number, as a shell reports a process the signal ended (130, 143).

    Parameters
    ----------
    signum : int
        The signal's number.
    """
    _stop_signal[0] = signum


def stop_exit_code() -> int:
    """The exit code of a command stopped by a signal: 130 after SIGINT, 143 after SIGTERM."""
    return 128 + _stop_signal[0]


def quiet_stdout() -> None:
    """Send what is still to be written to stdout to /dev/null: its reader has left (a
    pipe's, `lfctl ... | head`), and Python's last flush at exit must not fail on it."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, sys.stdout.fileno())
    os.close(devnull)


class _Version(argparse.Action):
    """``lfctl 0.1.0 (code 9b865979ab12)``: the start of the code's SHA-256 (the simulation's
    Python and C sources, :func:`lfctl.data.code_digest`) tells two builds of one version apart,
    as a log's provenance does; worked out only when asked."""

    def __call__(self, parser: argparse.ArgumentParser, *_: object) -> None:
        code = code_identity()
        print(f"lfctl {__version__} (code {code[:12] if code.isalnum() else code})")
        parser.exit()


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of every command."""
    p = OneLineParser(
        prog="lfctl", description="Vision-guided leader-follower ground robots: co-simulation, tools, benchmarks."
    )
    p.add_argument("--version", action=_Version, nargs=0, help="show the version and the code's digest, and exit")
    p.add_argument("--debug", action="store_true", help="show tracebacks and debug logging")
    p.add_argument("-v", "--verbose", action="store_true", help="log progress messages (INFO)")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in COMMANDS:
        importlib.import_module(f"lfctl.cli.{name}").register(sub)
    _global_options_anywhere(p)
    return p


def _global_options_anywhere(parser: argparse.ArgumentParser) -> None:
    """``--debug`` and ``-v`` after a command too (``lfctl sim convoy --debug``), as well as
    before it: each command's parser, down to the last action, takes them (with no default of
    its own, so one given before the command stands)."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for child in dict.fromkeys(action.choices.values()):  # (an alias maps to the same parser)
                child.add_argument(
                    "--debug", action="store_true", default=argparse.SUPPRESS, help="as before the command"
                )
                child.add_argument(
                    "-v", "--verbose", action="store_true", default=argparse.SUPPRESS, help="as before the command"
                )
                _global_options_anywhere(child)


def _parser_chain(
    parser: argparse.ArgumentParser, args: argparse.Namespace
) -> list[tuple[argparse.ArgumentParser, str | None]]:
    """The parsers ``args`` came through, outermost first, each with the command word that
    chose it (None for the outermost): ``lfctl``, ``lfctl gcs``, ``lfctl gcs upload``."""
    chain: list[tuple[argparse.ArgumentParser, str | None]] = [(parser, None)]
    while True:
        sub = next((a for a in chain[-1][0]._actions if isinstance(a, argparse._SubParsersAction)), None)
        name = getattr(args, sub.dest, None) if sub is not None else None
        if sub is None or name not in sub.choices:
            return chain
        chain.append((sub.choices[name], name))


def _unknown_error(
    parser: argparse.ArgumentParser, args: argparse.Namespace, argv: Sequence[str], unknown: list[str]
) -> None:
    """Say what was not understood, by the parser of the command it was given to (its --help
    lists that command's options); an option of an outer command given after an inner one is
    told where it goes (``lfctl gcs upload m.plan --target 2``)."""
    chain = _parser_chain(parser, args)
    words = list(argv)
    at = words.index(unknown[0]) if unknown[0] in words else len(words)
    owner, place = 0, 0  # the innermost command whose word comes before the stray one
    for i in range(1, len(chain)):
        name = chain[i][1]
        if name is None or name not in words[place:at]:
            break
        place, owner = words.index(name, place) + 1, i
    option = unknown[0].split("=", 1)[0]
    for j in range(owner - 1, -1, -1):
        if option in chain[j][0]._option_string_actions:
            chain[owner][0].error(f"{option} is an option of {chain[j][0].prog}: give it before {chain[j + 1][1]!r}")
    chain[owner][0].error(f"unrecognized arguments: {' '.join(unknown)}")


#: options whose value may start with a minus sign and a digit, as a list: "-10,-5,40,30"
#: (argparse takes a word starting with "-" for an option unless it is one number)
SIGNED_LIST_OPTIONS = ("--roi",)


def _joined_values(words: list[str]) -> list[str]:
    """``--roi -10,-5,40,30`` as ``--roi=-10,-5,40,30``, so that a box partly off the left or
    top edge is taken as the value it is."""
    out: list[str] = []
    it = iter(words)
    for word in it:
        if word in SIGNED_LIST_OPTIONS:
            value = next(it, None)
            if value is not None and len(value) > 1 and value[0] == "-" and (value[1].isdigit() or value[1] == "."):
                out.append(f"{word}={value}")
                continue
            out.append(word)
            if value is not None:
                out.append(value)
            continue
        if word == "--":
            out.append(word)
            out.extend(it)
            break
        out.append(word)
    return out


def main(argv: Sequence[str] | None = None) -> int:
    """Run one command; returns its exit code. A reader of stdout that leaves early (``lfctl
    ... | head``) ends nothing with an error, however early it left: the last output is
    flushed here, where its failure is caught, not by the interpreter as it exits (which
    printed "Exception ignored ... BrokenPipeError" and exited 120).

    Parameters
    ----------
    argv : sequence of str, optional
        The arguments (default ``sys.argv[1:]``).
    """
    try:
        code = _main(argv)
    except SystemExit:  # --help, --version, the command line's errors
        _flush_stdout()
        raise
    except BrokenPipeError:  # (--version printed while stdout is unbuffered)
        quiet_stdout()
        return 0
    _flush_stdout()
    return code


def _flush_stdout() -> None:
    """Flush stdout; a reader that has left is not an error of ours (nor a stdout closed
    before lfctl started, ``lfctl ... >&-``, which Python gives as None)."""
    if sys.stdout is None:
        return
    try:
        sys.stdout.flush()
    except BrokenPipeError:
        quiet_stdout()


def _main(argv: Sequence[str] | None) -> int:
    parser = build_parser()
    words = _joined_values(list(sys.argv[1:] if argv is None else argv))
    args, unknown = parser.parse_known_args(words)
    if unknown:
        _unknown_error(parser, args, words, unknown)
    stopped_by(signal.SIGINT)  # (a command run before in this process may have noted another)
    level = logging.DEBUG if args.debug else (logging.INFO if args.verbose else logging.WARNING)

    # SIGTERM ends a command like Ctrl-C (`lfctl sim` turns both into a stop between steps)
    def _terminate(signum: int, frame: object) -> None:
        stopped_by(signum)
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, _terminate)
    if not faulthandler.is_enabled():
        # a crash in native code (an FMU's doStep, say) prints the Python stack it was under
        # (the FMU's call named in it) instead of ending the process without a word
        with contextlib.suppress(AttributeError, ValueError, OSError):
            faulthandler.enable()
    if not args.debug:
        # OpenCV's and its FFmpeg's own warnings, read as OpenCV starts (a camera index that is
        # not there, a slice FFmpeg complains of and decodes all the same): lfctl says what
        # matters in its own line; --debug, or the variables set by the user, show them
        os.environ.setdefault("OPENCV_LOG_LEVEL", "ERROR")
        os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")
    guard_log(debug=args.debug)
    try:
        return int(args.func(args))
    except KeyboardInterrupt:
        code = stop_exit_code()
        print("lfctl: terminated" if code == 128 + signal.SIGTERM else "lfctl: interrupted", file=sys.stderr)
        return code
    except BrokenPipeError:  # `lfctl ... | head`: the reader left; not an error of ours
        quiet_stdout()
        return 0
    except (ConfigError, FileNotFoundError) as exc:
        if args.debug:
            raise
        print(f"lfctl: error: {exc}", file=sys.stderr)
        return 2
    except FmuError as exc:  # a file the user named that is no FMU lfctl can load is bad input
        if args.debug:
            raise
        print(f"lfctl: error: {exc}", file=sys.stderr)
        return 2 if exc.call in FMU_FILE_CALLS else 1
    except (OSError, LfctlError) as exc:  # a port in use, a directory not writable, an FMU error
        if args.debug:
            raise
        print(f"lfctl: error: {exc}", file=sys.stderr)
        return 1
    except UnicodeError as exc:  # a file name the locale cannot encode (LC_ALL=C, PYTHONUTF8=0)
        if args.debug:
            raise
        print(f"lfctl: error: {file_name_encoding_error(exc)}", file=sys.stderr)
        return 1
    except Exception as exc:  # a bug of ours: still one line, and how to see the rest
        if args.debug:
            raise
        print(
            f"lfctl: internal error: {type(exc).__name__}: {exc} (run with --debug for the traceback; please report it)",
            file=sys.stderr,
        )
        return 1
