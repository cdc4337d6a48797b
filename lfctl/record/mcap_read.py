"""Reading an MCAP log for `lfctl audit`, bounded in memory and time whatever the file holds.

The reader parses the record framing itself (opcode u8, length u64, body) from a regular
file, so that every declared size is checked against the file and against the limits below
*before* anything is allocated, and so that each fault is reported at the byte offset of
the record it is in. Chunks are inflated with an output cap (zstd, lz4); their CRC, the
data section's CRC and the summary's CRC are checked. In a complete file (one that ends
with MCAP's magic) a CRC mismatch caused by one flipped bit is located with CRC-32's
linearity: the finding names the record holding that bit.

A fault in the framing stops the reading (what was read before it is kept, for
``lfctl audit --recover``); a chunk that does not inflate or fails its CRC is skipped and
the reading goes on. A file cut short is called *truncated* only when it really ends inside
a record; damage inside a complete file is *corrupt* or a *CRC mismatch*.

A writer puts each Schema and Channel record in the data section once, in the first chunk
that uses it, and repeats them all in the summary. So messages on a channel not defined yet
are kept (as any message is, within the limits below) until a definition turns up, from a
later record or from the summary: a damaged chunk that held definitions loses only its own
messages when the file has its summary. Messages on a channel defined nowhere are dropped
at the end (an error).

Limits (module constants, the defaults of :class:`ReadLimits`; a finding names the one a
file hit):

``MAX_RECORD_BYTES`` (64 MiB)
    the body of one record (a compressed chunk, an attachment, a metadata record);
``MAX_CHUNK_BYTES`` (64 MiB)
    the records of one chunk, uncompressed (declared and actually inflated);
``MAX_MESSAGES`` (2,000,000)
    messages read; past it the audit stops reading;
``MAX_MESSAGE_BYTES`` (1 GiB)
    uncompressed chunk data kept in memory; past it messages are counted and checked, but
    their payloads are not kept (figures and ``--recover`` cover the part kept);
``MAX_OTHER_BYTES`` (256 MiB)
    attachments, metadata, schemas and channels kept; past it the audit stops reading;
``MAX_RECORDS`` (10,000,000)
    records of any kind (inside chunks too); past it the audit stops reading.
"""

from __future__ import annotations

import math
import os
import stat
import struct
import zlib
from array import array
from bisect import bisect_left, bisect_right
from collections import defaultdict
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, overload

from mcap.records import Channel, Schema, Statistics

__all__ = [
    "MAGIC",
    "MAX_CHUNK_BYTES",
    "MAX_MESSAGES",
    "MAX_MESSAGE_BYTES",
    "MAX_OTHER_BYTES",
    "MAX_RECORDS",
    "MAX_RECORD_BYTES",
    "Contents",
    "Finding",
    "MessageStore",
    "ReadLimits",
    "locate_flip",
    "read_contents",
    "regular_file_problem",
]

KiB = 1 << 10
MiB = 1 << 20
#: the largest record body read into memory, bytes
MAX_RECORD_BYTES = 64 * MiB
#: the largest chunk, uncompressed (declared, and as inflated), bytes
MAX_CHUNK_BYTES = 64 * MiB
#: messages read before the audit stops
MAX_MESSAGES = 2_000_000
#: uncompressed chunk data kept for the figures and recovery, bytes (then only counted)
MAX_MESSAGE_BYTES = 1024 * MiB
#: attachments, metadata, schemas and channels kept, bytes
MAX_OTHER_BYTES = 256 * MiB
#: records of any kind read before the audit stops
MAX_RECORDS = 10_000_000
#: damaged records passed over (their framing intact), and resumptions at a chunk the
#: summary's index names, before the audit stops: each is a finding, and a resumption reads the
#: data section again to locate a flipped bit; a file made of damage gets this many, not millions
MAX_PASSED_OVER = 64

MAGIC = b"\x89MCAP0\r\n"
KNOWN_SIGNATURES = {
    b"\x89PNG": "a PNG image",
    b"\xff\xd8\xff": "a JPEG image",
    b"PK\x03\x04": "a zip archive",
    b"%PDF": "a PDF",
    b"\x7fELF": "an ELF binary",
}

HEADER, FOOTER, SCHEMA, CHANNEL, MESSAGE, CHUNK, MESSAGE_INDEX, CHUNK_INDEX = 1, 2, 3, 4, 5, 6, 7, 8
ATTACHMENT, ATTACHMENT_INDEX, STATISTICS, METADATA, METADATA_INDEX, SUMMARY_OFFSET, DATA_END = range(9, 16)
KINDS = {
    HEADER: "Header",
    FOOTER: "Footer",
    SCHEMA: "Schema",
    CHANNEL: "Channel",
    MESSAGE: "Message",
    CHUNK: "Chunk",
    MESSAGE_INDEX: "MessageIndex",
    CHUNK_INDEX: "ChunkIndex",
    ATTACHMENT: "Attachment",
    ATTACHMENT_INDEX: "AttachmentIndex",
    STATISTICS: "Statistics",
    METADATA: "Metadata",
    METADATA_INDEX: "MetadataIndex",
    SUMMARY_OFFSET: "SummaryOffset",
    DATA_END: "DataEnd",
}
#: records that belong in the data section (not after DataEnd)
DATA_ONLY = {HEADER, MESSAGE, CHUNK, MESSAGE_INDEX, ATTACHMENT, METADATA}
FOOTER_BYTES = 9 + 20  # opcode, length, summary_start, summary_offset_start, summary_crc
DATA_END_BYTES = 9 + 4

_RECORD = struct.Struct("<BQ")
UNFINISHED = (1 << 64) - 1  # the length a streaming writer puts in a Chunk until it is finished
_U32 = "I" if array("I").itemsize >= 4 else "L"  # 4 bytes where it can (32 bytes a message kept)
_MESSAGE = struct.Struct("<HIQQ")  # channel id, sequence, log time, publish time


def _a(word: str) -> str:
    """``word`` with its indefinite article."""
    return f"{'an' if word[:1].lower() in 'aeiou' else 'a'} {word}"


def _count(n: int, word: str) -> str:
    """``1 channel`` / ``2 channels``."""
    return f"{n} {word}{'' if n == 1 else 's'}"


def _refer(topics: list[str], schema_id: int) -> str:
    """``channel '/a' refers to schema 3`` (``channels '/a' and 2 more refer ...``)."""
    if len(topics) == 1:
        return f"channel {topics[0]!r} refers to schema {schema_id}"
    return f"channels {topics[0]!r} and {len(topics) - 1} more refer to schema {schema_id}"


def _size(n: int) -> str:
    """``64 MiB`` / ``123 bytes``: a size for a person."""
    if n >= MiB and n % MiB == 0:
        return f"{n // MiB} MiB"
    return f"{n} bytes"


@dataclass(frozen=True)
class ReadLimits:
    """What :func:`read_contents` refuses to read or keep (defaults: the module constants)."""

    record_bytes: int = MAX_RECORD_BYTES  # largest record body, bytes (MAX_RECORD_BYTES)
    chunk_bytes: int = MAX_CHUNK_BYTES  # largest uncompressed chunk, bytes (MAX_CHUNK_BYTES)
    messages: int = MAX_MESSAGES  # messages read before stopping (MAX_MESSAGES)
    message_bytes: int = MAX_MESSAGE_BYTES  # chunk data kept, bytes (MAX_MESSAGE_BYTES)
    other_bytes: int = MAX_OTHER_BYTES  # attachments, metadata, schemas, channels kept (MAX_OTHER_BYTES)
    records: int = MAX_RECORDS  # records read before stopping (MAX_RECORDS)
    passed_over: int = MAX_PASSED_OVER  # damaged records passed over, and resumptions (MAX_PASSED_OVER)


@dataclass
class Finding:
    """One problem: ``error`` fails the audit, ``warning`` is reported."""

    level: str  # "error" or "warning"
    what: str  # what is wrong, for a person
    offset: int | None = None  # byte offset in the file of the record it is in (None: not at one place)
    #: what sort of problem: "truncated", "corrupt", "crc", "limit", "file", "content",
    #: "provenance", "run" or "" (see docs/audit.md)
    kind: str = ""

    def line(self) -> str:
        """The finding as one report line: ``ERROR: what (byte N)``."""
        at = f" (byte {self.offset})" if self.offset is not None else ""
        return f"{self.level.upper()}: {self.what}{at}"


class MessageStore(Sequence[tuple[int, bytes]]):
    """The messages kept of one channel, in file order: a sequence of ``(log_time_ns,
    payload)``, stored as compact arrays over the inflated chunks (no object per message).

    Parameters
    ----------
    blocks : list of bytes
        The inflated chunks the payloads are slices of (shared by every channel's store).
    offsets : list of int
        The file offset of the record each block came from (a chunk, or a message).
    """

    def __init__(self, blocks: list[bytes], offsets: list[int]) -> None:
        self._blocks = blocks
        self._offsets = offsets
        self.log_times = array("Q")  # log time of each message, ns
        self.publish_times = array("Q")  # publish time of each message, ns
        self.sequences = array(_U32)  # sequence number of each message
        self._block = array(_U32)
        self._start = array(_U32)
        self._size = array(_U32)

    def append(self, log_time: int, publish_time: int, sequence: int, block: int, start: int, size: int) -> None:
        """Keep one message: its times, sequence and where its payload lies.

        Parameters
        ----------
        log_time, publish_time : int
            Its times, ns.
        sequence : int
            Its sequence number.
        block : int
            Index of the block (inflated chunk) holding its payload.
        start, size : int
            Where in the block the payload starts, and its length, bytes.
        """
        self.log_times.append(log_time)
        self.publish_times.append(publish_time)
        self.sequences.append(sequence)
        self._block.append(block)
        self._start.append(start)
        self._size.append(size)

    def __len__(self) -> int:
        return len(self.log_times)

    def payload(self, i: int) -> bytes:
        """The payload of message ``i``.

        Parameters
        ----------
        i : int
            Its index in this store.
        """
        s = self._start[i]
        return bytes(self._blocks[self._block[i]][s : s + self._size[i]])

    def offset(self, i: int) -> int:
        """The file offset of the record holding message ``i`` (its chunk, or itself).

        Parameters
        ----------
        i : int
            Its index in this store.
        """
        return self._offsets[self._block[i]]

    @overload
    def __getitem__(self, i: int) -> tuple[int, bytes]: ...

    @overload
    def __getitem__(self, i: slice) -> list[tuple[int, bytes]]: ...

    def __getitem__(self, i: int | slice) -> tuple[int, bytes] | list[tuple[int, bytes]]:
        if isinstance(i, slice):
            return [self[k] for k in range(*i.indices(len(self)))]
        if i < 0:
            i += len(self)
        if not 0 <= i < len(self):
            raise IndexError(i)
        return self.log_times[i], self.payload(i)

    def __iter__(self) -> Iterator[tuple[int, bytes]]:
        for i in range(len(self)):
            yield self.log_times[i], self.payload(i)


class _TopicView(Sequence[tuple[int, bytes]]):
    """The messages of several channels that share a topic, by log time."""

    def __init__(self, stores: list[MessageStore]) -> None:
        keyed = [(s.log_times[i], k, i) for k, s in enumerate(stores) for i in range(len(s))]
        keyed.sort()
        self._stores = stores
        self._order = [(k, i) for _, k, i in keyed]

    def __len__(self) -> int:
        return len(self._order)

    def __getitem__(self, j: Any) -> Any:
        if isinstance(j, slice):
            return [self[k] for k in range(*j.indices(len(self)))]
        k, i = self._order[j]
        return self._stores[k][i]

    def offset(self, j: int) -> int:
        """The file offset of the record holding message ``j``."""
        k, i = self._order[j]
        return self._stores[k].offset(i)


@dataclass
class Contents:
    """Everything read from the file, up to a fault if there was one."""

    header_library: str = ""  # the header's library field (who wrote the file)
    schemas: dict[int, Schema] = field(default_factory=dict)  # by schema id
    channels: dict[int, Channel] = field(default_factory=dict)  # by channel id
    #: topic -> (log_time in ns, payload) of every message kept, in file order (channels
    #: that share a topic: by log time); a view of ``by_channel``
    messages: dict[str, Sequence[tuple[int, bytes]]] = field(default_factory=lambda: defaultdict(list))
    #: channel id -> the messages kept of that channel (each message once)
    by_channel: dict[int, MessageStore] = field(default_factory=dict)
    #: channel id -> messages read on it (kept or not: see MAX_MESSAGE_BYTES)
    counts: dict[int, int] = field(default_factory=dict)
    metadata: dict[str, dict[str, str]] = field(default_factory=dict)  # by metadata record name
    attachments: dict[str, bytes] = field(default_factory=dict)  # by attachment name
    attachment_types: dict[str, str] = field(default_factory=dict)  # media type, by attachment name
    attachment_times: dict[str, tuple[int, int]] = field(default_factory=dict)  # (log, create) time, ns, by name
    statistics: Statistics | None = None  # the summary's statistics record (None: not reached)
    footer: bool = False  # the footer was read: the file is complete
    data_end: bool = False  # the data section's end record was read
    complete: bool = False  # the file ends with MCAP's magic (it was finished, maybe damaged since)
    bytes_read: int = 0  # bytes read intact, up to the first fault that stopped the reading
    file_size: int = 0  # the file's size, bytes
    payloads_dropped: int = 0  # messages counted whose payloads were not kept (MAX_MESSAGE_BYTES)
    #: decoded JSON topics, filled by the audit on first use (topic -> good and bad messages)
    decoded: dict[str, Any] = field(default_factory=dict, init=False, repr=False, compare=False)

    @property
    def start_ns(self) -> int:
        """The run's start on the epoch clock, ns (metadata ``run.start_time_ns``); 0 for a
        log whose times are the simulation time itself, or whose value is not a time."""
        text = self.metadata.get("run", {}).get("start_time_ns", "0")
        return int(text) if isinstance(text, str) and text.isdigit() and len(text) <= 19 else 0

    def sim_s(self, log_time_ns: int) -> float:
        """A log time as simulation time, s.

        Parameters
        ----------
        log_time_ns : int
            A message's ``log_time``, ns.
        """
        return (log_time_ns - self.start_ns) / 1e9


class _Bad(Exception):
    """A record's content does not parse (becomes a finding at the record's offset)."""


class _Fault(Exception):
    """Reading cannot go on (or, with ``skip``, goes on after this record)."""

    def __init__(self, kind: str, what: str, offset: int, skip: bool = False) -> None:
        super().__init__(what)
        self.kind, self.what, self.offset, self.skip = kind, what, offset, skip


class _Cursor:
    """Bounded little-endian reads from a record body; running past it raises _Bad."""

    __slots__ = ("buf", "end", "pos", "what")

    def __init__(self, buf: bytes | memoryview, what: str, pos: int = 0, end: int | None = None) -> None:
        self.buf, self.what, self.pos = buf, what, pos
        self.end = len(buf) if end is None else end

    def take(self, n: int, name: str) -> int:
        if n > self.end - self.pos:
            raise _Bad(f"{self.what}: {name} needs {n} bytes, {self.end - self.pos} are left in the record")
        p = self.pos
        self.pos += n
        return p

    def u8(self, name: str) -> int:
        return self.buf[self.take(1, name)]

    def u16(self, name: str) -> int:
        return int.from_bytes(self.buf[self.take(2, name) : self.pos], "little")

    def u32(self, name: str) -> int:
        return int.from_bytes(self.buf[self.take(4, name) : self.pos], "little")

    def u64(self, name: str) -> int:
        return int.from_bytes(self.buf[self.take(8, name) : self.pos], "little")

    def raw(self, n: int, name: str) -> bytes:
        p = self.take(n, name)
        return bytes(self.buf[p : self.pos])

    def string(self, name: str) -> str:
        data = self.raw(self.u32(f"{name} length"), name)
        try:
            return data.decode("utf-8")
        except UnicodeDecodeError as exc:
            raise _Bad(f"{self.what}: {name} is not UTF-8 ({exc.reason} at byte {exc.start})") from None

    def sub(self, name: str) -> _Cursor:
        """The next u32-length-prefixed field as a cursor of its own."""
        n = self.u32(f"{name} length")
        p = self.take(n, name)
        return _Cursor(self.buf, f"{self.what} {name}", p, self.pos)

    def str_map(self, name: str) -> dict[str, str]:
        sub, out = self.sub(name), {}
        while sub.pos < sub.end:
            key = sub.string("key")
            out[key] = sub.string(f"value of {key!r}")
        return out

    def u16_u64_map(self, name: str) -> dict[int, int]:
        sub, out = self.sub(name), {}
        while sub.pos < sub.end:
            key = sub.u16("key")
            out[key] = sub.u64("value")
        return out


# -- locating a flipped bit with CRC-32's linearity -------------------------------------------
_POLY = 0xEDB88320  # CRC-32 (reflected); x^0 is bit 31
_ONE = 0x80000000


def _mulx(r: int) -> int:
    return (r >> 1) ^ (_POLY if r & 1 else 0)


def _mul(a: int, b: int) -> int:
    r = 0
    for i in range(32):
        if b & (_ONE >> i):
            r ^= a
        a = _mulx(a)
    return r


def _xpow(e: int) -> int:
    r, base = _ONE, _mulx(_ONE)
    while e:
        if e & 1:
            r = _mul(r, base)
        base = _mul(base, base)
        e >>= 1
    return r


#: the largest span in which a flipped bit is looked for, bytes (about 0.3 s at the most)
LOCATE_MAX_BYTES = 1 << 30


def locate_flip(stored: int, computed: int, length: int) -> tuple[int, int] | None:
    """Where one flipped bit would turn CRC-32 ``stored`` into ``computed`` over ``length``
    bytes: ``(byte, bit)``, or None when no single bit does (more damage than one bit).

    A bit flipped at byte ``p``, bit ``b`` changes the CRC by ``x^e mod P`` with
    ``e = 8 (length - p) + 31 - b`` (CRC-32 is linear; its polynomial is primitive, so
    ``e`` is unique below 2^32 - 1); ``e`` is found by baby-step giant-step.

    Parameters
    ----------
    stored, computed : int
        The CRC the file says and the CRC of the bytes as they are.
    length : int
        The bytes the CRC covers.
    """
    syndrome = stored ^ computed
    if not syndrome or not 0 < length <= LOCATE_MAX_BYTES:
        return None
    n = 8 * length + 32
    m = math.isqrt(n) + 1
    baby: dict[int, int] = {}
    cur = syndrome
    for j in range(m):
        baby.setdefault(cur, j)
        cur = _mulx(cur)
    step = _xpow(m)
    cur = step
    for i in range(1, n // m + 2):
        j = baby.get(cur)
        if j is not None:
            e = i * m - j
            bit = (31 - e) % 8
            back = (e - 31 + bit) // 8
            return (length - back, bit) if 1 <= back <= length else None
        cur = _mul(cur, step)
    return None


# -- the reader ---------------------------------------------------------------------------------
def _file_kind(mode: int) -> str:
    for test, name in (
        (stat.S_ISDIR, "a directory"),
        (stat.S_ISFIFO, "a FIFO (named pipe)"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
        (stat.S_ISSOCK, "a socket"),
    ):
        if test(mode):
            return name
    return "not a regular file"


def regular_file_problem(path: str | Path) -> str | None:
    """Why ``path`` cannot be audited (missing, not a regular file), or None when it can.

    Parameters
    ----------
    path : str or Path
        The file.
    """
    try:
        st = os.stat(path)
    except OSError as exc:
        return f"cannot read {path}: {exc.strerror or exc}"
    if not stat.S_ISREG(st.st_mode):
        return f"{path} is {_file_kind(st.st_mode)}, not a regular file"
    return None


def read_contents(path: str | Path, limits: ReadLimits | None = None) -> tuple[Contents, list[Finding]]:
    """Read every record of an MCAP file within ``limits``; say where each fault is.

    Never raises for a bad file: a path that is not a regular file (a FIFO, a directory, a
    device) is refused before it is opened; everything else the file holds becomes
    findings.

    Parameters
    ----------
    path : str or Path
        The file.
    limits : ReadLimits, optional
        What to refuse (default the module constants).
    """
    c = Contents()
    problem = regular_file_problem(path)
    if problem:
        return c, [Finding("error", problem, kind="file")]
    try:  # O_NONBLOCK: should the path have become a FIFO since, opening it cannot block
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0))
    except OSError as exc:
        return c, [Finding("error", f"cannot read {path}: {exc.strerror or exc}", kind="file")]
    with open(fd, "rb") as f:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            return c, [Finding("error", f"{path} is {_file_kind(st.st_mode)}, not a regular file", kind="file")]
        c.file_size = st.st_size
        findings: list[Finding] = []
        _Reader(f, c, findings, limits or ReadLimits()).run()
    return c, findings


class _Reader:
    def __init__(self, f: Any, c: Contents, findings: list[Finding], limits: ReadLimits) -> None:
        self.f, self.c, self.findings, self.lim = f, c, findings, limits
        self.size = c.file_size
        self.pos = 0
        self.records = 0
        self.messages = 0
        self.kept_bytes = 0
        self.other_bytes = 0
        self.blocks: list[bytes] = []
        self.block_offsets: list[int] = []
        self.starts = array("Q")  # top-level record offsets, for locating a flipped bit
        self.kinds = array("B")  # and their opcodes
        self.data_crc = zlib.crc32(MAGIC)
        self.summary_start: int | None = None  # where the summary section began (after DataEnd)
        self.summary_crc = 0
        self.summary_offset_start = 0
        self.seen_header = False
        self.last_time: dict[int, int] = {}
        #: (kind of anomaly, channel id) -> [count, first offset, first detail]
        self.anomalies: dict[tuple[str, int], list[Any]] = {}
        #: the offset of the last chunk skipped (damaged, or past a limit): definitions in it are lost
        self.skipped_chunk: int | None = None
        #: channel id -> [messages read before its definition, the first one's offset, the
        #: chunk skipped before it or None]: kept in ``by_channel`` until a definition turns up
        self.held: dict[int, list[Any]] = {}
        #: schema id -> [topics of the channels defined before it, the first one's offset,
        #: the chunk skipped before it or None]
        self.orphans: dict[int, list[Any]] = {}
        #: skipped chunk's offset -> [channels, schemas] whose lost definitions the summary gave
        self.restored: dict[int, list[int]] = {}
        #: a complete file's ChunkIndex (chunk start -> its record's body length), read when a
        #: damaged record stops the reading (see :meth:`resync`); None until then
        self.chunk_index: dict[int, int] | None = None
        self.resumed: set[int] = set()  # where reading went on after a damaged record
        self.passed_over = 0  # damaged records passed over, and resumptions (MAX_PASSED_OVER)
        self.index_starts: list[int] = []  # the index's chunk starts, in order
        self.forced: dict[int, int] = {}  # chunk start -> body length, the index's over a damaged header

    # -- bytes --------------------------------------------------------------------------------
    def read(self, n: int, start: int) -> bytes:
        data = self.f.read(n)
        if len(data) != n:  # the file shrank while being read
            raise _Fault("truncated", f"the file ended while being read (at byte {self.pos + len(data)})", start)
        self.pos += n
        return data

    def fail(self, start: int, what: str, kind: str = "corrupt", skip: bool = False) -> _Fault:
        return _Fault(kind, what, start, skip)

    def past_end(self, start: int, kind: str, declared: int) -> _Fault:
        """A record that runs past the end of the file: the file is cut short, or the length is
        damaged (in a file that ends with MCAP's magic)."""
        have = self.size - start
        if kind == "closing magic":
            return self.fail(
                start, f"truncated: the file ends inside the closing magic ({have} of 8 bytes)", "truncated"
            )
        have -= 9  # past the record's opcode and length
        if self.c.complete:
            return self.fail(
                start, f"corrupt {kind} record: it declares {declared} bytes, the file ends {have} bytes on"
            )
        return self.fail(
            start,
            f"truncated: the file ends inside {_a(kind)} record ({declared} bytes declared, {have} present; "
            f"file {self.size} bytes)",
            "truncated",
        )

    # -- the record loop ----------------------------------------------------------------------
    def run(self) -> None:
        c = self.c
        head = self.f.read(8)
        self.pos = len(head)
        c.complete = self.size >= 16 + 9 + FOOTER_BYTES and self._tail_is_magic()
        if head != MAGIC:
            kind = next((name for sig, name in KNOWN_SIGNATURES.items() if head.startswith(sig)), None)
            what = f"not an MCAP file: bad magic {head[:8]!r}" + (f" (looks like {kind})" if kind else "")
            if len(head) == 8 and bin(int.from_bytes(head, "big") ^ int.from_bytes(MAGIC, "big")).count("1") <= 2:
                what = f"corrupt: the opening magic is damaged ({head!r}, MCAP's is {MAGIC!r})"
            elif not head:
                what = "not an MCAP file: the file is empty"
            elif len(head) < 8 and MAGIC.startswith(head):
                what = f"truncated: the file ends inside the opening magic ({len(head)} bytes)"
            self.findings.append(Finding("error", what, 0, "truncated" if what.startswith("truncated") else "corrupt"))
            return
        fault: _Fault | None = None
        while not c.footer:
            start = self.pos
            try:
                self.step(start)
            except _Fault as exc:
                self.findings.append(Finding("error", exc.what, exc.offset, exc.kind))
                if exc.skip or (exc.kind == "corrupt" and self.resync(exc)):
                    continue
                fault = exc
                break
        c.bytes_read = self.pos if fault is None else fault.offset
        self.finish(fault)

    def resync(self, fault: _Fault) -> bool:
        """Go on reading after a damaged record of a complete file's data section, at the
        first Chunk its summary's ChunkIndex (its CRC checked) puts there or after it: the
        index's length where the damage is in that chunk's own header, the bytes between
        passed over (their definitions are the summary's too). Whether there is one."""
        if self.passed_over >= self.lim.passed_over:
            self.findings.append(
                Finding(
                    "error",
                    f"{self.passed_over} damaged records were passed over, or resumed after, before this one "
                    f"(MAX_PASSED_OVER = {self.lim.passed_over}): the audit stops here",
                    fault.offset,
                    "limit",
                )
            )
            return False
        if not self.c.complete or self.summary_start is not None:
            return False
        if self.chunk_index is None:
            self.chunk_index = self.read_chunk_index()
            self.index_starts = sorted(self.chunk_index)
        i = bisect_left(self.index_starts, fault.offset)
        while i < len(self.index_starts) and self.index_starts[i] in self.resumed:
            i += 1  # (resumed there already: the damage is in that chunk itself)
        if i >= len(self.index_starts):
            return False
        if not self.resumed:
            self.explain(fault)  # (a flipped bit the data CRC locates: said at the first; not checked after)
        at = self.index_starts[i]
        self.resumed.add(at)
        self.passed_over += 1
        if at == fault.offset:
            self.forced[at] = self.chunk_index[at]
            where = f"this Chunk again, with the length the summary's index gives it ({self.chunk_index[at]} bytes)"
        else:
            where = f"byte {at}, the next Chunk the summary's index names (bytes {fault.offset}-{at} passed over)"
        self.findings.append(Finding("warning", f"reading went on at {where}", fault.offset, "corrupt"))
        self.seen_header = True  # (a damaged Header was there)
        self.f.seek(at)
        self.pos = at
        return True

    def read_footer(self) -> tuple[bytes, int, int] | None:
        """A complete file's Footer record, where it must be: its bytes, summary_start and
        summary_crc; None where no Footer is."""
        self.f.seek(self.size - 8 - FOOTER_BYTES)
        foot = self.f.read(FOOTER_BYTES)
        if len(foot) != FOOTER_BYTES:
            return None
        op, length, summary_start, _, crc = struct.unpack("<BQQQI", foot)
        return (foot, summary_start, crc) if op == FOOTER and length == 20 else None

    def read_chunk_index(self) -> dict[int, int]:
        """A complete file's ChunkIndex records: chunk start -> its record's body length; empty
        when the footer or the summary is damaged (its CRC does not hold) or too large."""
        f = self.f
        here = f.tell()
        out: dict[int, int] = {}
        try:
            footer = self.read_footer()
            if footer is None:
                return out
            foot, summary_start, crc = footer
            end = self.size - 8 - FOOTER_BYTES
            if not 8 < summary_start < end or end - summary_start > self.lim.record_bytes:
                return out
            f.seek(summary_start)
            summary = f.read(end - summary_start)
            if len(summary) != end - summary_start or (crc and zlib.crc32(foot[:25], zlib.crc32(summary)) != crc):
                return out
            at = 0
            while at + 9 <= len(summary):
                rop, rlen = _RECORD.unpack_from(summary, at)
                if at + 9 + rlen > len(summary):
                    break
                if rop == CHUNK_INDEX and rlen >= 32:
                    start, chunk_length = struct.unpack_from("<QQ", summary, at + 9 + 16)
                    if 8 <= start < summary_start and 9 <= chunk_length <= summary_start - start:
                        out[start] = chunk_length - 9
                at += 9 + rlen
            return out
        finally:
            f.seek(here)

    def _tail_is_magic(self) -> bool:
        here = self.f.tell()
        self.f.seek(self.size - 8)
        tail = self.f.read(8)
        self.f.seek(here)
        return tail == MAGIC

    def step(self, start: int) -> None:
        """Read the record at ``start``."""
        c, lim = self.c, self.lim
        if self.records >= lim.records:
            raise self.fail(start, f"more than {lim.records} records (MAX_RECORDS): the audit stops here", "limit")
        left = self.size - start
        if left == 0:
            raise self.fail(start, "no footer: the file was not finished", "truncated")
        if left < 9:
            if c.complete:
                raise self.fail(start, f"corrupt: {left} stray bytes where a record should start")
            raise self.fail(start, f"truncated: the file ends inside a record header ({self.size} bytes)", "truncated")
        header = self.read(9, start)
        op, length = _RECORD.unpack(header)
        forced = self.forced.pop(start, None)
        if forced is not None:  # a damaged Chunk header: what the summary's index says is here
            op, length = CHUNK, forced
        kind = KINDS.get(op)
        if kind is None:
            raise self.fail(start, f"corrupt record: unknown opcode {op:#04x} (length field {length})")
        if op == CHUNK and length == UNFINISHED and not c.complete:
            raise self.unfinished_chunk(start)
        if length > lim.record_bytes:
            if length > self.size - self.pos:
                raise self.fail(
                    start,
                    f"corrupt {kind} record: it declares {length} bytes (more than MAX_RECORD_BYTES = "
                    f"{_size(lim.record_bytes)}, and more than the {self.size - self.pos} left in the file)",
                )
            raise self.fail(
                start,
                f"{kind} record of {length} bytes refused: more than MAX_RECORD_BYTES = {_size(lim.record_bytes)}",
                "limit",
            )
        if length > self.size - self.pos:
            if op == CHUNK and not c.complete:  # cut short inside a finished chunk: keep what is whole
                raise self.unfinished_chunk(start, length)
            raise self.past_end(start, kind, length)
        footer_at = self.size - FOOTER_BYTES - 8
        if c.complete and start == footer_at and (op != FOOTER or length != 20):
            raise self.fail(start, f"corrupt Footer: opcode {op:#04x} and length {length} where the footer is")
        if c.complete and op != FOOTER and self.pos + length > footer_at:
            raise self.fail(start, f"corrupt {kind} record: its length {length} runs into the footer")
        body = self.read(length, start)
        self.records += 1
        self.starts.append(start)
        self.kinds.append(op)
        if not self.seen_header and op != HEADER:
            raise self.fail(start, f"corrupt: the first record is a {kind}, not a Header")
        if self.summary_start is not None and op in DATA_ONLY:
            raise self.fail(start, f"corrupt: a {kind} record after the data section's end")
        if self.summary_start is None and op != DATA_END:
            self.data_crc = zlib.crc32(body, zlib.crc32(header, self.data_crc))
        elif op not in (DATA_END, FOOTER):
            self.summary_crc = zlib.crc32(body, zlib.crc32(header, self.summary_crc))
        try:
            self.record(op, kind, body, start, header)
        except _Bad as exc:
            # its framing holds (its length stayed in the file): reading goes on at the next
            # record, but after a damaged DataEnd or Footer, where the file's end is told
            if op == HEADER:
                self.seen_header = True  # (there, though damaged)
            elif op == CHUNK:
                self.skipped_chunk = start  # (its definitions lost: the summary's are used)
            more = self.passed_over >= self.lim.passed_over
            skip = op not in (DATA_END, FOOTER) and not more
            self.passed_over += skip
            # (past MAX_PASSED_OVER the reading stops: resync says so, as a limit finding)
            raise self.fail(start, f"corrupt {kind} record: {exc}", skip=skip) from None

    def record(self, op: int, kind: str, body: bytes, start: int, header: bytes) -> None:
        c = self.c
        cur = _Cursor(body, kind)
        if op == HEADER:
            if self.seen_header:
                raise _Bad("a second Header")
            cur.string("profile")
            c.header_library = cur.string("library")
            self.seen_header = True
        elif op in (SCHEMA, CHANNEL):
            self.keep_other(len(body), start)
            if op == SCHEMA:
                self.define_schema(_schema(cur), start)
            else:
                self.define_channel(_channel(cur), start)
        elif op == MESSAGE:
            self.message_record(body, start)
        elif op == CHUNK:
            try:
                self.chunk(cur, start)
            except _Fault as exc:
                if exc.skip:  # skipped whole: any Schema or Channel record in it is lost
                    self.skipped_chunk = start
                raise
        elif op == MESSAGE_INDEX:
            cur.u16("channel id")
            entries = cur.sub("records")
            if (entries.end - entries.pos) % 16:
                raise _Bad(f"its records take {entries.end - entries.pos} bytes, not a multiple of 16")
        elif op == CHUNK_INDEX:
            for name in ("message_start_time", "message_end_time", "chunk_start_offset", "chunk_length"):
                cur.u64(name)
            cur.u16_u64_map("message_index_offsets")
            cur.u64("message_index_length")
            cur.string("compression")
            cur.u64("compressed_size")
            cur.u64("uncompressed_size")
        elif op == ATTACHMENT:
            self.keep_other(len(body), start)
            self.attachment(cur, body, start)
        elif op == ATTACHMENT_INDEX:
            for name in ("offset", "length", "log_time", "create_time", "data_size"):
                cur.u64(name)
            cur.string("name")
            cur.string("media_type")
        elif op == STATISTICS:
            c.statistics = Statistics(
                message_count=cur.u64("message_count"),
                schema_count=cur.u16("schema_count"),
                channel_count=cur.u32("channel_count"),
                attachment_count=cur.u32("attachment_count"),
                metadata_count=cur.u32("metadata_count"),
                chunk_count=cur.u32("chunk_count"),
                message_start_time=cur.u64("message_start_time"),
                message_end_time=cur.u64("message_end_time"),
                channel_message_counts=cur.u16_u64_map("channel_message_counts"),
            )
        elif op == METADATA:
            self.keep_other(len(body), start)
            name = cur.string("name")
            c.metadata[name] = cur.str_map("metadata")
        elif op == METADATA_INDEX:
            cur.u64("offset")
            cur.u64("length")
            cur.string("name")
        elif op == SUMMARY_OFFSET:
            if not self.summary_offset_start:
                self.summary_offset_start = start
            cur.u8("group_opcode")
            cur.u64("group_start")
            cur.u64("group_length")
        elif op == DATA_END:
            self.data_end(cur, start)
        elif op == FOOTER:
            self.footer(cur, body, start, header)

    # -- records ------------------------------------------------------------------------------
    def keep_other(self, n: int, start: int) -> None:
        self.other_bytes += n
        if self.other_bytes > self.lim.other_bytes:
            raise self.fail(
                start,
                f"more than MAX_OTHER_BYTES = {_size(self.lim.other_bytes)} of attachments, metadata, schemas "
                "and channels: the audit stops here",
                "limit",
            )

    def define_schema(self, s: Schema, start: int) -> None:
        old = self.c.schemas.get(s.id)
        if old is not None and old != s and self.summary_start is None:
            self.anomaly("schema redefined", s.id, start, f"schema {s.id} is defined twice, differently")
        if old is None or self.summary_start is None:
            self.c.schemas[s.id] = s
        waiting = self.orphans.pop(s.id, None)
        if waiting is not None:
            topics, first, skipped = waiting
            self.defined_late(
                "schema undefined", s.id, 1, first, skipped, f"{_refer(topics, s.id)} before it is defined", schema=True
            )

    def define_channel(self, ch: Channel, start: int) -> None:
        c = self.c
        old = c.channels.get(ch.id)
        if old is not None and old != ch and self.summary_start is None:
            self.anomaly("channel redefined", ch.id, start, f"channel {ch.id} is defined twice, differently")
        if old is not None and self.summary_start is not None:
            return  # the summary's copy
        if ch.schema_id != 0 and ch.schema_id not in c.schemas:  # until a Schema record turns up
            waiting = self.orphans.setdefault(ch.schema_id, [[], start, self.skipped_chunk])
            waiting[0].append(ch.topic)
        c.channels[ch.id] = ch
        if ch.id not in c.by_channel:
            c.by_channel[ch.id] = MessageStore(self.blocks, self.block_offsets)
        held = self.held.pop(ch.id, None)
        if held is not None:  # its messages read so far are in by_channel already: in file order
            n, first, skipped = held
            detail = f"message on channel {ch.id} ({ch.topic}) before the channel is defined"
            self.defined_late("channel undefined", ch.id, n, first, skipped, detail)

    def defined_late(
        self, key: str, ident: int, n: int, first: int, skipped: int | None, detail: str, schema: bool = False
    ) -> None:
        """A definition turned up for ``n`` messages (or a channel) read before it, the first
        at ``first``. In the data section the writer's order is wrong: an error. From the
        summary after a skipped chunk it stands in for the copy presumably lost with that
        chunk: counted for one warning (see :meth:`finish`). From the summary with no chunk
        skipped before, the data section never defined it: an error."""
        if self.summary_start is not None:
            if skipped is not None:
                self.restored.setdefault(skipped, [0, 0])[int(schema)] += 1
                return
            detail += " (only the summary defines it)"
        self.anomalies[(key, ident)] = [n, first, detail]

    def anomaly(self, key: str, channel: int, offset: int, detail: str) -> None:
        a = self.anomalies.get((key, channel))
        if a is None:
            self.anomalies[(key, channel)] = [1, offset, detail]
        else:
            a[0] += 1

    def message_record(self, body: bytes, start: int) -> None:
        if len(body) < 22:
            raise _Bad(f"{len(body)} bytes, a message needs at least 22")
        block = self.new_block(body, start, len(body))
        self.message(body, 0, len(body), block, start)

    def new_block(self, data: bytes, start: int, n: int) -> int:
        """Keep ``data`` for its payloads when the budget allows; the block index or -1."""
        if self.kept_bytes + n > self.lim.message_bytes:
            return -1
        self.kept_bytes += n
        self.blocks.append(data)
        self.block_offsets.append(start)
        return len(self.blocks) - 1

    def message(self, buf: Any, pos: int, length: int, block: int, start: int) -> int:
        """One message record's body at ``buf[pos:pos+length]``; returns its log time."""
        c = self.c
        if self.messages >= self.lim.messages:
            raise self.fail(
                start,
                f"more than {self.lim.messages} messages (MAX_MESSAGES): the audit stops here "
                "(lfctl audit --max-messages N reads further)",
                "limit",
            )
        self.messages += 1
        cid, seq, log_time, publish_time = _MESSAGE.unpack_from(buf, pos)
        c.counts[cid] = c.counts.get(cid, 0) + 1
        store = c.by_channel.get(cid)
        if store is None:  # kept until the channel is defined (a later chunk, the summary): see held
            store = c.by_channel[cid] = MessageStore(self.blocks, self.block_offsets)
        if cid not in c.channels:
            held = self.held.get(cid)
            if held is None:
                self.held[cid] = [1, start, self.skipped_chunk]
            else:
                held[0] += 1
        prev = self.last_time.get(cid)
        if prev is not None and log_time < prev:
            name = c.channels[cid].topic if cid in c.channels else f"channel {cid}"
            self.anomaly("time back", cid, start, f"log_time goes back on {name}: {log_time} ns after {prev} ns")
        self.last_time[cid] = log_time
        if block < 0:
            c.payloads_dropped += 1
        else:
            store.append(log_time, publish_time, seq, block, pos + 22, length - 22)
        return log_time

    def attachment(self, cur: _Cursor, body: bytes, start: int) -> None:
        times = cur.u64("log_time"), cur.u64("create_time")
        name = cur.string("name")
        media = cur.string("media_type")
        data = cur.raw(cur.u64("data length"), "data")
        end = cur.pos
        crc = cur.u32("crc")
        if crc:
            got = zlib.crc32(memoryview(body)[:end])
            if got != crc:  # the framing is intact: skip it, read on
                raise self.fail(
                    start,
                    f"CRC mismatch in the Attachment {name!r}: computed {got:#010x}, the record says {crc:#010x}",
                    "crc",
                    skip=True,
                )
        self.c.attachments[name] = data
        self.c.attachment_types[name] = media
        self.c.attachment_times[name] = times

    def chunk(self, cur: _Cursor, start: int) -> None:
        t0 = cur.u64("message_start_time")
        t1 = cur.u64("message_end_time")
        size = cur.u64("uncompressed_size")
        crc = cur.u32("uncompressed_crc")
        compression = cur.string("compression")
        n = cur.u64("records length")
        data = memoryview(cur.buf)[cur.take(n, "records") : cur.pos]
        if size > self.lim.chunk_bytes:
            raise self.fail(
                start,
                f"Chunk declares {size} bytes uncompressed, more than MAX_CHUNK_BYTES = {_size(self.lim.chunk_bytes)}",
                "limit",
                skip=True,
            )
        try:
            records = _inflate(compression, data, size, self.lim.chunk_bytes)
        except _Bad as exc:
            raise self.fail(start, f"corrupt Chunk ({compression or 'uncompressed'}): {exc}", skip=True) from None
        if crc:
            got = zlib.crc32(records)
            if got != crc:
                raise self.fail(
                    start,
                    f"CRC mismatch in a Chunk: its records give {got:#010x}, the chunk says {crc:#010x}",
                    "crc",
                    skip=True,
                )
        try:
            ops, positions, lengths = _frame_chunk(records)
        except _Bad as exc:
            raise self.fail(start, f"corrupt Chunk: {exc}", skip=True) from None
        out_of_range = self.chunk_records(records, ops, positions, lengths, start, t0, t1)
        if out_of_range:
            self.findings.append(
                Finding(
                    "error",
                    f"corrupt Chunk: {out_of_range} of its messages lie outside its time range {t0}..{t1} ns",
                    start,
                    "corrupt",
                )
            )

    def chunk_records(
        self, records: Any, ops: array, positions: array, lengths: array, start: int, t0: int, t1: int
    ) -> int:
        """Read a chunk's framed records; the number of messages outside ``t0..t1``."""
        others = [i for i, op in enumerate(ops) if op != MESSAGE]
        if others:
            self.keep_other(sum(lengths[i] for i in others), start)
        block = self.new_block(records, start, len(records)) if len(others) < len(ops) else -1
        out_of_range = 0
        for op, pos, ln in zip(ops, positions, lengths, strict=True):
            if op == MESSAGE:
                out_of_range += not t0 <= self.message(records, pos, ln, block, start) <= t1
            else:
                sub = _Cursor(records, KINDS[op], pos, pos + ln)
                try:  # framing checked; a bad field here is damage that passed the CRC
                    if op == SCHEMA:
                        self.define_schema(_schema(sub), start)
                    else:
                        self.define_channel(_channel(sub), start)
                except _Bad as exc:
                    raise self.fail(start, f"corrupt Chunk: {exc}") from None
        return out_of_range

    def unfinished_chunk(self, start: int, declared: int | None = None) -> _Fault:
        """A Chunk the file ends inside: one whose length still holds the writer's placeholder
        (the writer streams a chunk to the file and fills its lengths in when the chunk is
        finished, so a writer killed in between leaves this), or, with ``declared``, a finished
        one cut short (a copy or a disk that ended early). The messages whose records reached
        the file in full are kept."""
        rest = self.size - self.pos
        body = self.read(min(rest, self.lim.record_bytes), start)
        cur = _Cursor(body, "Chunk")
        kept, note = 0, ""
        try:
            for name in ("message_start_time", "message_end_time", "uncompressed_size"):
                cur.u64(name)
            cur.u32("uncompressed_crc")
            compression = cur.string("compression")
            cur.u64("records length")
            records = _inflate_prefix(compression, memoryview(body)[cur.pos :], self.lim.chunk_bytes)
            ops, positions, lengths, used = _frame_prefix(records)
            before = self.messages
            self.chunk_records(records, ops, positions, lengths, start, 0, UNFINISHED)
            kept = self.messages - before
            if used < len(records):
                note = f"; {len(records) - used} bytes of a record cut off"
        except _Bad as exc:
            note = f"; nothing recovered from it: {exc}"
        what = (
            "a Chunk the writer had not finished (its length is still the writer's placeholder; "
            if declared is None
            else f"a Chunk record ({declared} bytes declared, "
        )
        return self.fail(
            start,
            f"truncated: the file ends inside {what}{rest} bytes of it present, {kept} whole messages recovered{note})",
            "truncated",
        )

    def data_end(self, cur: _Cursor, start: int) -> None:
        crc = cur.u32("data_section_crc")
        if cur.pos != cur.end:
            raise _Bad(f"{cur.end} bytes, a DataEnd has 4")
        self.c.data_end = True
        self.summary_start = self.pos
        if crc and crc != self.data_crc and not self.resumed:  # (bytes passed over: the CRC cannot hold)
            self.findings.append(self.crc_finding("data section", crc, self.data_crc, 0, start, start))

    def footer(self, cur: _Cursor, body: bytes, start: int, header: bytes) -> None:
        c = self.c
        summary_start = cur.u64("summary_start")
        summary_offset_start = cur.u64("summary_offset_start")
        crc = cur.u32("summary_crc")
        if cur.pos != cur.end:
            raise _Bad(f"{cur.end} bytes, a Footer has 20")
        left = self.size - self.pos
        if left < 8:
            raise self.past_end(self.pos, "closing magic", 8)
        tail = self.read(8, self.pos)
        if tail != MAGIC:
            raise self.fail(self.pos - 8, f"corrupt: the closing magic is {tail!r}, not {MAGIC!r}")
        if left > 8:  # the file itself is whole: say so, and check it
            self.findings.append(
                Finding("error", f"corrupt: {left - 8} bytes after the closing magic", self.pos, "corrupt")
            )
        c.footer = True
        if self.summary_start is None:
            self.findings.append(Finding("error", "corrupt: the file has no DataEnd record", start, "corrupt"))
            return
        empty = self.summary_start == start
        if crc:
            got = zlib.crc32(body[:16], zlib.crc32(header, self.summary_crc))
            if got != crc:
                self.findings.append(self.crc_finding("summary", crc, got, self.summary_start, start + 25, start))
                return
        if summary_start != (0 if empty else self.summary_start):
            self.findings.append(
                Finding(
                    "error",
                    f"corrupt Footer: summary_start says {summary_start}, the summary begins at {self.summary_start}",
                    start,
                    "corrupt",
                )
            )
        if summary_offset_start != self.summary_offset_start:
            self.findings.append(
                Finding(
                    "error",
                    f"corrupt Footer: summary_offset_start says {summary_offset_start}, the summary offsets "
                    f"begin at {self.summary_offset_start}",
                    start,
                    "corrupt",
                )
            )

    # -- diagnosis ----------------------------------------------------------------------------
    def crc_finding(self, what: str, stored: int, got: int, first: int, end: int, at: int) -> Finding:
        """A CRC mismatch over bytes ``first..end``: at the record holding the flipped bit when
        one bit explains it, else at ``at`` (the record that holds the CRC)."""
        text = f"{what} CRC mismatch: computed {got:#010x}, the file says {stored:#010x}"
        if bin(stored ^ got).count("1") == 1:
            return Finding("error", f"{text} (one bit differs: the stored CRC itself is damaged)", at, "crc")
        hit = locate_flip(stored, got, end - first)
        if hit is None:
            return Finding("error", f"{text} (more than one bit is damaged)", at, "crc")
        byte, bit = first + hit[0], hit[1]
        rec = self.record_at(byte)
        return Finding("error", f"{text}: one flipped bit explains it, byte {byte} bit {bit}{rec[1]}", rec[0], "crc")

    def record_at(self, byte: int) -> tuple[int, str]:
        """The start of the top-level record read that holds ``byte``, and a phrase naming it."""
        i = bisect_right(self.starts, byte) - 1
        if byte < 8 or i < 0:
            return byte, " (in the opening magic)" if byte < 8 else ""
        start = self.starts[i]
        return start, f", in the {KINDS.get(self.kinds[i], 'unknown')} record at byte {start}"

    def finish(self, fault: _Fault | None) -> None:
        c = self.c
        for skipped, counts in self.restored.items():
            what = " and ".join(_count(n, word) for n, word in zip(counts, ("channel", "schema"), strict=True) if n)
            self.findings.append(
                Finding(
                    "warning",
                    f"{what} used after this skipped Chunk {'is' if sum(counts) == 1 else 'are'} defined only in "
                    "the summary (their definitions were presumably in the chunk): the summary's are used",
                    skipped,
                    "corrupt",
                )
            )
        for cid, (n, first, skipped) in self.held.items():  # defined nowhere: nothing to read them with
            del c.by_channel[cid]
            lost = (
                f"; its definition was presumably in the Chunk skipped at byte {skipped}" if skipped is not None else ""
            )
            detail = f"message on channel {cid}, which no intact Channel record defines{lost}"
            self.anomalies[("channel undefined", cid)] = [n, first, detail]
        for sid, (topics, first, skipped) in self.orphans.items():
            lost = (
                f"; its definition was presumably in the Chunk skipped at byte {skipped}" if skipped is not None else ""
            )
            detail = f"{_refer(topics, sid)}, which no intact Schema record defines{lost}"
            self.anomalies[("schema undefined", sid)] = [1, first, detail]
        for (key, cid), (n, offset, detail) in self.anomalies.items():
            more = f" ({n} times)" if n > 1 else ""
            level = "error"
            self.findings.append(Finding(level, detail + more, offset, "corrupt" if "defined" in key else "content"))
            del cid
        if c.payloads_dropped:
            self.findings.append(
                Finding(
                    "warning",
                    f"payloads of {c.payloads_dropped} messages not kept: more than MAX_MESSAGE_BYTES = "
                    f"{_size(self.lim.message_bytes)} of chunk data (they were checked and counted; figures and "
                    "--recover cover the messages kept)",
                    kind="limit",
                )
            )
        if fault is not None and c.complete and fault.kind in ("corrupt", "truncated", "limit"):
            self.explain(fault)
        for ch_id, store in c.by_channel.items():
            if len(store) and ch_id in c.channels:
                c.messages.setdefault(c.channels[ch_id].topic, []).append(store)  # type: ignore[attr-defined]
        for topic, stores in list(c.messages.items()):
            c.messages[topic] = stores[0] if len(stores) == 1 else _TopicView(stores)  # type: ignore[arg-type]

    def explain(self, fault: _Fault) -> None:
        """A fault that stopped the reading of a complete file: a flipped bit the data section's
        (or the summary's) CRC locates moves the finding to the record that holds it."""
        f, size = self.f, self.size
        footer = self.read_footer()
        if footer is None:
            return
        _, summary_start, summary_crc = footer
        data_end = (summary_start or size - 8 - FOOTER_BYTES) - DATA_END_BYTES
        sections = []  # (stored CRC, first byte, end) of the sections that may hold the flip
        if data_end > 8:  # the data section, also for a fault past it: a flipped length can jump there
            f.seek(data_end)
            raw = f.read(DATA_END_BYTES)
            if len(raw) == DATA_END_BYTES and raw[:9] == _RECORD.pack(DATA_END, 4):
                sections.append((int.from_bytes(raw[9:], "little"), 0, data_end))
        if summary_start and fault.offset >= summary_start:
            sections.append((summary_crc, summary_start, size - 8 - 4))
        hit = None
        for stored, first, end in sections:
            if not stored or end - first > LOCATE_MAX_BYTES:  # nothing to locate with, or too long to
                continue
            got = _crc_range(f, first, end)
            found = locate_flip(stored, got, end - first) if got != stored else None
            if found is not None and first + found[0] <= fault.offset + 9:  # before the fault, or in its header
                hit = (first + found[0], found[1])
                break
        if hit is None:
            return
        byte, bit = hit
        finding = next(x for x in reversed(self.findings) if x.offset == fault.offset and x.what == fault.what)
        if byte < fault.offset:  # in a record read before: that is the damaged one
            finding.offset, name = self.record_at(byte)
        else:
            name = f", in the record header at byte {fault.offset}"
        finding.what += f" -- one flipped bit explains it: byte {byte} bit {bit}{name}"
        finding.kind = "corrupt"


def _crc_range(f: Any, first: int, end: int) -> int:
    f.seek(first)
    crc, left = 0, end - first
    while left > 0:
        block = f.read(min(left, MiB))
        if not block:
            break
        crc = zlib.crc32(block, crc)
        left -= len(block)
    return crc


def _schema(cur: _Cursor) -> Schema:
    sid = cur.u16("id")
    name = cur.string("name")
    encoding = cur.string("encoding")
    data = cur.raw(cur.u32("data length"), "data")
    return Schema(id=sid, name=name, encoding=encoding, data=data)


def _channel(cur: _Cursor) -> Channel:
    cid = cur.u16("id")
    schema_id = cur.u16("schema_id")
    topic = cur.string("topic")
    encoding = cur.string("message_encoding")
    return Channel(
        id=cid, topic=topic, message_encoding=encoding, metadata=cur.str_map("metadata"), schema_id=schema_id
    )


def _frame_chunk(records: bytes | memoryview) -> tuple[array, array, array]:
    """The opcode, body offset and body length of each record in an inflated chunk (arrays:
    no object per record); raises _Bad for a record that runs past the chunk or has no place
    in one."""
    ops, positions, lengths = array("B"), array(_U32), array(_U32)
    pos, n = 0, len(records)
    unpack = _RECORD.unpack_from
    while pos < n:
        if n - pos < 9:
            raise _Bad(f"{n - pos} stray bytes at the end of its records")
        op, length = unpack(records, pos)
        body = pos + 9
        if length > n - body:
            raise _Bad(f"a record at byte {pos} of its records declares {length} bytes, {n - body} are left")
        if op == MESSAGE:
            if length < 22:
                raise _Bad(f"a Message at byte {pos} of its records has {length} bytes, fewer than 22")
        elif op not in (SCHEMA, CHANNEL):
            raise _Bad(f"a record with opcode {op:#04x} at byte {pos} of its records (only Schema, Channel, Message)")
        ops.append(op)
        positions.append(body)
        lengths.append(length)
        pos = body + length
    return ops, positions, lengths


def _frame_prefix(records: bytes | memoryview) -> tuple[array, array, array, int]:
    """Like _frame_chunk for the records of a chunk cut short: the records that are there in
    full, and the bytes they take."""
    n, pos = len(records), 0
    while n - pos >= 9:
        op, length = _RECORD.unpack_from(records, pos)
        if op not in (SCHEMA, CHANNEL, MESSAGE) or length > n - pos - 9:
            break
        pos += 9 + length
    ops, positions, lengths = _frame_chunk(memoryview(records)[:pos])
    return ops, positions, lengths, pos


def _inflate_prefix(compression: str, data: memoryview, limit: int) -> bytes | memoryview:
    """What a compressed stream cut short inflates to (at most ``limit`` bytes); raises _Bad.
    The input goes in a KiB at a time, so a bomb cannot inflate far past ``limit``."""
    if compression == "":
        return data[:limit]
    if compression == "zstd":
        import zstandard

        d: Any = zstandard.ZstdDecompressor(max_window_size=_window(limit)).decompressobj()
        error: type[Exception] = zstandard.ZstdError
    elif compression == "lz4":
        import lz4.frame

        d, error = lz4.frame.LZ4FrameDecompressor(), RuntimeError
    else:
        raise _Bad(f"unknown compression {compression!r}")
    out = bytearray()
    try:
        for at in range(0, len(data), KiB):
            out += d.decompress(data[at : at + KiB])
            if len(out) >= limit or getattr(d, "eof", False):
                break
    except error as exc:
        if not out:
            raise _Bad(f"{compression}: {exc}") from None
    return bytes(out[:limit])


def _window(limit: int) -> int:
    return max(MiB, 1 << max(limit - 1, 1).bit_length())


def _inflate(compression: str, data: memoryview, size: int, limit: int) -> bytes | memoryview:
    """A chunk's records, inflated to exactly ``size`` bytes (at most ``limit``); raises _Bad."""
    if compression == "":
        if len(data) != size:
            raise _Bad(f"it holds {len(data)} bytes and declares {size}")
        return data
    if compression == "zstd":
        import zstandard

        try:
            declared = zstandard.get_frame_parameters(data).content_size
        except zstandard.ZstdError as exc:
            raise _Bad(f"not a zstd frame: {exc}") from None
        if declared not in (zstandard.CONTENTSIZE_UNKNOWN, size):
            raise _Bad(f"the zstd frame says it inflates to {declared} bytes, the chunk declares {size}")
        try:  # with a declared size the output is that size; without one, at most ``size``
            out = zstandard.ZstdDecompressor(max_window_size=_window(limit)).decompress(
                data, max_output_size=size, allow_extra_data=False
            )
        except zstandard.ZstdError as exc:
            raise _Bad(f"zstd: {exc}") from None
    elif compression == "lz4":
        import lz4.frame

        try:
            declared = lz4.frame.get_frame_info(data)["content_size"]
            if declared and declared != size:
                raise _Bad(f"the lz4 frame says it inflates to {declared} bytes, the chunk declares {size}")
            d = lz4.frame.LZ4FrameDecompressor()
            out = d.decompress(data, max_length=size + 1)
        except RuntimeError as exc:  # how lz4.frame reports a bad frame
            raise _Bad(f"lz4: {exc}") from None
        if len(out) > size:
            raise _Bad(f"it inflates to more than the {size} bytes it declares")
        if not d.eof:
            raise _Bad(f"the lz4 frame ends early ({len(out)} of {size} bytes inflated)")
        if d.unused_data:
            raise _Bad(f"{len(d.unused_data)} bytes after its lz4 frame")
    else:
        raise _Bad(f"unknown compression {compression!r}")
    if len(out) != size:
        raise _Bad(f"it inflates to {len(out)} bytes and declares {size}")
    return out
