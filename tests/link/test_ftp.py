"""MAVLink FTP answered as a vehicle with no files: each request gets its reply at once, with
the request's sequence number plus one, so a ground station falls back without waiting."""

from __future__ import annotations

import struct

import pytest
from hypothesis import given
from hypothesis import strategies as st

from lfctl.link import ftp

HEADER = struct.Struct("<HBBBBBBI")


def request(seq: int, opcode: int, data: bytes = b"", session: int = 0, offset: int = 0) -> bytes:
    return (HEADER.pack(seq, session, opcode, len(data), 0, 0, 0, offset) + data).ljust(251, b"\0")


@pytest.mark.parametrize(
    ("opcode", "answer", "error"),
    [
        (4, ftp.NAK, ftp.ERR_FILE_NOT_FOUND),  # OpenFileRO @PARAM/param.pck: MAVProxy's first ask
        (3, ftp.NAK, ftp.ERR_FILE_NOT_FOUND),  # ListDirectory
        (14, ftp.NAK, ftp.ERR_FILE_NOT_FOUND),  # CalcFileCRC32
        (15, ftp.NAK, ftp.ERR_FILE_NOT_FOUND),  # BurstReadFile: no file open on the session
        (5, ftp.NAK, ftp.ERR_FILE_NOT_FOUND),  # ReadFile
        (12, ftp.NAK, ftp.ERR_UNKNOWN_COMMAND),  # TruncateFile: ArduPilot has none
        (16, ftp.NAK, ftp.ERR_UNKNOWN_COMMAND),  # ListDirectoryWithTime: MAVProxy falls back to 3
        (99, ftp.NAK, ftp.ERR_UNKNOWN_COMMAND),
        (0, ftp.ACK, None),  # None
        (1, ftp.ACK, None),  # TerminateSession
        (2, ftp.ACK, None),  # ResetSessions
    ],
)
def test_each_request_is_answered_at_once(opcode: int, answer: int, error: int | None) -> None:
    out = ftp.reply(request(0xFFFF, opcode, b"@PARAM/param.pck?withdefaults=1", session=3, offset=12))
    assert out is not None and len(out) == 251
    seq, session, op, size, req_opcode, burst, _pad, offset = HEADER.unpack_from(out)
    # the sequence wraps; the offset is ListDirectory's only, as ArduPilot's setup_reply
    assert (seq, session, op, req_opcode, burst, offset) == (0, 3, answer, opcode, 0, 12 if opcode == 3 else 0)
    assert (size, out[12]) == ((1, error) if error is not None else (0, 0))


def test_replies_and_scraps_get_no_answer() -> None:
    assert ftp.reply(request(5, ftp.ACK)) is None
    assert ftp.reply(request(5, ftp.NAK)) is None
    assert ftp.reply(b"\x01\x02") is None


@given(st.binary(max_size=260))
def test_any_bytes_are_answered_or_ignored_never_raise(data: bytes) -> None:
    out = ftp.reply(data)
    assert out is None or len(out) == 251
