"""MAVLink FTP (FILE_TRANSFER_PROTOCOL) answered as a vehicle with no files to serve.

A ground station asks for files over MAVLink FTP before it falls back to other messages:
MAVProxy, for one, first asks for ``@PARAM/param.pck`` and, with no answer, waits about 11 s
before it lists the parameters with PARAM_REQUEST_LIST. lfctl's vehicles keep no files (a
Rover serves its parameters, logs and scripts there), so every request that names a file
is refused at once with FileNotFound (a read or write on a session too: none has a file
open), a command ArduPilot does not know with UnknownCommand, and None and the session
commands are acknowledged, as ArduPilot's ``GCS_FTP`` answers each when it has no file to
serve; the ground station then falls back without waiting.

The payload is MAVLink FTP's (``seq_number`` uint16, ``session``, ``opcode``, ``size``,
``req_opcode``, ``burst_complete``, padding, ``offset`` uint32, then data), and each reply
carries the request's sequence number plus one and its session, with the offset 0 but for
ListDirectory's, as ArduPilot's ``GCS_MAVLINK::ftp_worker``.
"""

from __future__ import annotations

import struct

__all__ = ["ACK", "ERR_FILE_NOT_FOUND", "ERR_UNKNOWN_COMMAND", "NAK", "reply"]

#: the reply opcodes
ACK, NAK = 128, 129
#: the errors a NAK carries in its first data byte
ERR_UNKNOWN_COMMAND, ERR_FILE_NOT_FOUND = 7, 10
#: None, TerminateSession, ResetSessions: acknowledged (no session is open)
_ACKNOWLEDGED = frozenset((0, 1, 2))
#: ListDirectory, OpenFileRO, ReadFile, CreateFile, WriteFile, RemoveFile, CreateDirectory,
#: RemoveDirectory, OpenFileWO, Rename, CalcFileCRC32, BurstReadFile: no such file (reads and
#: writes: no file open on the session)
_NOT_FOUND = frozenset((3, 4, 5, 6, 7, 8, 9, 10, 11, 13, 14, 15))
LIST_DIRECTORY = 3
_HEADER = struct.Struct("<HBBBBBBI")
PAYLOAD_BYTES = 251


def reply(payload: bytes) -> bytes | None:
    """The reply payload to one FILE_TRANSFER_PROTOCOL request's payload; None for a reply
    (an ACK or NAK sent to us) or a payload too short to hold a header.

    Parameters
    ----------
    payload : bytes
        The request's 251-byte payload.
    """
    if len(payload) < _HEADER.size:
        return None
    seq, session, opcode, _size, _req, _burst, _pad, offset = _HEADER.unpack_from(payload)
    if opcode in (ACK, NAK):
        return None
    if opcode in _ACKNOWLEDGED:
        op, data = ACK, b""
    elif opcode in _NOT_FOUND:
        op, data = NAK, bytes([ERR_FILE_NOT_FOUND])
    else:  # TruncateFile, ListDirectoryWithTime and anything newer: unknown to ArduPilot
        op, data = NAK, bytes([ERR_UNKNOWN_COMMAND])
    offset = offset if opcode == LIST_DIRECTORY else 0
    head = _HEADER.pack((seq + 1) & 0xFFFF, session, op, len(data), opcode, 0, 0, offset)
    return (head + data).ljust(PAYLOAD_BYTES, b"\0")
