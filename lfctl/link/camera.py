"""A follower's camera as a MAVLink camera component, so a ground station offers its video.

MAVLink's camera protocol: a camera is its own component (MAV_COMP_ID_CAMERA, 100) of the
vehicle's system, with its own HEARTBEAT (MAV_TYPE_CAMERA). A ground station that hears it
asks, with MAV_CMD_REQUEST_MESSAGE (or the older MAV_CMD_REQUEST_CAMERA_INFORMATION and
MAV_CMD_REQUEST_VIDEO_STREAM_INFORMATION), for CAMERA_INFORMATION (flag HAS_VIDEO_STREAM)
and VIDEO_STREAM_INFORMATION, whose RTPUDP stream's URI is the UDP port it should listen
on (QGroundControl turns ``5600`` into ``udp://0.0.0.0:5600``; QGroundControl 5 then
applies its own UDP URL setting over it, 5600 unless changed). Each request is answered with
a COMMAND_ACK from the camera and, when accepted, the message.

:class:`CameraRouter` puts a camera on a vehicle's link without touching the vehicle's
endpoint: it hands the camera what is addressed to it and passes everything else on.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mav

from lfctl.link.port import pack_next
from lfctl.link.signing import advance_signing_clock, setup_signing

__all__ = ["CAMERA_COMPID", "CameraComponent", "CameraRouter"]

#: MAV_COMP_ID_CAMERA: the first camera of a system
CAMERA_COMPID = mav.MAV_COMP_ID_CAMERA
#: messages a ground station may ask the camera for, by id
_ANSWERS = {
    mav.MAVLINK_MSG_ID_CAMERA_INFORMATION: "camera_information",
    mav.MAVLINK_MSG_ID_VIDEO_STREAM_INFORMATION: "video_stream_information",
    mav.MAVLINK_MSG_ID_VIDEO_STREAM_STATUS: "video_stream_status",
    mav.MAVLINK_MSG_ID_CAMERA_SETTINGS: "camera_settings",
}
#: the older one-message request commands
_LEGACY = {
    mav.MAV_CMD_REQUEST_CAMERA_INFORMATION: mav.MAVLINK_MSG_ID_CAMERA_INFORMATION,
    mav.MAV_CMD_REQUEST_VIDEO_STREAM_INFORMATION: mav.MAVLINK_MSG_ID_VIDEO_STREAM_INFORMATION,
    mav.MAV_CMD_REQUEST_VIDEO_STREAM_STATUS: mav.MAVLINK_MSG_ID_VIDEO_STREAM_STATUS,
    mav.MAV_CMD_REQUEST_CAMERA_SETTINGS: mav.MAVLINK_MSG_ID_CAMERA_SETTINGS,
}


#: the older requests whose param1 says whether to send (1) or not (0)
_LEGACY_ASKED = frozenset((mav.MAV_CMD_REQUEST_CAMERA_INFORMATION, mav.MAV_CMD_REQUEST_CAMERA_SETTINGS))
#: the messages about one stream, whose request names it (0: every stream; this camera has one, 1)
_PER_STREAM = frozenset((mav.MAVLINK_MSG_ID_VIDEO_STREAM_INFORMATION, mav.MAVLINK_MSG_ID_VIDEO_STREAM_STATUS))


def _text(value: str, size: int) -> bytes:
    """A char[size] field's bytes: at most size - 1, so a NUL always ends it (QGroundControl
    reads the stream's name as a C string: a full field ran on into the URI after it)."""
    return value.encode()[: size - 1]


def _message_id(param1: float) -> int | None:
    """The message id MAV_CMD_REQUEST_MESSAGE's param1 asks for; None for one that is not a
    whole number in MAVLink's range (a NaN or an infinity from a peer ends nothing)."""
    if not math.isfinite(param1) or param1 != int(param1) or not 0 <= param1 < 1 << 24:
        return None
    return int(param1)


class CameraComponent:
    """A camera component announcing one RTP/UDP H.264 stream.

    Parameters
    ----------
    sysid : int
        The vehicle's system id (the camera is a component of it).
    send : callable
        ``send(bytes)``: puts one packed packet on the vehicle's link.
    video_port : int
        The UDP port the stream is sent to (the ground station listens there).
    width, height : int
        The stream's frame size, pixels.
    fps : float
        Its frame rate, Hz.
    bitrate_kbps : int
        Its target bitrate, kbit/s.
    hfov_deg : float
        The camera's horizontal field of view, degrees.
    name : str
        The stream's and the camera's name (model name), e.g. the follower's.
    compid : int
        The camera's component id (default MAV_COMP_ID_CAMERA, 100).
    signing_key : bytes, optional
        MAVLink 2 signing key: sign what the camera sends.
    tap : callable, optional
        Sees every packet the camera sends or is handed: ``tap(direction, msg, raw)`` (the
        recorder; ``tap("out", msg, raw, to)`` for an answer sent to one peer alone).
    send_to : callable, optional
        ``send_to(bytes, (host, port))``: one peer alone. Given, the answers to a request
        whose sender :meth:`handle` is told of go to that sender alone, as a Rover's routing
        sends a message addressed to one system and component only where it learnt it.
    """

    def __init__(
        self,
        sysid: int,
        send: Callable[[bytes], None],
        *,
        video_port: int,
        width: int,
        height: int,
        fps: float,
        bitrate_kbps: int,
        hfov_deg: float,
        name: str,
        compid: int = CAMERA_COMPID,
        signing_key: bytes | None = None,
        tap: Callable[..., None] | None = None,
        send_to: Callable[[bytes, tuple[str, int]], None] | None = None,
    ) -> None:
        self.sysid, self.compid = sysid, compid
        self._send_raw = send
        self._send_to = send_to
        self._reply_to: tuple[str, int] | None = None  # the sender of the request in hand
        self.video_port = video_port
        self.width, self.height, self.fps = width, height, fps
        self.bitrate_kbps, self.hfov_deg, self.name = bitrate_kbps, hfov_deg, name
        self.tap = tap
        self.mav = mav.MAVLink(None, srcSystem=sysid, srcComponent=compid)
        if signing_key is not None:
            setup_signing(self.mav, signing_key)
        self.t_s = 0.0
        self._heartbeat_at = -math.inf
        self.requests = 0  # requests answered (accepted or not)
        #: the stream is sent (VIDEO_STOP_STREAMING stops it, VIDEO_START_STREAMING starts it)
        self.streaming = True
        #: told of each start and stop (the stream's sender pauses)
        self.on_streaming: Callable[[bool], None] | None = None

    def _send(self, msg: Any) -> None:
        if self.mav.signing.sign_outgoing:
            # its clock follows the wall clock: this codec reads nothing that would move it,
            # and a receiver takes a new signed stream only within a minute of its own clock
            advance_signing_clock(self.mav.signing, time.time())
        data = pack_next(msg, self.mav)
        to = self._reply_to
        if to is not None and self._send_to is not None:
            self._send_to(data, to)
            if self.tap is not None:
                self.tap("out", msg, data, to)
            return
        self._send_raw(data)
        if self.tap is not None:
            self.tap("out", msg, data)

    def tick(self, t_s: float) -> None:
        """Send the camera's HEARTBEAT when a second has passed since the last one.

        Parameters
        ----------
        t_s : float
            The vehicle's clock (the run's simulation time), s.
        """
        self.t_s = t_s
        if t_s - self._heartbeat_at >= 1.0:
            self._heartbeat_at = t_s
            self._send(
                mav.MAVLink_heartbeat_message(
                    mav.MAV_TYPE_CAMERA, mav.MAV_AUTOPILOT_INVALID, 0, 0, mav.MAV_STATE_ACTIVE, 3
                )
            )

    def wants(self, m: Any) -> bool:
        """Whether a received message is a command for this camera (to it, or to every
        component of its system and about the camera's messages).

        Parameters
        ----------
        m : pymavlink message
            Any received message.
        """
        if m.get_type() not in ("COMMAND_LONG", "COMMAND_INT") or m.target_system not in (0, self.sysid):
            return False
        if m.target_component == self.compid:
            return True
        return m.target_component == 0 and (
            m.command in _LEGACY or (m.command == mav.MAV_CMD_REQUEST_MESSAGE and _message_id(m.param1) in _ANSWERS)
        )

    def handle(self, m: Any, sender: tuple[str, int] | None = None) -> None:
        """Answer a command :meth:`wants`: COMMAND_ACK, then the message asked for.

        Parameters
        ----------
        m : pymavlink message
            COMMAND_LONG or COMMAND_INT for the camera.
        sender : (host, port), optional
            Where it came from: the answers go there alone (with ``send_to``).
        """
        self._reply_to = sender
        try:
            self._handle(m)
        finally:
            self._reply_to = None

    def _handle(self, m: Any) -> None:
        if self.tap is not None:
            self.tap("in", m, bytes(m.get_msgbuf()))
        self.requests += 1
        if m.command in (mav.MAV_CMD_VIDEO_START_STREAMING, mav.MAV_CMD_VIDEO_STOP_STREAMING):
            self._start_stop(m)
            return
        if m.command == mav.MAV_CMD_SET_CAMERA_MODE:
            # its one mode (CAMERA_SETTINGS says VIDEO): asked for, nothing to do; another is
            # not one it has (MAVSDK's set_mode(VIDEO) was refused by a camera in VIDEO mode)
            result = mav.MAV_RESULT_ACCEPTED if m.param2 == mav.CAMERA_MODE_VIDEO else mav.MAV_RESULT_DENIED
            self._ack(m, result)
            return
        msg_id, which = _LEGACY.get(m.command), m.param1  # (the older commands: the stream, or whether to send)
        if m.command == mav.MAV_CMD_REQUEST_MESSAGE:
            msg_id, which = _message_id(m.param1), m.param2
        answer = _ANSWERS.get(msg_id) if msg_id is not None else None
        if answer is None:
            self._ack(m, mav.MAV_RESULT_UNSUPPORTED)
            return
        if (msg_id in _PER_STREAM or m.command in _LEGACY_ASKED) and which not in (0.0, 1.0):
            # a stream this camera does not have (MAVLink: 0 every stream, 1 the first), or
            # neither "send" (1) nor "do not" (0): nothing sent
            self._ack(m, mav.MAV_RESULT_DENIED)
            return
        self._ack(m, mav.MAV_RESULT_ACCEPTED)
        if m.command in _LEGACY_ASKED and which == 0.0:
            return  # MAVLink's "no request": answered, nothing sent
        if answer == "camera_information":
            # a ground station finding the camera (its discovery starts with this request:
            # QGroundControl started again after its VIDEO_STOP_STREAMING) wants its video,
            # and sends no START to a camera it has just found
            self.resume()
        self._send(getattr(self, f"_{answer}")())

    def resume(self) -> None:
        """Stream again (told to :attr:`on_streaming`), if stopped."""
        if not self.streaming:
            self.streaming = True
            if self.on_streaming is not None:
                self.on_streaming(True)

    def _start_stop(self, m: Any) -> None:
        """VIDEO_START_STREAMING / VIDEO_STOP_STREAMING (QGroundControl's as a vehicle is
        chosen or left): param1 is the stream, 1 (the only one) or 0 (all); another is DENIED."""
        if m.param1 not in (0.0, 1.0):
            result = mav.MAV_RESULT_DENIED
        else:
            result = mav.MAV_RESULT_ACCEPTED
            self.streaming = m.command == mav.MAV_CMD_VIDEO_START_STREAMING
            if self.on_streaming is not None:
                self.on_streaming(self.streaming)
        self._ack(m, result)

    def _ack(self, m: Any, result: int) -> None:
        """COMMAND_ACK of the command ``m`` to its sender."""
        self._send(mav.MAVLink_command_ack_message(m.command, result, 0, 0, m.get_srcSystem(), m.get_srcComponent()))

    def _camera_information(self) -> Any:
        vendor = list(_text("lfctl", 32).ljust(32, b"\0"))
        model = list(_text(self.name, 32).ljust(32, b"\0"))
        return mav.MAVLink_camera_information_message(
            int(self.t_s * 1000) & 0xFFFFFFFF,
            vendor,
            model,
            0,
            float("nan"),  # focal length and sensor size unknown: NaN, as the message allows
            float("nan"),
            float("nan"),
            self.width,
            self.height,
            0,
            mav.CAMERA_CAP_FLAGS_HAS_VIDEO_STREAM,
            0,
            b"",
        )

    def _stream(self) -> tuple[float, int, int, int, int, int]:
        """What VIDEO_STREAM_INFORMATION and _STATUS both say: frame rate, size, bitrate
        (bit/s), rotation, horizontal field of view (deg)."""
        return float(self.fps), self.width, self.height, self.bitrate_kbps * 1000, 0, int(round(self.hfov_deg))

    def _video_stream_information(self) -> Any:
        return mav.MAVLink_video_stream_information_message(
            1,
            1,
            mav.VIDEO_STREAM_TYPE_RTPUDP,
            self._flags(),
            *self._stream(),
            _text(self.name, 32),
            str(self.video_port).encode(),  # RTPUDP: the URI is the port the ground station listens on
            mav.VIDEO_STREAM_ENCODING_H264,
        )

    def _video_stream_status(self) -> Any:
        return mav.MAVLink_video_stream_status_message(1, self._flags(), *self._stream())

    def _flags(self) -> int:
        return mav.VIDEO_STREAM_STATUS_FLAGS_RUNNING if self.streaming else 0

    def _camera_settings(self) -> Any:
        return mav.MAVLink_camera_settings_message(
            int(self.t_s * 1000) & 0xFFFFFFFF, mav.CAMERA_MODE_VIDEO, float("nan"), float("nan")
        )


class CameraRouter:
    """A vehicle's link with camera components on it: commands addressed to a camera go to
    it, everything else to whoever reads the link (the vehicle's endpoint), unchanged.
    ``send`` and ``accept_peer`` are the inner link's.

    Only datagrams from the network are looked at (in-memory ones pass straight on).

    Parameters
    ----------
    inner : DatagramLink
        The vehicle's link (UDP, in memory, or both).
    cameras : list of CameraComponent
        The cameras on it.
    signing_key : bytes, optional
        With MAVLink 2 signing on, only correctly signed commands reach a camera.
    """

    def __init__(self, inner: Any, cameras: list[CameraComponent], signing_key: bytes | None = None) -> None:
        self.inner = inner
        self.cameras = cameras
        self._key = signing_key
        # what goes out, and which senders get answers, is the inner link's business
        self.send = inner.send
        self.accept_peer = inner.accept_peer
        self._parser = self._new_parser()

    def _new_parser(self) -> Any:
        p = mav.MAVLink(None)
        p.robust_parsing = True
        if self._key is not None:
            setup_signing(p, self._key)
        return p

    def recv(self, max_datagrams: int = 256) -> list[tuple[bytes, tuple[str, int]]]:
        """What is waiting on the link, less the commands the cameras took.

        Parameters
        ----------
        max_datagrams : int
            At most this many.
        """
        out = []
        for data, addr in self.inner.recv(max_datagrams):
            if addr[0] == "memory":
                out.append((data, addr))
                continue
            try:
                msgs = self._parser.parse_buffer(data) or []
            except Exception:  # a malformed datagram must not end the run: the endpoint judges it
                msgs = []
                self._parser = self._new_parser()
            rest: list[bytes] = []
            taken = False
            for m in msgs:
                if m.get_type() == "BAD_DATA":
                    continue  # what the parser could not read stays out of a rebuilt datagram
                camera = next((c for c in self.cameras if c.wants(m)), None)
                if camera is None:
                    rest.append(bytes(m.get_msgbuf()))
                else:
                    self.accept_peer(addr)  # a valid command: its sender gets the answer
                    camera.handle(m, addr)
                    taken = True
            if not taken:
                out.append((data, addr))
            elif rest:
                out.append((b"".join(rest), addr))
        return out

    def close(self) -> None:
        """Close the inner link."""
        self.inner.close()
