"""MAVLink FTP: the packed parameter file and the list files by hand, and the server's answer
to each request as ArduPilot's GCS_FTP gives it (sessions, reads, bursts, writes, listings,
CRCs, requests sent again), and to bytes that are no request at all."""

from __future__ import annotations

import errno
import struct
import zlib

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pymavlink.dialects.v20 import ardupilotmega as mav
from pymavlink.mavftp import MAVFTP
from support import list_file

from lfctl.link import ftp
from lfctl.link.mission import MissionItem
from lfctl.link.mission_server import FENCE, MISSION, MissionServer
from lfctl.link.param_server import ParamServer, pack_params, unpack_params
from lfctl.link.params import INT8, INT16, INT32, REAL32, Param

HEADER = struct.Struct("<HBBBBBBI")


def request(
    seq: int, opcode: int, data: bytes = b"", session: int = 0, offset: int = 0, size: int | None = None
) -> bytes:
    n = len(data) if size is None else size
    return (HEADER.pack(seq, session, opcode, n, 0, 0, 0, offset) + data).ljust(251, b"\0")


def parse(reply: bytes) -> tuple[tuple[int, ...], bytes]:
    head = HEADER.unpack_from(reply)
    return head, reply[12 : 12 + head[3]]


class Clock:
    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


class Served:
    """A server over two files (one writable), its replies and texts kept."""

    def __init__(self) -> None:
        self.content = bytes(range(256)) * 3 + b"end"  # 771 bytes
        self.written: list[tuple[bytes, int, int]] = []
        self.refuse: str | None = None
        self.replies: list[tuple[bytes, int, int]] = []
        self.texts: list[str] = []
        self.clock = Clock()
        self.opened = 0
        files = {
            "@SYS/data.bin": ftp.FtpFile(self.read, options=True, on_open=self.on_open),
            "@SYS/in.bin": ftp.FtpFile(lambda q: b"", self.write),
        }
        self.server = ftp.FtpServer(
            files, lambda p, s, c: self.replies.append((p, s, c)), self.texts.append, self.clock
        )

    def read(self, query: str) -> bytes:
        if query:
            raise ValueError(f"no such option, got {query!r}")
        return self.content

    def on_open(self) -> None:
        self.opened += 1

    def write(self, data: bytes, sysid: int, compid: int) -> str | None:
        self.written.append((data, sysid, compid))
        return self.refuse

    def ask(self, payload: bytes, sysid: int = 255, compid: int = 190) -> list[tuple[tuple[int, ...], bytes]]:
        self.replies.clear()
        self.server.handle(payload, sysid, compid)
        assert all(len(p) == 251 and (s, c) == (sysid, compid) for p, s, c in self.replies)
        return [parse(p) for p, _, _ in self.replies]

    def tick(self, after_s: float) -> list[tuple[tuple[int, ...], bytes]]:
        """What the server sends at its tick ``after_s`` later (a burst going on)."""
        self.replies.clear()
        self.clock.t += after_s
        self.server.tick()
        return [parse(p) for p, _, _ in self.replies]


# -- the packed parameter file ---------------------------------------------------------------
TABLE = {
    "WP_SPEED": Param(2.5, 0.0, 100.0, "m/s", ""),
    "WP_RADIUS": Param(2.0, 0.0, 100.0, "m", ""),
    "CRUISE_THROTTLE": Param(50, 0, 100, "%", "", kind=INT8),
}


def test_the_packed_parameter_file_by_hand() -> None:
    out = pack_params(TABLE)
    assert out == (
        b"\x1b\x67\x03\x00\x03\x00"  # magic 0x671b, 3 in the file, 3 in all
        + b"\x04\x70WP_SPEED\x00\x00\x20\x40"  # float; 8 new bytes (7 << 4), none shared; 2.5
        + b"\x04\x53RADIUS\x00\x00\x00\x40"  # "WP_" shared (3), 6 new (5 << 4); 2.0
        + b"\x01\xe0CRUISE_THROTTLE\x32"  # int8; 15 new; 50
    )
    # with defaults: WP_SPEED's (2.0) follows its value (flag 1 in the type's high nibble)
    with_defaults = pack_params(TABLE, {"WP_SPEED": 2.0, "WP_RADIUS": 2.0, "CRUISE_THROTTLE": 50})
    assert with_defaults[:2] == b"\x1c\x67"
    assert with_defaults[6:20] == b"\x14\x70WP_SPEED\x00\x00\x20\x40" and with_defaults[20:24] == b"\x00\x00\x00\x40"
    # start and count, as param.pck?start=1&count=1 asks: one in the file, three in all
    assert pack_params(TABLE, start=1, count=1) == b"\x1b\x67\x01\x00\x03\x00\x04\x80WP_RADIUS\x00\x00\x00\x40"


def test_pymavlink_reads_the_file_as_a_rover_s() -> None:
    # pymavlink's own decoder (MAVProxy's is the same code), a name that is the start of
    # the one before included (one byte of it is told again)
    table = dict(TABLE) | {
        "LFC_RANGE2": Param(-3.25, -10, 10, "", ""),
        "LFC_RANGE": Param(7, 0, 20, "", "", kind=INT16),
        "LFC_BIG": Param(-70000, -1e6, 1e6, "", "", kind=INT32),
    }
    data = pack_params(table, {name: 0.0 for name in table})
    decoded = MAVFTP.ftp_param_decode(data)
    assert decoded is not None
    assert {n.decode(): v for n, v, _ in decoded.params} == {n: p.value for n, p in table.items()}
    assert {n.decode(): v for n, v, _ in decoded.defaults} == dict.fromkeys(table, 0.0)
    assert [t for _, _, t in decoded.params] == [4, 4, 1, 4, 2, 3]


@settings(max_examples=60, deadline=None)
@given(
    st.dictionaries(
        st.text("ABCDEFGHIJKLMNOPQRSTUVWXYZ_0123456789", min_size=1, max_size=16),
        st.tuples(st.sampled_from([INT8, INT16, INT32, REAL32]), st.integers(-100, 100)),
        min_size=1,
        max_size=40,
    )
)
def test_any_table_comes_back_whole_through_pymavlink(raw: dict[str, tuple[int, int]]) -> None:
    table = {name: Param(float(v), -1000, 1000, "", "", kind=kind) for name, (kind, v) in raw.items()}
    decoded = MAVFTP.ftp_param_decode(pack_params(table))
    assert decoded is not None
    assert [(n.decode(), v) for n, v, _ in decoded.params] == [(n, p.value) for n, p in table.items()]
    # and an upload of the same (its header's third number is the file's length) reads back
    data = bytearray(pack_params(table))
    struct.pack_into("<H", data, 4, len(data))
    assert unpack_params(bytes(data)) == [(n, p.value) for n, p in table.items()]


@pytest.mark.parametrize(
    ("damage", "words"),
    [
        (lambda d: b"\x1c" + d[1:], "magic 0x671c"),  # an upload carries no defaults
        (lambda d: d[:4] + b"\x09\x00" + d[6:], "length as 9"),
        (lambda d: d[:6] + b"\x14" + d[7:], "flags 1"),
        (lambda d: d[:6] + b"\x07" + d[7:], "type 7"),
        (lambda d: d[:6] + b"\x04\x7f" + d[8:], r"a name of 15 \+ 8 bytes"),
        (lambda d: d[:3], "3 bytes"),
    ],
)
def test_a_damaged_upload_is_refused_naming_the_fault(damage, words: str) -> None:
    data = bytearray(pack_params(TABLE))
    struct.pack_into("<H", data, 4, len(data))
    with pytest.raises(ValueError, match=words):
        unpack_params(damage(bytes(data)))


def test_an_uploaded_file_sets_what_a_param_set_would_and_names_the_rest() -> None:
    table = {name: Param(p.value, p.lo, p.hi, p.unit, p.description, kind=p.kind) for name, p in TABLE.items()}
    said: list[str] = []
    server = ParamServer(table, lambda m: None, lambda text, severity: said.append(text))
    upload = {
        "WP_SPEED": Param(4.0, 0, 100, "", ""),
        "WP_RADIUS": Param(500.0, 0, 1000, "", ""),  # outside 0..100
        "NO_SUCH": Param(1.0, 0, 10, "", ""),
    }
    data = bytearray(pack_params(upload))
    struct.pack_into("<H", data, 4, len(data))
    assert server.upload(bytes(data)) is None
    assert (table["WP_SPEED"].value, table["WP_RADIUS"].value) == (4.0, 2.0)
    # one line however many were refused (a file may name thousands), with what was not set
    assert said == ["Param upload: 1 of 3 set; refused WP_RADIUS (500); no such parameter NO_SUCH"]
    assert server.upload(b"\x1b\x67") == "param.pck not read: 2 bytes, fewer than the header's 6"
    assert table["WP_SPEED"].value == 4.0
    # the defaults are the values the table had when the server was made
    assert server.defaults == {"WP_SPEED": 2.5, "WP_RADIUS": 2.0, "CRUISE_THROTTLE": 50}


@pytest.mark.parametrize(
    ("query", "words"),
    [
        ("start=3", "start=3: there are 3"),
        ("withdefaults=2", "out of range"),
    ],
)
def test_param_file_options_ardupilot_refuses_are_named(query: str, words: str) -> None:
    server = ParamServer(dict(TABLE), lambda m: None, lambda text, severity: None)
    with pytest.raises(ValueError, match=words):
        server.packed(query)
    assert server.packed("withdefaults=1&start=2")[:6] == b"\x1c\x67\x01\x00\x03\x00"


# -- the server --------------------------------------------------------------------------
def test_a_file_is_opened_read_in_parts_and_closed() -> None:
    s = Served()
    ((head, data),) = s.ask(request(10, ftp.OP_OPEN_RO, b"@SYS/data.bin", session=2))
    # seq + 1, the session, ACK, 4 bytes (the size), the request's opcode
    assert head[:5] == (11, 2, ftp.ACK, 4, ftp.OP_OPEN_RO) and struct.unpack("<I", data) == (771,)
    ((head, data),) = s.ask(request(11, ftp.OP_READ, session=2, offset=700, size=239))
    assert head[2] == ftp.ACK and head[7] == 700 and data == s.content[700:]
    ((head, data),) = s.ask(request(12, ftp.OP_READ, session=2, offset=771, size=239))
    assert (head[2], data) == (ftp.NAK, bytes([ftp.ERR_END_OF_FILE]))
    ((head, _),) = s.ask(request(13, ftp.OP_TERMINATE, session=2))
    assert head[2] == ftp.ACK
    ((head, data),) = s.ask(request(14, ftp.OP_READ, session=2, size=10))
    assert (head[2], data) == (ftp.NAK, bytes([ftp.ERR_FILE_NOT_FOUND]))  # no file open on it now


def test_a_burst_sends_the_file_in_numbered_parts_and_ends_at_its_end() -> None:
    s = Served()
    s.ask(request(0, ftp.OP_OPEN_RO, b"@SYS/data.bin"))
    replies = s.ask(request(1, ftp.OP_BURST, offset=100, size=200))
    assert [h[0] for h, _ in replies] == [2, 3, 4, 5, 6]  # one sequence number each
    assert [h[7] for h, _ in replies] == [100, 300, 500, 700, 771]
    assert b"".join(d for h, d in replies if h[2] == ftp.ACK) == s.content[100:]
    last_head, last = replies[-1]
    assert (last_head[2], last, last_head[5]) == (ftp.NAK, bytes([ftp.ERR_END_OF_FILE]), 1)  # burst complete
    # a long file of 300 x 239 bytes, one burst: what the ration has at once, the rest as it
    # refills (GCS_FTP's burst waits for room on the link), only the very last marked complete
    s.content = bytes(300 * ftp.DATA_BYTES)
    s.ask(request(0, ftp.OP_RESET))
    s.ask(request(1, ftp.OP_OPEN_RO, b"@SYS/data.bin", session=1))
    # 256 at once, less the 6 replies so far and the reset's and the open's: 248
    replies = s.ask(request(2, ftp.OP_BURST, session=1))
    assert len(replies) == 248 and all(h[2] == ftp.ACK and h[5] == 0 for h, _ in replies)
    assert (replies[0][0][0], replies[-1][0][0], replies[-1][0][7]) == (3, 250, 247 * 239)
    assert s.tick(0.0) == []  # the ration spent: nothing more yet
    # 0.125 s later: 400 a second, 50 more, the parts from 248 to 297
    more = s.tick(0.125)
    assert [h[7] // 239 for h, _ in more] == list(range(248, 298)) and all(h[5] == 0 for h, _ in more)
    # another 0.125 s: the last 2 parts and the end, EndOfFile marked complete (sequence 3 + 300)
    rest = s.tick(0.125)
    assert [len(d) for _, d in rest] == [239, 239, 1] and [h[5] for h, _ in rest] == [0, 0, 1]
    assert (rest[-1][0][0], rest[-1][0][2], rest[-1][1]) == (303, ftp.NAK, bytes([ftp.ERR_END_OF_FILE]))
    assert s.tick(1.0) == []  # over


def test_a_request_sent_again_gets_the_same_reply_not_a_second_action() -> None:
    s = Served()
    s.refuse = "item 1: MAV_MISSION_INVALID_PARAM5_X"
    s.ask(request(0, ftp.OP_CREATE, b"@SYS/in.bin\0"))  # the name with its NUL, as MAVProxy sends it
    s.ask(request(1, ftp.OP_WRITE, b"hello", offset=3))
    first = s.ask(request(2, ftp.OP_TERMINATE))
    assert first[0][0][2] == ftp.NAK and first[0][1] == bytes([ftp.ERR_FAIL_ERRNO, errno.EINVAL])
    assert s.written == [(b"\0\0\0hello", 255, 190)]
    assert s.texts == ["FTP: @SYS/in.bin refused: item 1: MAV_MISSION_INVALID_PARAM5_X"]
    assert s.ask(request(2, ftp.OP_TERMINATE)) == first  # its reply lost: the refusal again
    assert len(s.written) == 1
    # another sender's same numbers are its own
    assert s.ask(request(2, ftp.OP_TERMINATE), sysid=254)[0][0][2] == ftp.ACK


@pytest.mark.parametrize(
    ("opcode", "data", "error"),
    [
        (ftp.OP_OPEN_RO, b"@PARAM/none.pck", ftp.ERR_FILE_NOT_FOUND),
        (ftp.OP_OPEN_RO, b"", ftp.ERR_INVALID_DATA_SIZE),
        (ftp.OP_CRC, b"APM/LOGS/1.BIN", ftp.ERR_FILE_NOT_FOUND),
        (ftp.OP_LIST, b"APM/LOGS", ftp.ERR_FILE_NOT_FOUND),
        (ftp.OP_READ, b"", ftp.ERR_FILE_NOT_FOUND),  # no file open on the session
        (ftp.OP_BURST, b"", ftp.ERR_FILE_NOT_FOUND),
        (ftp.OP_WRITE, b"x", ftp.ERR_FILE_NOT_FOUND),
        (ftp.OP_REMOVE, b"@SYS/data.bin", ftp.ERR_FILE_NOT_FOUND),  # nothing can be removed
        (ftp.OP_RENAME, b"@SYS/data.bin\0x", ftp.ERR_FILE_NOT_FOUND),
        (ftp.OP_TRUNCATE, b"@SYS/data.bin", ftp.ERR_UNKNOWN_COMMAND),  # ArduPilot has none
        (16, b"/", ftp.ERR_UNKNOWN_COMMAND),  # ListDirectoryWithTime: MAVProxy falls back to 3
        (99, b"", ftp.ERR_UNKNOWN_COMMAND),
    ],
)
def test_what_is_not_here_is_refused_at_once(opcode: int, data: bytes, error: int) -> None:
    s = Served()
    ((head, answer),) = s.ask(request(0xFFFF, opcode, data, session=3, offset=12))
    # the sequence wraps; the offset only a listing's, as ArduPilot's setup_reply
    assert head[:3] == (0, 3, ftp.NAK) and head[4] == opcode and answer == bytes([error])
    assert head[7] == (12 if opcode == ftp.OP_LIST else 0)


def test_one_file_a_session_a_read_only_file_and_a_read_on_a_written_one() -> None:
    s = Served()
    s.ask(request(0, ftp.OP_OPEN_RO, b"@SYS/data.bin"))
    assert s.ask(request(1, ftp.OP_OPEN_RO, b"@SYS/data.bin"))[0][1] == bytes([ftp.ERR_FAIL])
    assert s.ask(request(2, ftp.OP_WRITE, b"x"))[0][1] == bytes([ftp.ERR_FAIL])  # open for reading
    assert s.ask(request(3, ftp.OP_CREATE, b"@SYS/data.bin", session=1))[0][1] == bytes(
        [ftp.ERR_FAIL_ERRNO, errno.EACCES]
    )
    s.ask(request(4, ftp.OP_OPEN_WO, b"@SYS/in.bin", session=1))
    assert s.ask(request(5, ftp.OP_READ, session=1, size=5))[0][1] == bytes([ftp.ERR_FAIL])
    too_far = s.ask(request(6, ftp.OP_WRITE, b"x", session=1, offset=ftp.MAX_WRITE_BYTES))
    assert too_far[0][1] == bytes([ftp.ERR_FAIL_ERRNO, errno.ENOSPC])
    # a ground station that timed out on its open's reply may open again after 3 s
    s.clock.t += ftp.SESSION_TIMEOUT_S + 0.1
    assert s.ask(request(7, ftp.OP_OPEN_RO, b"@SYS/data.bin"))[0][0][2] == ftp.ACK


def test_sessions_are_limited_and_idle_ones_taken_over_or_closed() -> None:
    s = Served()
    for k in range(ftp.MAX_SESSIONS):
        assert s.ask(request(0, ftp.OP_OPEN_RO, b"@SYS/data.bin", session=k))[0][0][2] == ftp.ACK
    assert s.ask(request(0, ftp.OP_OPEN_RO, b"@SYS/data.bin", session=9))[0][1] == bytes([ftp.ERR_NO_SESSIONS])
    s.clock.t += ftp.SESSION_TIMEOUT_S + 0.1  # every session idle: the oldest is taken over
    assert s.ask(request(1, ftp.OP_OPEN_RO, b"@SYS/data.bin", session=9))[0][0][2] == ftp.ACK
    s.clock.t += ftp.SESSION_KILL_S + 0.1  # all closed: a read finds no file open
    assert s.ask(request(2, ftp.OP_READ, session=9, size=4))[0][1] == bytes([ftp.ERR_FILE_NOT_FOUND])
    # ResetSessions closes the sender's sessions; a file written is handed over, as
    # ArduPilot's close hands it over (one not written whole is refused by its own checks)
    s.ask(request(3, ftp.OP_CREATE, b"@SYS/in.bin", session=5))
    s.ask(request(4, ftp.OP_WRITE, b"abc", session=5))
    assert s.ask(request(5, ftp.OP_RESET))[0][0][2] == ftp.ACK and s.written == [(b"abc", 255, 190)]
    assert s.ask(request(6, ftp.OP_TERMINATE, session=5))[0][0][2] == ftp.ACK and len(s.written) == 1


def test_a_written_file_whose_terminate_was_lost_is_handed_over_when_its_session_closes() -> None:
    # pymavlink's put sends TerminateSession once: lost, the file is not lost with it
    s = Served()
    s.ask(request(0, ftp.OP_CREATE, b"@SYS/in.bin", session=1))
    s.ask(request(1, ftp.OP_WRITE, b"whole", session=1))
    s.clock.t += ftp.SESSION_KILL_S - 1
    s.server.tick()
    assert s.written == []  # not yet: its ground station may still close it
    s.clock.t += 2
    s.server.tick()  # idle for SESSION_KILL_S: closed, handed over
    assert s.written == [(b"whole", 255, 190)]
    # taken over by another session while every slot is busy (and this one idle)
    s.ask(request(2, ftp.OP_CREATE, b"@SYS/in.bin", session=2))
    s.ask(request(3, ftp.OP_WRITE, b"next", session=2))
    for k in range(3, 3 + ftp.MAX_SESSIONS - 1):
        s.ask(request(0, ftp.OP_OPEN_RO, b"@SYS/data.bin", session=k))
    s.clock.t += ftp.SESSION_TIMEOUT_S + 0.1
    s.refuse = "not whole"
    s.ask(request(0, ftp.OP_OPEN_RO, b"@SYS/data.bin", session=9))
    assert s.written[-1] == (b"next", 255, 190) and s.texts == ["FTP: @SYS/in.bin refused: not whole"]


def test_a_reply_is_sent_again_only_while_fresh_and_a_refusal_for_want_of_room_never() -> None:
    s = Served()
    first = s.ask(request(1, ftp.OP_CRC, b"@SYS/data.bin"))
    s.content = b"changed"
    assert s.ask(request(1, ftp.OP_CRC, b"@SYS/data.bin")) == first  # sent again at once: the same reply
    s.clock.t += ftp.SESSION_TIMEOUT_S + 0.1
    again = s.ask(request(1, ftp.OP_CRC, b"@SYS/data.bin"))  # long after: a new request, answered anew
    assert struct.unpack("<I", again[0][1]) == (ftp.ardupilot_crc32(b"changed"),)
    for k in range(ftp.MAX_SESSIONS):
        s.ask(request(0, ftp.OP_OPEN_RO, b"@SYS/data.bin", session=k))
    assert s.ask(request(7, ftp.OP_OPEN_RO, b"@SYS/data.bin", session=9))[0][1] == bytes([ftp.ERR_NO_SESSIONS])
    s.clock.t += ftp.SESSION_TIMEOUT_S + 0.1
    assert s.ask(request(7, ftp.OP_OPEN_RO, b"@SYS/data.bin", session=9))[0][0][2] == ftp.ACK  # room now


def test_replies_are_rationed_so_no_peer_can_make_the_vehicle_flood() -> None:
    s = Served()
    s.content = bytes(239 * 1000)
    s.ask(request(0, ftp.OP_OPEN_RO, b"@SYS/data.bin"))
    sent = sum(len(s.ask(request(k, ftp.OP_BURST, offset=0))) for k in range(1, 200))  # all at one instant
    assert sent <= ftp.REPLY_BURST and s.server.unanswered > 0
    # a second later, a burst again (replacing the one under way): the full ration at once, 256,
    # none marked complete: the rest goes on at the ration's pace
    s.clock.t += 1.0
    replies = s.ask(request(500, ftp.OP_BURST, offset=0))
    assert len(replies) == ftp.REPLY_BURST and not any(h[5] for h, _ in replies)
    # over a second, the ration's refill and no more
    total = 0
    for k in range(100):
        s.clock.t += 0.01
        total += len(s.ask(request(600 + k, ftp.OP_BURST, offset=0)))
    assert total <= ftp.REPLIES_PER_S * 1.0 + ftp.REPLY_BURST


def test_a_size_past_the_payload_is_refused_as_ardupilot_refuses_it() -> None:
    s = Served()
    s.ask(request(0, ftp.OP_OPEN_RO, b"@SYS/data.bin"))
    assert s.ask(request(1, ftp.OP_READ, size=240))[0][1] == bytes([ftp.ERR_INVALID_DATA_SIZE])
    assert s.ask(request(2, ftp.OP_READ, size=239))[0][0][2] == ftp.ACK and s.opened == 1


def test_directories_list_from_the_offset_and_end_with_end_of_file() -> None:
    s = Served()
    ((head, data),) = s.ask(request(0, ftp.OP_LIST, b"/"))
    assert (head[2], data) == (ftp.ACK, b"D@SYS\0")
    ((head, data),) = s.ask(request(1, ftp.OP_LIST, b"@SYS/"))
    assert data == b"F data.bin\t771\0F in.bin\t0\0".replace(b"F ", b"F")
    ((head, data),) = s.ask(request(2, ftp.OP_LIST, b"@SYS", offset=1))
    assert (head[7], data) == (1, b"Fin.bin\t0\0")
    assert s.ask(request(3, ftp.OP_LIST, b"@SYS", offset=2))[0][1] == bytes([ftp.ERR_END_OF_FILE])


def test_a_crc_is_ardupilots() -> None:
    s = Served()
    ((head, data),) = s.ask(request(0, ftp.OP_CRC, b"@SYS/data.bin"))
    crc = struct.unpack("<I", data)[0]
    assert head[2] == ftp.ACK and crc == ftp.ardupilot_crc32(s.content)

    # ArduPilot's crc_crc32 from a zero seed, bit by bit: the reflected polynomial, no
    # inversions (over "123456789": 0x2dfd2d88, where zlib's CRC-32 is 0xcbf43926)
    def by_bits(data: bytes) -> int:
        c = 0
        for b in data:
            c ^= b
            for _ in range(8):
                c = (c >> 1) ^ (0xEDB88320 if c & 1 else 0)
        return c

    assert by_bits(s.content) == crc and ftp.ardupilot_crc32(b"123456789") == 0x2DFD2D88 != zlib.crc32(b"123456789")


def test_an_option_a_file_cannot_take_is_refused_and_said() -> None:
    s = Served()
    ((head, data),) = s.ask(request(0, ftp.OP_OPEN_RO, b"@SYS/data.bin?x=1"))
    assert (head[2], data) == (ftp.NAK, bytes([ftp.ERR_FAIL_ERRNO, errno.EINVAL]))
    assert s.texts == ["FTP: @SYS/data.bin?x=1 not read: no such option, got 'x=1'"] and s.opened == 0
    # a file that takes no options: the name with them is no such file (ArduPilot compares it whole)
    assert s.ask(request(1, ftp.OP_OPEN_RO, b"@SYS/in.bin?x=1", session=1))[0][1] == bytes([ftp.ERR_FILE_NOT_FOUND])


def test_replies_and_scraps_get_no_answer() -> None:
    s = Served()
    assert s.ask(request(5, ftp.ACK)) == [] and s.ask(request(5, ftp.NAK)) == [] and s.ask(b"\x01\x02") == []


@settings(max_examples=300, deadline=None)
@given(st.lists(st.binary(min_size=0, max_size=260), max_size=12))
def test_any_bytes_are_answered_or_ignored_never_raise(payloads: list[bytes]) -> None:
    s = Served()
    for p in payloads:
        assert all(len(d) <= ftp.DATA_BYTES for _, d in s.ask(p))


# -- the lists as files --------------------------------------------------------------------
LAT, LON = 129_602_000, 776_690_000


def lists() -> tuple[MissionServer, list[tuple[int, list[MissionItem]]], list[str]]:
    changed: list[tuple[int, list[MissionItem]]] = []
    said: list[str] = []
    home = MissionItem(0, 0, 16, x=LAT, y=LON, z=900.0)
    ms = MissionServer(
        lambda m: None, said.append, lambda t, items: changed.append((t, list(items))), home=lambda: home
    )
    return ms, changed, said


def wp(seq: int, north_e7: int = 1000, hold_s: float = 0.0) -> MissionItem:
    return MissionItem(seq, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, 16, hold_s, x=LAT + north_e7, y=LON)


def test_a_list_file_by_hand_and_back() -> None:
    ms, changed, _ = lists()
    assert ms.packed(MISSION) == b"\x3d\x76\x00\x00\x00\x00\x00\x00\x00\x00"  # magic 0x763d, no items
    items = [wp(0), wp(1), wp(2, 2000, hold_s=3.0)]
    assert ms.upload_packed(MISSION, list_file(items), 255, 190, 1.0) is None
    assert [(i.seq, i.x, i.param1) for i in ms.lists[MISSION]] == [
        (0, LAT + 1000, 0.0),
        (1, LAT + 1000, 0.0),
        (2, LAT + 2000, 3.0),
    ]
    assert changed[-1][0] == MISSION and ms.changes[-1].sysid == 255
    data = ms.packed(MISSION)
    assert len(data) == 10 + 3 * 38 == ms.packed_size(MISSION)
    # item 0 is home now (as a download's), its `current` 0 (AP_Mission::get_item: 1 only where
    # the command id equals the navigation command's index, and none is under way)
    unit = mav.MAVLink_mission_item_int_message
    first = dict(zip(unit.ordered_fieldnames, unit.unpacker.unpack(data[10:48]), strict=True))
    assert (first["seq"], first["x"], first["z"], first["current"], first["frame"]) == (0, LAT, 900.0, 0, 0)
    # the no-clear option replaces item 2 and adds item 3, keeping the rest
    assert ms.upload_packed(MISSION, list_file([wp(0, 5000), wp(1, 6000)], options=1, start=2), 255, 190, 2.0) is None
    assert [i.x - LAT for i in ms.lists[MISSION]] == [1000, 1000, 5000, 6000]
    assert ms.changes[-1].edit
    # a whole file written over the mission keeps the item under way, as an upload by the
    # mission protocol does (Rover's upload writes over the old items, nothing reset)
    assert ms.set_current(2)
    assert ms.upload_packed(MISSION, list_file([wp(0), wp(1), wp(2, 7000)]), 255, 190, 3.0) is None
    assert ms.current_seq == 2


@pytest.mark.parametrize(
    ("data", "why"),
    [
        (b"\x3d\x76\x00", "3 bytes, fewer than the header's 10"),
        (b"\x3d\x77" + list_file([wp(0)])[2:], "magic 0x773d"),
        (list_file([wp(0)], mission_type=FENCE), "its header is for list type 1, the file is the mission's (0)"),
        (list_file([wp(0)], options=2), "options 0x2"),
        (list_file([wp(0), wp(1)])[:-1], "the header gives 2 items, the file has 75 bytes after it, not 76"),
        (list_file([wp(0)]) + bytes(38), "the header gives 1 items"),
        (struct.pack("<HHHHH", 0x763D, 0, 0, 0, 1) + bytes(38), "item 0 is all zeros"),
        (list_file([wp(0), wp(1)], start=1), "its first item is 1"),
        (list_file([wp(0), wp(1)], options=1, start=5), "its first item 5 is past the mission's end (0 items)"),
        (list_file([wp(0), MissionItem(1, 3, 16, x=950_000_000, y=LON)]), "item 1: MAV_MISSION_INVALID_PARAM5_X"),
        (list_file([wp(0), wp(1), MissionItem(2, 0, 177, 9, 1)]), "item 2: MAV_MISSION_ERROR"),  # DO_JUMP to 9
    ],
)
def test_a_list_file_the_vehicle_would_not_take_changes_nothing_and_says_why(data: bytes, why: str) -> None:
    ms, changed, _ = lists()
    assert why in (ms.upload_packed(MISSION, data, 255, 190, 1.0) or "")
    assert changed == [] and ms.changes == []


def test_a_fence_file_is_checked_whole_with_rovers_words_and_not_during_another_upload() -> None:
    ms, _, _ = lists()
    v = mav.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION
    tri = [
        MissionItem(k, 0, v, 3, x=LAT + dx, y=LON + dy)
        for k, (dx, dy) in enumerate(((9000, 0), (0, 9000), (-9000, -9000)))
    ]
    assert (
        ms.upload_packed(FENCE, list_file(tri[:2], FENCE), 255, 190, 1.0)
        == "item 1: MAV_MISSION_ERROR (Incorrect item count)"
    )
    assert ms.upload_packed(FENCE, list_file(tri, FENCE, options=1), 255, 190, 1.0) == (
        "the fence is only replaced whole (no clear is for the mission)"
    )
    assert ms.upload_packed(FENCE, list_file(tri, FENCE), 255, 190, 1.0) is None and len(ms.lists[FENCE]) == 3
    ms.on_count(mav.MAVLink_mission_count_message(1, 1, 2, FENCE), 2.0)  # (from "nobody": pymavlink's default ids)
    assert ms.upload_packed(FENCE, list_file(tri, FENCE), 255, 190, 2.0) == (
        "an upload of the fence by the mission protocol is under way"
    )
