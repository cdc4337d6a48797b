"""MAVLink FTP (FILE_TRANSFER_PROTOCOL): a vehicle's virtual files, served as ArduPilot's
``GCS_FTP`` serves them.

A ground station asks for files over MAVLink FTP before it falls back to other messages:
MAVProxy fetches ``@PARAM/param.pck`` instead of listing the parameters one message at a
time, and ``wp ftp``, ``fence ftp`` and ``rally ftp`` fetch ``@MISSION/mission.dat``,
``fence.dat`` and ``rally.dat`` (pymavlink's ``mavftp`` the same). A vehicle keeps no other
files (a Rover also serves its SD card, logs and scripts): any other name is FileNotFound, at
once, so a ground station that wanted one does not wait out its timeout.

What :class:`FtpServer` answers, as ``GCS_FTP::Session::handle_request``: OpenFileRO (the
file is read whole then, so a download is one consistent copy, and its size is given),
ReadFile and BurstReadFile (a burst runs to the file's end, EndOfFile, or to
:data:`BURST_PACKETS` replies, only its last reply marked ``burst_complete``; reading past the
end is EndOfFile; a file that opens but cannot be read, :class:`ReadFails`, fails its reads
with FailErrno), ListDirectory, CalcFileCRC32
(ArduPilot's CRC-32: zlib's polynomial from a zero seed, without the final inversion),
CreateFile and OpenFileWO on a writable file, WriteFile, TerminateSession (which hands a
written file over: refused, the reply is FailErrno with EINVAL and a line of text says why),
ResetSessions, None; RemoveFile, CreateDirectory, RemoveDirectory and Rename are
FileNotFound (nothing can be removed or made), and TruncateFile and anything newer
UnknownCommand; a request whose size is past the payload's 239 bytes is InvalidDataSize.
Each reply carries the request's sequence number plus one and its session; a request sent
again within :data:`SESSION_TIMEOUT_S` (its reply lost) gets the same reply again, not a
second action.

Sessions are the ground station's numbers, one open file each, at most :data:`MAX_SESSIONS`
at a time over all senders; one idle for :data:`SESSION_TIMEOUT_S` may be taken over, and one
idle for :data:`SESSION_KILL_S` is closed (:meth:`FtpServer.tick`). However a session with a
written file closes (its TerminateSession lost, a ResetSessions, a takeover, idleness), the
file is handed over as ArduPilot's ``close`` hands it over: a file not written whole is
refused by its checks, and said.

Replies are rationed, as a vehicle's link is: at most :data:`REPLIES_PER_S` a second on
average (:data:`REPLY_BURST` at once); a request that finds none left goes unanswered, as
ArduPilot drops a request its queue has no room for (the ground station asks again). A burst
is paced by the ration as ArduPilot's by the link's free buffer space: it sends what the
ration has at once and goes on at :meth:`FtpServer.tick` as the ration refills, so a ground
station sees the same replies as from a Rover, only the last marked complete, and other
traffic is not held up. Unlike ArduPilot's one FTP worker, which answers what comes during a
burst after the burst, a request that comes during one is answered at once (a new burst on
the same session replaces it; the session's closing ends it).

The payload is MAVLink FTP's (``seq_number`` uint16, ``session``, ``opcode``, ``size``,
``req_opcode``, ``burst_complete``, padding, ``offset`` uint32, then up to 239 bytes of data).
"""

from __future__ import annotations

import errno
import struct
import time
import zlib
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass

__all__ = [
    "ACK",
    "BURST_PACKETS",
    "DATA_BYTES",
    "ERR_END_OF_FILE",
    "ERR_FAIL",
    "ERR_FAIL_ERRNO",
    "ERR_FILE_NOT_FOUND",
    "ERR_INVALID_DATA_SIZE",
    "ERR_NO_SESSIONS",
    "ERR_UNKNOWN_COMMAND",
    "MAX_SESSIONS",
    "NAK",
    "REPLIES_PER_S",
    "REPLY_BURST",
    "SESSION_KILL_S",
    "SESSION_TIMEOUT_S",
    "FtpFile",
    "FtpServer",
    "ReadFails",
    "ardupilot_crc32",
]

#: the reply opcodes
ACK, NAK = 128, 129
#: the errors a NAK carries in its first data byte (FailErrno: an errno in the second)
ERR_FAIL, ERR_FAIL_ERRNO, ERR_INVALID_DATA_SIZE, ERR_NO_SESSIONS = 1, 2, 3, 5
ERR_END_OF_FILE, ERR_UNKNOWN_COMMAND, ERR_FILE_NOT_FOUND = 6, 7, 10
#: the request opcodes
(
    OP_NONE,
    OP_TERMINATE,
    OP_RESET,
    OP_LIST,
    OP_OPEN_RO,
    OP_READ,
    OP_CREATE,
    OP_WRITE,
    OP_REMOVE,
    OP_MKDIR,
    OP_RMDIR,
    OP_OPEN_WO,
    OP_TRUNCATE,
    OP_RENAME,
    OP_CRC,
    OP_BURST,
) = range(16)
_HEADER = struct.Struct("<HBBBBBBI")
#: the payload's length, and the data it carries after the header
PAYLOAD_BYTES = 251
DATA_BYTES = PAYLOAD_BYTES - _HEADER.size
#: the most replies one BurstReadFile gets before the ground station asks for more: GCS_FTP's
#: transfer_size (a full parameter file of the most parameters)
BURST_PACKETS = 2000
#: sessions open at once (over all senders): GCS_FTP's AP_MAVLINK_FTP_MAX_SESSIONS
MAX_SESSIONS = 5
#: a session this long idle may be taken over by another, or its file reopened, s (ArduPilot's)
SESSION_TIMEOUT_S = 3.0
#: a session this long idle is closed, s (ArduPilot's)
SESSION_KILL_S = 20.0
#: the largest file a ground station may write, bytes (a mission of 2,000 items is 76,010)
MAX_WRITE_BYTES = 1 << 17
#: replies kept for requests sent again
_KEPT_REPLIES = 32
#: the replies a second the server sends on average, and at most at once (a 2,000-item
#: mission, 318 replies, takes about a second; a hostile peer cannot make the vehicle flood)
REPLIES_PER_S = 400.0
REPLY_BURST = 256.0


def ardupilot_crc32(data: bytes) -> int:
    """ArduPilot's ``crc_crc32`` of ``data`` from a zero seed (what CalcFileCRC32 answers):
    the standard reflected CRC-32 without zlib's initial and final inversions.

    Parameters
    ----------
    data : bytes
        The file.
    """
    return zlib.crc32(data, 0xFFFFFFFF) ^ 0xFFFFFFFF


class ReadFails(ValueError):
    """Raised by an :class:`FtpFile`'s ``read`` for a file that opens but cannot be read, as
    ArduPilot's ``AP_Filesystem_Param`` opens ``param.pck?start=N`` whatever N and fails only
    the read that takes its header (``AP_Filesystem_Param::read``): OpenFileRO is ACKed, giving
    ``size``; a read (ReadFile, BurstReadFile) from before byte ``until`` is FailErrno with
    ``code``, one from ``until`` on finds the file's end (nothing follows the header).

    Parameters
    ----------
    why : str
        Why it cannot be read (said in a line of text at the open).
    code : int
        The errno a failed read carries.
    until : int
        The reads that start before this byte fail.
    size : int
        The file's size the open's reply gives, bytes.
    """

    def __init__(self, why: str, code: int = errno.EINVAL, until: int = 0, size: int = 0) -> None:
        super().__init__(why)
        self.code, self.until, self.size = code, until, size


@dataclass
class FtpFile:
    """One file a vehicle serves.

    Parameters
    ----------
    read : callable
        The file now, given what followed ``?`` in the name asked for (``""``: nothing);
        raises ValueError naming what it cannot take there (the open is refused), or
        :class:`ReadFails` (the open is taken, the reads fail).
    write : callable, optional
        Takes a written file whole, with its writer's system and component: returns None
        when taken, else why not. None: the file is read-only.
    size : callable, optional
        The file's size now, bytes, for a listing (None: the length of what ``read`` gives).
    options : bool
        The name may carry options after ``?`` (``param.pck?withdefaults=1``); for a file
        without, a name with them is no such file (ArduPilot compares the whole name).
    on_open : callable, optional
        Called when the file is opened for reading (ArduPilot's banner on param.pck).
    """

    read: Callable[[str], bytes]
    write: Callable[[bytes, int, int], str | None] | None = None
    size: Callable[[], int] | None = None
    options: bool = False
    on_open: Callable[[], None] | None = None


@dataclass
class _Burst:
    """A BurstReadFile under way: its request's sequence number, the next reply's offset, the
    bytes a reply, and the replies sent."""

    seq: int
    offset: int
    size: int
    sent: int = 0


@dataclass
class _Session:
    key: tuple[int, int, int]  # sysid, compid, session number
    last_s: float
    path: str = ""
    content: bytes | None = None  # a file open for reading
    written: bytearray | None = None  # a file open for writing
    file: FtpFile | None = None
    fails: ReadFails | None = None  # a file open for reading whose reads fail
    burst: _Burst | None = None  # a BurstReadFile under way

    @property
    def open(self) -> bool:
        return self.content is not None or self.written is not None

    def close(self) -> None:
        self.path, self.content, self.written, self.file = "", None, None, None
        self.fails, self.burst = None, None


class FtpServer:
    """Serves ``files`` over MAVLink FTP (the module's docstring gives what is answered how).

    Parameters
    ----------
    files : dict of str to FtpFile
        The files by path (``"@PARAM/param.pck"``); their directories are listed from it.
    send : callable
        Sends one reply payload (:data:`PAYLOAD_BYTES`) to a system and component.
    say : callable
        Says a line of text to the ground station (a written file refused, and why).
    clock : callable
        Now, s (sessions' idle times).
    """

    def __init__(
        self,
        files: dict[str, FtpFile],
        send: Callable[[bytes, int, int], None],
        say: Callable[[str], None],
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.files = files
        self._send = send
        self._say = say
        self._clock = clock
        #: requests that went unanswered because the replies' ration was spent
        self.unanswered = 0
        self.reset()

    def reset(self) -> None:
        """Forget every session (a file being written is dropped, not handed over), every
        kept reply, and the spent ration: as after the vehicle restarts."""
        self._sessions: dict[tuple[int, int, int], _Session] = {}
        # each session's last request (its sequence number and opcode), when, and the replies
        # it got, kept for that request sent again
        self._last: OrderedDict[tuple[int, int, int], tuple[int, int, float, list[bytes]]] = OrderedDict()
        self._tokens = REPLY_BURST
        self._tokens_t = self._clock()
        self._burst_served: tuple[int, int, int] | None = None  # the session whose burst went last

    def tick(self) -> None:
        """Close the sessions idle for :data:`SESSION_KILL_S` (a written file is handed over),
        and send the bursts under way as many replies as the ration has refilled since (one
        from each in turn): call it often (each step), so a long burst goes on at the
        ration's pace and a file whose TerminateSession was lost is not held for ever."""
        now = self._clock()
        self._refill(now)
        self._expire(now)
        going = [s for s in self._sessions.values() if s.burst is not None]
        # in turn from the session after the one served last, so none is left out however
        # often the ration runs dry
        keys = [s.key for s in going]
        if self._burst_served in keys:
            k = keys.index(self._burst_served) + 1
            going = going[k:] + going[:k]
        while going and self._tokens >= 1.0:
            for s in list(going):
                if self._tokens < 1.0:
                    break
                replies = self._burst(s, 1)
                self._tokens -= len(replies)
                s.last_s = now  # (as ArduPilot's push_reply: a session sending is not idle)
                self._burst_served = s.key
                self._deliver(replies, s.key[0], s.key[1])
                if s.burst is None:
                    going.remove(s)

    def _refill(self, now: float) -> None:
        """The ration, refilled for the time since it was last looked at."""
        self._tokens = min(REPLY_BURST, self._tokens + max(0.0, now - self._tokens_t) * REPLIES_PER_S)
        self._tokens_t = now  # (a clock set back refills nothing and takes nothing)

    # -- the requests ----------------------------------------------------------------------
    def handle(self, payload: bytes, sysid: int, compid: int) -> None:
        """Answer one FILE_TRANSFER_PROTOCOL payload from ``sysid``/``compid``; a reply sent
        to us (an ACK or a NAK) and a payload too short for a header are ignored.

        Parameters
        ----------
        payload : bytes
            The message's payload.
        sysid, compid : int
            Its sender.
        """
        if len(payload) < _HEADER.size:
            return
        seq, session, opcode, size, _req, _burst, _pad, offset = _HEADER.unpack_from(payload)
        if opcode in (ACK, NAK):
            return
        # the whole data field (a name is measured over it, as ArduPilot's strnlen), and the
        # request's own bytes
        field = bytes(payload[_HEADER.size : _HEADER.size + DATA_BYTES])
        key = (sysid, compid, session)
        now = self._clock()
        self._refill(now)
        if self._tokens < 1.0:
            self.unanswered += 1  # as lost: the ground station asks again
            return
        self._expire(now)
        last = self._last.get(key)
        if last is not None and last[:2] == (seq, opcode) and now - last[2] <= SESSION_TIMEOUT_S and opcode != OP_RESET:
            self._tokens -= len(last[3])
            self._deliver(last[3], sysid, compid)  # sent again: its reply was lost
            return
        head = (seq, session, opcode, offset)
        if size > DATA_BYTES:
            replies = [self._nak(head, ERR_INVALID_DATA_SIZE)]  # (ArduPilot's first check of any request)
        elif opcode == OP_RESET:
            for k in [k for k in self._sessions if k[:2] == (sysid, compid)]:
                self._finish(self._sessions.pop(k))  # (a written file is handed over, as ArduPilot closes it)
            for k in [k for k in self._last if k[:2] == (sysid, compid)]:
                del self._last[k]  # a client starting afresh may use the same numbers again
            replies = [self._reply(head, ACK)]
        elif opcode == OP_TERMINATE:
            closing = self._sessions.pop(key, None)
            why = None if closing is None else self._finish(closing)
            replies = [self._nak(head, ERR_FAIL_ERRNO, errno.EINVAL) if why else self._reply(head, ACK)]
        elif opcode == OP_NONE:
            replies = [self._reply(head, ACK)]
        elif opcode == OP_LIST:
            replies = [self._list(head, size, field)]
        elif opcode in (OP_REMOVE, OP_MKDIR, OP_RMDIR, OP_RENAME):
            replies = [self._nak(head, ERR_FILE_NOT_FOUND)]  # nothing here can be removed or made
        elif opcode == OP_CRC:
            replies = [self._crc(head, size, field)]
        elif opcode in (OP_OPEN_RO, OP_READ, OP_BURST, OP_CREATE, OP_OPEN_WO, OP_WRITE):
            s = self._session(key, now)
            if s is None:
                replies = [self._nak(head, ERR_NO_SESSIONS)]
            else:
                idle_s, s.last_s = now - s.last_s, now
                replies = self._on_session(s, head, size, field, idle_s)
        else:  # TruncateFile, ListDirectoryWithTime and anything newer: unknown to ArduPilot
            replies = [self._nak(head, ERR_UNKNOWN_COMMAND)]
        no_room = replies[0][3] == NAK and replies[0][12] == ERR_NO_SESSIONS
        if opcode == OP_BURST:
            # a burst is not kept (it may go on after this): sent again, it starts again from its
            # offset, as ArduPilot's keeps only the last reply, which a burst of more than one
            # reply numbers past its request's
            self._last.pop(key, None)
        elif not no_room:  # (a refusal for want of room is not kept: asked again, there may be room)
            self._last[key] = (seq, opcode, now, replies)
            self._last.move_to_end(key)
            while len(self._last) > _KEPT_REPLIES:
                self._last.popitem(last=False)
        self._tokens -= len(replies)
        self._deliver(replies, sysid, compid)

    def _on_session(
        self, s: _Session, head: tuple[int, int, int, int], size: int, field: bytes, idle_s: float
    ) -> list[bytes]:
        opcode = head[2]
        if opcode in (OP_OPEN_RO, OP_CREATE, OP_OPEN_WO):
            if opcode == OP_OPEN_RO and s.content is not None and idle_s > SESSION_TIMEOUT_S:
                s.close()  # as ArduPilot: its ground station timed out on the open's reply
            return [self._open(s, head, size, field)]
        if not s.open:
            return [self._nak(head, ERR_FILE_NOT_FOUND)]  # no file open on the session
        if opcode == OP_WRITE:
            return [self._write(s, head, field[:size])]
        if s.content is None:
            return [self._nak(head, ERR_FAIL)]  # a read on a file open for writing
        if opcode == OP_READ:
            return [self._read(s, head, size)]
        # a burst: as many replies now as the ration has (at least one), the rest as it refills
        s.burst = _Burst(head[0], head[3], size or DATA_BYTES)  # (one under way before: replaced)
        return self._burst(s, int(self._tokens))

    def _open(self, s: _Session, head: tuple[int, int, int, int], size: int, data: bytes) -> bytes:
        """OpenFileRO, CreateFile or OpenFileWO: one file a session; its name checked as
        ArduPilot's ``check_name_len``; a read takes the file whole now."""
        if s.open:
            return self._nak(head, ERR_FAIL)
        name = _name(size, data)
        if name is None:
            return self._nak(head, ERR_INVALID_DATA_SIZE)
        path, _, query = name.lstrip("/").partition("?")
        f = self.files.get(path)
        if f is None or ("?" in name and not f.options):
            return self._nak(head, ERR_FILE_NOT_FOUND)
        if head[2] != OP_OPEN_RO:
            if f.write is None:
                return self._nak(head, ERR_FAIL_ERRNO, errno.EACCES)
            s.path, s.file, s.written = path, f, bytearray()
            return self._reply(head, ACK)
        try:
            content = f.read(query)
        except ReadFails as exc:  # opened all the same (ArduPilot's open takes it); its reads fail
            self._say(f"FTP: {name} cannot be read: {exc}")
            s.path, s.file, s.content, s.fails = path, f, b"", exc
            if f.on_open is not None:
                f.on_open()
            return self._reply(head, ACK, struct.pack("<I", exc.size))
        except ValueError as exc:
            self._say(f"FTP: {name} not read: {exc}")
            return self._nak(head, ERR_FAIL_ERRNO, errno.EINVAL)
        s.path, s.file, s.content = path, f, content
        if f.on_open is not None:
            f.on_open()
        return self._reply(head, ACK, struct.pack("<I", len(content)))

    def _read(self, s: _Session, head: tuple[int, int, int, int], size: int) -> bytes:
        offset = head[3]
        if s.fails is not None and offset < s.fails.until:
            return self._nak(head, ERR_FAIL_ERRNO, s.fails.code)
        chunk = (s.content or b"")[offset : offset + size]
        if not chunk:
            return self._nak(head, ERR_END_OF_FILE)
        return self._reply(head, ACK, chunk, offset=offset)

    def _burst(self, s: _Session, packets: int) -> list[bytes]:
        """The next ``packets`` replies (at least one) of the burst under way on ``s``: the
        file from the offset asked for in replies of the size asked for, each with the next
        sequence number, until EndOfFile at the end or :data:`BURST_PACKETS` replies, the
        last marked ``burst_complete`` (the burst is then over: ``s.burst`` None)."""
        b = s.burst
        out: list[bytes] = []
        while b is not None and len(out) < max(1, packets):
            h = (b.seq + b.sent, s.key[2], OP_BURST, b.offset)
            chunk = (s.content or b"")[b.offset : b.offset + b.size]
            if s.fails is not None and b.offset < s.fails.until:
                out.append(self._nak(h, ERR_FAIL_ERRNO, s.fails.code, burst=True))
            elif not chunk:
                out.append(self._nak(h, ERR_END_OF_FILE, burst=True))
            else:
                b.sent += 1
                out.append(self._reply(h, ACK, chunk, offset=b.offset, burst=b.sent == BURST_PACKETS))
                b.offset += len(chunk)
                if b.sent < BURST_PACKETS:
                    continue
            s.burst = b = None  # its last reply sent
        return out

    def _write(self, s: _Session, head: tuple[int, int, int, int], data: bytes) -> bytes:
        if s.written is None:
            return self._nak(head, ERR_FAIL)  # a write on a file open for reading
        offset = head[3]
        if offset + len(data) > MAX_WRITE_BYTES:
            return self._nak(head, ERR_FAIL_ERRNO, errno.ENOSPC)
        if len(s.written) < offset + len(data):
            s.written.extend(bytes(offset + len(data) - len(s.written)))
        s.written[offset : offset + len(data)] = data
        return self._reply(head, ACK, offset=offset)

    def _finish(self, s: _Session) -> str | None:
        """Close the session; a written file is handed over (why it was refused, or None)."""
        written, f, path = s.written, s.file, s.path
        s.close()
        if written is None or f is None or f.write is None:
            return None
        sysid, compid, _ = s.key
        why = f.write(bytes(written), sysid, compid)
        if why is not None:
            self._say(f"FTP: {path} refused: {why}")
        return why

    def _list(self, head: tuple[int, int, int, int], size: int, data: bytes) -> bytes:
        """ListDirectory: from the entry the offset names, as many as fit ("F<name>\\t<size>"
        for a file, "D<name>" for a directory, each ending in a NUL); none left: EndOfFile."""
        name = _name(size, data)
        if name is None:
            return self._nak(head, ERR_INVALID_DATA_SIZE)
        entries = self._entries(name.strip("/"))
        if entries is None:
            return self._nak(head, ERR_FILE_NOT_FOUND)
        out = b""
        for entry in entries[head[3] :]:
            if len(out) + len(entry) >= DATA_BYTES:  # as ArduPilot's list_dir: never the whole field
                break
            out += entry
        if not out:
            return self._nak(head, ERR_END_OF_FILE)
        return self._reply(head, ACK, out, offset=head[3])

    def _entries(self, directory: str) -> list[bytes] | None:
        """A directory's entries, or None when there is no such directory."""
        if directory == "":
            return [f"D{d}\0".encode() for d in dict.fromkeys(p.split("/")[0] for p in self.files)]
        out = []
        for path, f in self.files.items():
            folder, _, base = path.rpartition("/")
            if folder == directory:
                out.append(f"F{base}\t{_size(f)}\0".encode())
        return out or None

    def _crc(self, head: tuple[int, int, int, int], size: int, data: bytes) -> bytes:
        name = _name(size, data)
        if name is None:
            return self._nak(head, ERR_INVALID_DATA_SIZE)
        f = self.files.get(name.lstrip("/"))
        if f is None:
            return self._nak(head, ERR_FILE_NOT_FOUND)
        return self._reply(head, ACK, struct.pack("<I", ardupilot_crc32(f.read(""))))

    # -- sessions and replies ----------------------------------------------------------------
    def _session(self, key: tuple[int, int, int], now: float) -> _Session | None:
        """The session ``key`` names, opened if new: in a free slot, or one idle for
        :data:`SESSION_TIMEOUT_S` taken over; None when every slot is busy."""
        s = self._sessions.get(key)
        if s is not None:
            return s
        if len(self._sessions) >= MAX_SESSIONS:
            oldest = min(self._sessions.values(), key=lambda x: x.last_s)
            if now - oldest.last_s < SESSION_TIMEOUT_S:
                return None
            self._finish(self._sessions.pop(oldest.key))  # taken over: a written file is handed over
        s = self._sessions[key] = _Session(key, now)
        return s

    def _expire(self, now: float) -> None:
        for k in [k for k, s in self._sessions.items() if now - s.last_s > SESSION_KILL_S]:
            self._finish(self._sessions.pop(k))

    def _deliver(self, replies: list[bytes], sysid: int, compid: int) -> None:
        for r in replies:
            self._send(r, sysid, compid)

    @staticmethod
    def _reply(
        head: tuple[int, int, int, int], opcode: int, data: bytes = b"", offset: int = 0, burst: bool = False
    ) -> bytes:
        seq, session, req, _ = head
        out = _HEADER.pack((seq + 1) & 0xFFFF, session, opcode, len(data), req, int(burst), 0, offset) + data
        return out.ljust(PAYLOAD_BYTES, b"\0")

    def _nak(self, head: tuple[int, int, int, int], error: int, code: int | None = None, burst: bool = False) -> bytes:
        """A NAK; its offset is 0 but for a listing's and a burst's end (as ArduPilot's)."""
        data = bytes([error]) if code is None else bytes([error, code])
        return self._reply(head, NAK, data, offset=head[3] if head[2] == OP_LIST or burst else 0, burst=burst)


def _name(size: int, field: bytes) -> str | None:
    """The path a request names, or None when its size does not match it (ArduPilot's
    ``check_name_len``: the name is measured up to its NUL over the whole data field,
    ``field``, and the size is its length, or one more for its NUL)."""
    if size == 0 or size > DATA_BYTES:
        return None
    name = field.split(b"\0", 1)[0]
    if len(name) != size and not (len(name) == size - 1 and field[size - 1 : size] == b"\0"):
        return None
    return name.decode("utf-8", errors="replace")


def _size(f: FtpFile) -> int:
    """A file's size for a listing (its content now; a file that cannot be read whole: 0)."""
    if f.size is not None:
        return f.size()
    try:
        return len(f.read(""))
    except ValueError:
        return 0
