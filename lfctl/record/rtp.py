"""Live H.264 over RTP/UDP (RFC 6184), as QGroundControl and GStreamer receive it.

:class:`RtpH264Sender` cuts each access unit (Annex B, as
:class:`~lfctl.record.video.H264Encoder` makes it) into NAL units and sends each as one RTP
packet, or in FU-A fragments when it is larger than the payload size; the marker bit closes
each frame, the timestamp is the frame's time on the 90 kHz clock, payload type 96. Sending
never blocks and never fails a run: with nobody listening the datagrams are dropped.
:func:`sdp` describes the stream for players that need a session description (ffplay,
VLC, PyAV).
"""

from __future__ import annotations

import os
import re
import socket
import struct

__all__ = ["PAYLOAD_TYPE", "RtpH264Sender", "nal_units", "sdp"]

from lfctl.video import RTP_CLOCK_HZ as CLOCK_HZ
from lfctl.video import RTP_PAYLOAD_TYPE as PAYLOAD_TYPE
from lfctl.video import sdp

#: RTP payload bytes per datagram: under a 1500-byte Ethernet MTU with IP, UDP and RTP headers
MAX_PAYLOAD = 1400
FU_A = 28
_START = re.compile(b"\x00\x00\x01")


def nal_units(access_unit: bytes) -> list[bytes]:
    """The NAL units of an Annex B byte stream, without their start codes.

    Parameters
    ----------
    access_unit : bytes
        NAL units each behind a 3- or 4-byte start code.
    """
    starts = [m.end() for m in _START.finditer(access_unit)]
    out = []
    for k, s in enumerate(starts):
        end = starts[k + 1] - 3 if k + 1 < len(starts) else len(access_unit)
        nal = access_unit[s:end]
        if k + 1 < len(starts) and nal.endswith(b"\x00"):
            nal = nal[:-1]  # the leading zero of the next 4-byte start code
        if nal:
            out.append(nal)
    return out


class RtpH264Sender:
    """Sends one camera's H.264 as RTP over UDP to ``host:port``.

    Parameters
    ----------
    host : str
        Where the ground station listens (an address or name; an IPv6 address with or
        without the brackets HOST:PORT writes it in, ``[::1]``).
    port : int
        Its UDP port (QGroundControl's default is 5600).
    ssrc : int, optional
        The stream's RTP synchronisation source (default random).

    Raises
    ------
    OSError
        The host cannot be resolved or no UDP socket can be made.
    """

    def __init__(self, host: str, port: int, ssrc: int | None = None) -> None:
        bare = host[1:-1] if host.startswith("[") and host.endswith("]") else host  # [::1], as HOST:PORT writes it
        # an IPv6 address as it is (--video's HOST:PORT and an rtp:// camera take one); a name
        # as IPv4, as before (a receiver on 0.0.0.0 hears nothing sent to localhost's ::1)
        family = socket.AF_INET6 if ":" in bare else socket.AF_INET
        try:
            self.addr = socket.getaddrinfo(bare, port, family, socket.SOCK_DGRAM)[0][4]
        except (OSError, UnicodeError) as exc:
            raise OSError(f"cannot send video to {host}:{port}: {exc}") from exc
        self.sock = socket.socket(family, socket.SOCK_DGRAM)
        self.sock.setblocking(False)
        self.ssrc = int.from_bytes(os.urandom(4), "big") if ssrc is None else ssrc & 0xFFFFFFFF
        self.seq = int.from_bytes(os.urandom(2), "big")
        #: the 90 kHz clock's start, random as RFC 3550 (5.1) asks: two runs' streams do not
        #: look alike to a receiver that keeps state
        self.timestamp0 = int.from_bytes(os.urandom(4), "big")
        #: while True, frames are not sent (a ground station's VIDEO_STOP_STREAMING)
        self.paused = False
        self.packets = 0  # datagrams sent
        self.dropped = 0  # datagrams the socket refused (nobody listening, buffer full)
        self.frames = 0  # access units sent

    def _packet(self, payload: bytes, timestamp: int, marker: bool) -> None:
        header = struct.pack(
            "!BBHII", 0x80, (0x80 if marker else 0) | PAYLOAD_TYPE, self.seq, timestamp & 0xFFFFFFFF, self.ssrc
        )
        self.seq = (self.seq + 1) & 0xFFFF
        try:
            self.sock.sendto(header + payload, self.addr)
            self.packets += 1
        except OSError:  # ECONNREFUSED from a closed port, a full buffer: live video drops, the run goes on
            self.dropped += 1

    def send(self, access_unit: bytes, t_s: float) -> None:
        """Send one frame.

        Parameters
        ----------
        access_unit : bytes
            The frame's NAL units, Annex B.
        t_s : float
            The frame's time, s (its RTP timestamp on the 90 kHz clock, from a random start).
        """
        if self.paused:
            return
        ts = self.timestamp0 + int(round(t_s * CLOCK_HZ))
        nals = nal_units(access_unit)
        for k, nal in enumerate(nals):
            last = k == len(nals) - 1
            if len(nal) <= MAX_PAYLOAD:
                self._packet(nal, ts, last)
                continue
            indicator = (nal[0] & 0xE0) | FU_A
            kind = nal[0] & 0x1F
            body = nal[1:]
            for off in range(0, len(body), MAX_PAYLOAD - 2):
                first, end = off == 0, off + MAX_PAYLOAD - 2 >= len(body)
                fu_header = (0x80 if first else 0) | (0x40 if end else 0) | kind
                self._packet(bytes((indicator, fu_header)) + body[off : off + MAX_PAYLOAD - 2], ts, last and end)
        self.frames += 1

    def close(self) -> None:
        """Close the socket."""
        self.sock.close()
