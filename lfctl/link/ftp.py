"""MAVLink FTP (FILE_TRANSFER_PROTOCOL) answered as a vehicle with no files to serve.

A ground station asks for files over MAVLink FTP before it falls back to other messages:
MAVProxy, for one, first asks for ``@PARAM/param.pck`` and, with no answer, waits about 11 s
before it lists the parameters with PARAM_REQUEST_LIST. lfctl's vehicles keep no files (a
Rover serves its parameters, logs and scripts there), so every request that names a file
is refused at once with FileNotFound, one on a session with InvalidSession, and the session
commands are acknowledged; the ground station then falls back without waiting.

The payload is MAVLink FTP's (``seq_number`` uint16, ``session``, ``opcode``, ``size``,
``req_opcode``, ``burst_complete``, padding, ``offset`` uint32, then data), and each reply
carries the request's sequence number plus one, as ArduPilot's ``GCS_MAVLINK::ftp_worker``.
"""

from __future__ import annotations

import struct

__all__ = ["ACK", "ERR_FILE_NOT_FOUND", "ERR_INVALID_SESSION", "ERR_UNKNOWN_COMMAND", "NAK", "reply"]

#: the reply opcodes
ACK, NAK = 128, 129
#: the errors a NAK carries in its first data byte
ERR_INVALID_SESSION, ERR_UNKNOWN_COMMAND, ERR_FILE_NOT_FOUND = 4, 7, 10
#: TerminateSession, ResetSessions: acknowledged (no session is open)
_SESSION_COMMANDS = frozenset((1, 2))
#: ReadFile, WriteFile, BurstReadFile: on a session that was never opened
_ON_A_SESSION = frozenset((5, 7, 15))
#: ListDirectory .. CalcFileCRC32 but the session ones: each names a file or a directory
_ON_A_PATH = frozenset((3, 4, 6, 8, 9, 10, 11, 12, 13, 14))
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
    if opcode in _SESSION_COMMANDS:
        op, data = ACK, b""
    elif opcode in _ON_A_SESSION:
        op, data = NAK, bytes([ERR_INVALID_SESSION])
    elif opcode in _ON_A_PATH:
        op, data = NAK, bytes([ERR_FILE_NOT_FOUND])
    else:
        op, data = NAK, bytes([ERR_UNKNOWN_COMMAND])
    head = _HEADER.pack((seq + 1) & 0xFFFF, session, op, len(data), opcode, 0, 0, offset)
    return (head + data).ljust(PAYLOAD_BYTES, b"\0")
