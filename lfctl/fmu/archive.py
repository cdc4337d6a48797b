"""FMU archives opened without trusting them, and the folders they are unpacked into.

An FMU is a zip archive from anyone. Before anything is read from it, its end record and
central directory are checked against the limits below; unpacking then streams each member
with its declared size as a hard cap, so a header that lies cannot make lfctl write more
than it agreed to. Anything wrong (not a zip, truncated, a bad CRC, a limit exceeded, a member
that would land outside the folder) is an :class:`~lfctl.errors.FmuError` naming the file.

Each FMU is unpacked into its own folder ``<tmp>/lfctl-<model>-<pid>-<random>/`` (the files
in ``fmu/``), which holds ``owner.lock``, flock-ed for as long as the process lives. Closing
the library removes the folder; a process that was killed (SIGKILL, power loss) cannot, so
loading an FMU first removes the folders of processes that are gone
(:func:`remove_stale_extractions`; docs/architecture.md, "Containing FMUs").

The limits are module constants (tests patch them): :data:`MAX_UNPACKED_BYTES` (512 MiB),
:data:`MAX_MEMBERS` (10,000), :data:`MAX_CENTRAL_DIRECTORY_BYTES` (16 MiB),
:data:`MAX_MODEL_DESCRIPTION_BYTES` (64 MiB) and :data:`MAX_COMPRESSION_RATIO` (200, for
members over 1 MiB). Members must be plain relative paths (no absolute path, ``..``,
backslash or drive), regular files or folders (no symbolic link, device or FIFO), stored or
deflated, unencrypted, each named once.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import io
import logging
import os
import re
import shutil
import stat
import tempfile
import time
import zipfile
from collections.abc import Iterator
from pathlib import Path
from typing import IO

from lfctl.errors import FmuError

__all__ = [
    "MAX_CENTRAL_DIRECTORY_BYTES",
    "MAX_COMPRESSION_RATIO",
    "MAX_MEMBERS",
    "MAX_MODEL_DESCRIPTION_BYTES",
    "MAX_UNPACKED_BYTES",
    "RATIO_CHECK_MIN_BYTES",
    "ExtractionDir",
    "check_archive",
    "extract_archive",
    "pid_alive",
    "read_member",
    "remove_stale_extractions",
]

log = logging.getLogger(__name__)

#: most bytes an FMU may unpack to, all members together (declared, and as actually written)
MAX_UNPACKED_BYTES = 512 * 2**20
#: most members (files and folders) an FMU may hold
MAX_MEMBERS = 10_000
#: largest central directory read (10,000 members with long names fit in far less)
MAX_CENTRAL_DIRECTORY_BYTES = 16 * 2**20
#: largest modelDescription.xml parsed
MAX_MODEL_DESCRIPTION_BYTES = 64 * 2**20
#: most uncompressed bytes per compressed byte of a member larger than RATIO_CHECK_MIN_BYTES
#: (deflate reaches about 1030 only on runs of one byte; libraries and XML stay below 50)
MAX_COMPRESSION_RATIO = 200
#: members at most this large are not ratio-checked (a small file of zeros is harmless)
RATIO_CHECK_MIN_BYTES = 2**20

#: compression methods unpacked (the FMI standard allows stored and deflated)
_METHODS = {zipfile.ZIP_STORED: "stored", zipfile.ZIP_DEFLATED: "deflated"}
_CHUNK = 2**20
#: the folder name made by ExtractionDir: lfctl-<model identifier>-<pid>-<tempfile's 8 chars>
_FOLDER_RE = re.compile(r"lfctl-[A-Za-z_][A-Za-z0-9_]*-(\d+)-[a-z0-9_]{8}")
_LOCK = "owner.lock"
#: a folder without its lock file is left alone this long (it may be being created)
_UNLOCKED_GRACE_S = 60.0


def _mib(n: int) -> str:
    return f"{n / 2**20:.4g} MiB"


def _member_parts(path: Path, name: str) -> tuple[str, ...]:
    """The path components of a member name, or an FmuError saying why it is refused."""
    why = ""
    if not name:
        why = "has an empty name"
    elif name.startswith("/"):
        why = "is an absolute path"
    elif "\\" in name:
        why = "contains a backslash"
    elif ":" in name:
        why = "contains ':' (a drive or device name)"
    elif "\0" in name:
        why = "contains a NUL byte"
    parts = tuple(name[:-1].split("/") if name.endswith("/") else name.split("/"))
    if not why and ".." in parts:
        why = "has a '..' component (it would land outside the FMU's folder)"
    elif not why and any(p in ("", ".") for p in parts):
        why = "has an empty or '.' component"
    if why:
        raise FmuError(f"{path}: member {name!r} {why}; refused", model=str(path), call="extract")
    return parts


def _check_members(path: Path, zf: zipfile.ZipFile) -> list[tuple[zipfile.ZipInfo, tuple[str, ...]]]:
    infos = zf.infolist()
    if len(infos) > MAX_MEMBERS:
        raise FmuError(
            f"{path}: {len(infos)} members, more than the limit of {MAX_MEMBERS}; refused",
            model=str(path),
            call="extract",
        )
    out: list[tuple[zipfile.ZipInfo, tuple[str, ...]]] = []
    seen: set[tuple[str, ...]] = set()
    total = 0
    for info in infos:
        name = info.filename
        parts = _member_parts(path, name)

        def refuse(why: str, name: str = name) -> FmuError:
            return FmuError(f"{path}: member {name!r} {why}; refused", model=str(path), call="extract")

        mode = info.external_attr >> 16 if info.create_system == 3 else 0  # Unix file type and mode
        if stat.S_ISLNK(mode):
            raise refuse("is a symbolic link")
        if stat.S_IFMT(mode) not in (0, stat.S_IFREG, stat.S_IFDIR):
            raise refuse(f"is not a regular file or folder (mode {mode:o})")
        if info.flag_bits & 0x1:
            raise refuse("is encrypted")
        if info.compress_type not in _METHODS:
            raise refuse(f"uses compression method {info.compress_type} (FMUs use stored or deflated)")
        if parts in seen:
            raise refuse("appears twice")
        seen.add(parts)
        if info.is_dir():
            out.append((info, parts))
            continue
        size = info.file_size
        if size > RATIO_CHECK_MIN_BYTES and size > MAX_COMPRESSION_RATIO * max(info.compress_size, 1):
            raise refuse(
                f"unpacks {info.compress_size} bytes to {_mib(size)}, a compression ratio of "
                f"{size / max(info.compress_size, 1):.0f} (limit {MAX_COMPRESSION_RATIO})"
            )
        if parts == ("modelDescription.xml",) and size > MAX_MODEL_DESCRIPTION_BYTES:
            raise refuse(f"is {_mib(size)}, more than the limit of {_mib(MAX_MODEL_DESCRIPTION_BYTES)}")
        total += size
        out.append((info, parts))
    if total > MAX_UNPACKED_BYTES:
        raise FmuError(
            f"{path}: unpacks to {_mib(total)}, more than the limit of {_mib(MAX_UNPACKED_BYTES)}; refused",
            model=str(path),
            call="extract",
        )
    return out


@contextlib.contextmanager
def _checked_zip(path: Path) -> Iterator[tuple[zipfile.ZipFile, list[tuple[zipfile.ZipInfo, tuple[str, ...]]]]]:
    """The archive open, its members checked: (zip, [(member, path components)])."""
    try:
        f = path.open("rb")
    except FileNotFoundError as exc:
        raise FmuError(f"FMU file {path} does not exist", model=str(path), call="load") from exc
    except OSError as exc:
        raise FmuError(f"cannot open FMU {path}: {exc.strerror or exc}", model=str(path), call="load") from exc
    with f:
        # The end record says how many members and how large a central directory ZipFile
        # would read into memory: refuse an absurd one before it does (ZipFile's own reader).
        end_record = getattr(zipfile, "_EndRecData", None)
        try:
            end = end_record(f) if end_record is not None else ()
            if end is None:
                raise zipfile.BadZipFile("no end-of-central-directory record")
            if end:
                entries, size = end[zipfile._ECD_ENTRIES_TOTAL], end[zipfile._ECD_SIZE]  # type: ignore[attr-defined]
                if entries > MAX_MEMBERS:
                    raise FmuError(
                        f"{path}: {entries} members, more than the limit of {MAX_MEMBERS}; refused",
                        model=str(path),
                        call="extract",
                    )
                if size > MAX_CENTRAL_DIRECTORY_BYTES:
                    raise FmuError(
                        f"{path}: a central directory of {_mib(size)}, more than the limit of "
                        f"{_mib(MAX_CENTRAL_DIRECTORY_BYTES)}; refused",
                        model=str(path),
                        call="extract",
                    )
            f.seek(0)
            zf = zipfile.ZipFile(f)
        except FmuError:
            raise
        except Exception as exc:  # BadZipFile mostly; whatever a damaged directory raises
            raise FmuError(
                f"{path} is not an FMU: not a readable zip archive ({exc})", model=str(path), call="load"
            ) from exc
        with zf:
            yield zf, _check_members(path, zf)


def check_archive(path: str | Path) -> list[zipfile.ZipInfo]:
    """Check an FMU archive against the limits without unpacking it; its members.

    Parameters
    ----------
    path : str or Path
        The FMU file.

    Raises
    ------
    FmuError
        Not a readable zip, or a limit exceeded, or a member refused (the message says which).
    """
    with _checked_zip(Path(path)) as (_zf, members):
        return [info for info, _parts in members]


def read_member(path: str | Path, name: str) -> bytes:
    """One member of a checked FMU archive, read whole and CRC-checked (at most its declared size).

    Parameters
    ----------
    path : str or Path
        The FMU file.
    name : str
        The member, e.g. ``"modelDescription.xml"``.

    Raises
    ------
    FmuError
        As :func:`check_archive`, or no such member, or it is corrupt.
    """
    path = Path(path)
    with _checked_zip(path) as (zf, members):
        info = next((i for i, _parts in members if i.filename == name), None)
        if info is None:
            raise FmuError(f"{path} is not an FMU: it has no {name}", model=str(path), call="load")
        out = io.BytesIO()
        try:
            with zf.open(info) as src:
                n = _copy_capped(src, out, info.file_size)
        except Exception as exc:
            raise FmuError(f"{path}: cannot read member {name!r}: {exc}", model=str(path), call="load") from exc
        if n != info.file_size:
            raise FmuError(f"{path}: member {name!r} is not the size its header declares", model=str(path), call="load")
        return out.getvalue()


def _copy_capped(src: IO[bytes], dst: IO[bytes], cap: int) -> int:
    """Copy at most ``cap`` bytes; -1 when the source holds more."""
    n = 0
    while True:
        chunk = src.read(min(_CHUNK, cap - n + 1))
        if not chunk:
            return n
        n += len(chunk)
        if n > cap:
            return -1
        dst.write(chunk)


def extract_archive(path: str | Path, dest: str | Path) -> int:
    """Unpack a checked FMU archive into the empty folder ``dest``; the bytes written.

    Each member is streamed with its declared size as a cap (never more than
    :data:`MAX_UNPACKED_BYTES` in all) and must come out at exactly that size with its CRC.

    Parameters
    ----------
    path : str or Path
        The FMU file.
    dest : str or Path
        An existing, empty folder.

    Raises
    ------
    FmuError
        As :func:`check_archive`, or a member is corrupt (bad CRC, truncated, more bytes than
        declared), or the disk refused (full, a name too long).
    """
    path, dest = Path(path), Path(dest)
    written = 0
    with _checked_zip(path) as (zf, members):
        for info, parts in members:
            target = dest.joinpath(*parts)
            try:
                if info.is_dir():
                    target.mkdir(parents=True, exist_ok=True)
                    continue
                target.parent.mkdir(parents=True, exist_ok=True)
                with zf.open(info) as src, target.open("xb") as dst:
                    n = _copy_capped(src, dst, info.file_size)
            except FmuError:
                raise
            except Exception as exc:  # a corrupt member: zipfile, zlib, EOF, disk errors
                why = exc.strerror if isinstance(exc, OSError) and exc.strerror else exc
                raise FmuError(
                    f"{path}: cannot extract member {info.filename!r}: {why}", model=str(path), call="extract"
                ) from exc
            if n != info.file_size:
                what = "more bytes than" if n < 0 else f"{n} bytes, not"
                raise FmuError(
                    f"{path}: member {info.filename!r} unpacks to {what} the {info.file_size} its header declares; refused",
                    model=str(path),
                    call="extract",
                )
            written += n
    return written


class ExtractionDir:
    """A private folder an FMU is unpacked into, marked as this process's while it lives.

    ``<tmp>/lfctl-<identifier>-<pid>-<random>/``: the FMU's files in :attr:`files`, and
    ``owner.lock``, which this process holds an exclusive flock on until :meth:`remove`
    (the kernel drops it when the process dies, however it dies).

    Parameters
    ----------
    identifier : str
        The FMU's model identifier (a C identifier: it is part of the folder's name).
    tmpdir : str or Path, optional
        Where to make it (default: :func:`tempfile.gettempdir`).
    """

    def __init__(self, identifier: str, tmpdir: str | Path | None = None) -> None:
        if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", identifier):
            raise ValueError(f"model identifier {identifier!r} is not a C identifier")
        self.root = Path(tempfile.mkdtemp(prefix=f"lfctl-{identifier}-{os.getpid()}-", dir=tmpdir))
        self._lock_fd: int | None = None
        try:
            self._lock_fd = os.open(self.root / _LOCK, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_CLOEXEC, 0o600)
            fcntl.flock(self._lock_fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            self.files = self.root / "fmu"
            self.files.mkdir()
        except BaseException:
            self.remove()
            raise

    def remove(self) -> None:
        """Remove the folder and let go of it; safe to call twice."""
        shutil.rmtree(self.root, ignore_errors=True)
        if self._lock_fd is not None:
            os.close(self._lock_fd)
            self._lock_fd = None


def pid_alive(pid: int) -> bool:
    """A process ``pid`` exists (this user's or another's).

    Parameters
    ----------
    pid : int
        The process id.
    """
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process
        return True
    return True


def remove_stale_extractions(tmpdir: str | Path | None = None) -> list[Path]:
    """Remove the extraction folders of lfctl processes that are gone; the folders removed.

    A folder ``lfctl-<model>-<pid>-<random>`` in ``tmpdir`` is removed when it belongs to
    this user, its process ``pid`` no longer exists, and nobody holds its ``owner.lock``
    (the lock guards against a live owner in another PID namespace sharing the folder; a
    folder without a lock file is left alone for its first minute, while it may be being
    made). Anything else, another user's folder or a live process's, is left alone.

    Parameters
    ----------
    tmpdir : str or Path, optional
        Where to look (default: :func:`tempfile.gettempdir`).
    """
    where = Path(tmpdir if tmpdir is not None else tempfile.gettempdir())
    removed: list[Path] = []
    try:
        entries = list(os.scandir(where))
    except OSError:
        return removed
    uid = os.getuid()
    for entry in entries:
        m = _FOLDER_RE.fullmatch(entry.name)
        if m is None:
            continue
        pid = int(m.group(1))
        try:
            st = entry.stat(follow_symlinks=False)
        except OSError:
            continue
        if not stat.S_ISDIR(st.st_mode) or st.st_uid != uid or pid == os.getpid() or pid_alive(pid):
            continue
        folder = Path(entry.path)
        try:
            fd = os.open(folder / _LOCK, os.O_RDONLY | os.O_NOFOLLOW | os.O_CLOEXEC)
        except OSError as exc:
            if exc.errno == errno.ENOENT and time.time() - st.st_mtime > _UNLOCKED_GRACE_S:
                shutil.rmtree(folder, ignore_errors=True)
                removed.append(folder)
            continue
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:  # its owner lives (in another PID namespace)
            os.close(fd)
            continue
        try:
            shutil.rmtree(folder, ignore_errors=True)
        finally:
            os.close(fd)
        removed.append(folder)
        log.info("removed %s, left behind by process %d, which is gone", folder, pid)
    return removed
