"""H.264 for the follower's camera, with PyAV (its wheels ship libx264; no system ffmpeg).

One :class:`H264Encoder` per camera turns BGR frames into access units as Foxglove's
``CompressedVideo`` wants them and an RTP packetizer can send them: Annex B byte stream,
one access unit per frame, no B-frames, SPS and PPS repeated before every keyframe (so a
player can start at any keyframe), a keyframe every ``gop`` frames and no scene-cut ones.
:func:`decode_h264` turns such access units back into frames; :func:`psnr` compares them
with the originals.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import av
import cv2
import numpy as np

from lfctl.errors import ConfigError

__all__ = ["EncodedFrame", "H264Decoder", "H264Encoder", "bgr_to_i420", "decode_h264", "psnr"]


#: full-range chroma (0..255 about 128, OpenCV's YCrCb) to studio range (16..240): x 224 / 255
_STUDIO_CHROMA = np.round(128.0 + (np.arange(256) - 128.0) * 224.0 / 255.0).astype(np.uint8)
#: the same map as one multiply-add (cv2.convertScaleAbs, ~3x faster than cv2.LUT): the exact
#: value 128 + (c - 128) 224 / 255 is never within 1/510 of a half level ((c - 128) 448 is
#: even, 255 (2 k + 1) odd), far more than float32's error, so rounding it gives the table's
#: level for every c (tests/record/test_video.py checks all 256)
_STUDIO_ALPHA = 224.0 / 255.0
_STUDIO_BETA = 128.0 * (1.0 - _STUDIO_ALPHA)


def bgr_to_i420(frame_bgr: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """A BGR frame as planar YUV 4:2:0 (I420: the Y plane, then U, then V, one uint8 array of
    ``height * 3 / 2`` rows), BT.601 studio range, as H.264 decoders read it by default.

    Each chroma sample is the mean of its 2 x 2 block of pixels (the colour is averaged
    first, then converted, which the conversion's linearity allows; the mean, the full-range
    chroma and the studio-range table each round to whole levels, so a sample is within 1.5
    levels of the exact value). OpenCV's own BGR to I420
    takes it from the block's top-left pixel, which puts colour steps on a marker's edges.
    swscale (PyAV's conversion, which the encoder would otherwise apply) filters it too, at
    0.8-1.1 ms a 640 x 480 frame against 0.34-0.38 ms here (rendered frames, interleaved
    runs); converted back to BGR as a decoder does, a rendered frame comes out at 40.4 dB
    PSNR from here and 38.5 dB from swscale.

    The Y plane is OpenCV's (its I420 conversion, whose chroma is then overwritten); Cb and
    Cr go from the half-size YCrCb image straight into their planes (one cv2.split, its Y
    into a scratch plane: a fifth of cv2.mixChannels' 0.06 ms for the same copy) and are
    mapped to studio range there in one pass over both planes, the same levels as the table
    and per-plane copies did at about two thirds of their time (0.46 -> 0.29 ms a rendered
    frame, one core, interleaved runs).

    Parameters
    ----------
    frame_bgr : np.ndarray
        (height, width, 3) uint8 BGR image; height and width even.
    out : np.ndarray, optional
        A C-contiguous uint8 array of shape (height * 3 / 2, width) to write into (an
        encoder reuses one); a new one when None.

    Raises
    ------
    ValueError
        Not a uint8 three-channel image of even height and width, or ``out`` of another
        shape or type.
    """
    if frame_bgr.dtype != np.uint8 or frame_bgr.ndim != 3 or frame_bgr.shape[2] != 3:
        raise ValueError(f"I420 needs a uint8 BGR image, got {frame_bgr.dtype} of shape {frame_bgr.shape}")
    h, w = frame_bgr.shape[:2]
    if h % 2 or w % 2 or h == 0 or w == 0:
        raise ValueError(f"I420 needs an even, non-zero frame size, got {w}x{h}")
    if out is None:
        out = np.empty((h * 3 // 2, w), np.uint8)
    elif out.shape != (h * 3 // 2, w) or out.dtype != np.uint8 or not out.flags.c_contiguous:
        raise ValueError(f"I420 of a {w}x{h} frame needs a C-contiguous uint8 ({h * 3 // 2}, {w}) array")
    cv2.cvtColor(frame_bgr, cv2.COLOR_BGR2YUV_I420, dst=out)  # its Y plane; the chroma is replaced
    mean = cv2.resize(frame_bgr, (w // 2, h // 2), interpolation=cv2.INTER_AREA)  # each 2 x 2 block's mean
    ycrcb = cv2.cvtColor(mean, cv2.COLOR_BGR2YCrCb)
    flat, n = out.reshape(-1), h * w  # the planes follow each other: Y (n bytes), U and V (n / 4 each)
    u = flat[n : n + n // 4].reshape(h // 2, w // 2)
    v = flat[n + n // 4 :].reshape(h // 2, w // 2)
    cv2.split(ycrcb, [np.empty_like(u), v, u])  # Cr into V, Cb into U (in place: the planes are views)
    chroma = flat[n:]
    cv2.convertScaleAbs(chroma, dst=chroma, alpha=_STUDIO_ALPHA, beta=_STUDIO_BETA)  # = _STUDIO_CHROMA[chroma]
    return out


@dataclass(frozen=True)
class EncodedFrame:
    """One frame as H.264: an Annex B access unit."""

    data: bytes  # the access unit (NAL units with 4-byte start codes)
    keyframe: bool  # an IDR frame (with SPS and PPS in front of it)
    index: int  # the frame's number from the encoder's first, from 0


class H264Encoder:
    """libx264 at a target bitrate for a live or recorded camera.

    ``ultrafast`` with ``zerolatency`` (no lookahead, no B-frames): every frame put in comes
    out at once as one access unit. The rate is held by x264's VBV at ``bitrate_kbps`` over
    one second, so a file's size follows from its length.

    Parameters
    ----------
    width, height : int
        Frame size, pixels (even numbers: 4:2:0 chroma).
    fps : float
        Frame rate the bitrate is spread over, frames per second.
    bitrate_kbps : int
        Target bitrate, kbit/s.
    gop : int
        Frames from one keyframe to the next.
    preset : str
        x264 speed preset (``ultrafast`` .. ``placebo``).

    Raises
    ------
    ConfigError
        An odd frame size, or a rate, bitrate or GOP that is not positive.
    """

    def __init__(
        self, width: int, height: int, fps: float, bitrate_kbps: int, gop: int = 30, preset: str = "ultrafast"
    ) -> None:
        if width <= 0 or height <= 0 or width % 2 or height % 2:
            raise ConfigError(f"H.264 needs an even, positive frame size, got {width}x{height}")
        if not (fps > 0 and math.isfinite(fps)) or bitrate_kbps <= 0 or gop <= 0:
            raise ConfigError(f"H.264 needs fps, bitrate and GOP > 0, got {fps!r}, {bitrate_kbps!r}, {gop!r}")
        self.width, self.height = width, height
        self.bitrate_kbps = bitrate_kbps
        self.gop = gop
        cc = av.CodecContext.create("libx264", "w")
        cc.width, cc.height, cc.pix_fmt = width, height, "yuv420p"
        rate = Fraction(fps).limit_denominator(1001)
        cc.framerate = rate
        cc.time_base = 1 / rate
        cc.bit_rate = bitrate_kbps * 1000
        cc.gop_size = gop
        cc.max_b_frames = 0
        cc.thread_count = 1  # one core per camera process; frames come one at a time anyway
        cc.options = {
            "preset": preset,
            "tune": "zerolatency",
            "x264-params": (
                f"repeat-headers=1:scenecut=0:keyint={gop}:min-keyint={gop}"
                f":vbv-maxrate={bitrate_kbps}:vbv-bufsize={bitrate_kbps}"
            ),
        }
        cc.open()
        self._cc = cc
        # each frame's I420 goes into this one buffer, which x264 reads in place (PyAV's
        # from_numpy_buffer, no copy: ~0.17 ms a 640 x 480 frame less than from_ndarray).
        # Reusing it is safe: avcodec_send_frame runs x264_encoder_encode at once, which
        # copies the picture into x264's own frame before it returns (x264 has no zero-copy
        # input), and with zerolatency the access unit comes back in the same call.
        # PyAV reads the height of a yuv420p buffer as rows // 6 * 4, wrong unless height is a
        # multiple of 4: such sizes take the copy. The zero-copy frame is made once and sent
        # again with each new picture in its buffer and a new pts (the same bytes out; its
        # making was ~0.04 ms of every frame)
        self._i420 = np.empty((height * 3 // 2, width), np.uint8)
        self._frame = av.VideoFrame.from_numpy_buffer(self._i420, format="yuv420p") if height % 4 == 0 else None
        self.frames = 0  # frames encoded
        self.bytes = 0  # bytes of access units produced

    def encode(self, frame_bgr: np.ndarray) -> EncodedFrame:
        """Encode one frame; its access unit comes back at once.

        Parameters
        ----------
        frame_bgr : np.ndarray
            (height, width, 3) uint8 BGR image, the encoder's size.

        Raises
        ------
        ConfigError
            The frame is not of the encoder's size.
        """
        if frame_bgr.shape != (self.height, self.width, 3):
            raise ConfigError(f"H.264 encoder is {self.width}x{self.height}, got a frame of shape {frame_bgr.shape}")
        i420 = bgr_to_i420(frame_bgr, self._i420)
        vf = self._frame if self._frame is not None else av.VideoFrame.from_ndarray(i420, format="yuv420p")
        vf.pts = self.frames
        packets = self._cc.encode(vf)
        data = b"".join(bytes(p) for p in packets)
        keyframe = any(p.is_keyframe for p in packets)
        out = EncodedFrame(data, keyframe, self.frames)
        self.frames += 1
        self.bytes += len(data)
        return out


class H264Decoder:
    """Decodes Annex B access units one by one (as a live receiver or a log reader gets them)."""

    def __init__(self) -> None:
        self._dec = av.CodecContext.create("h264", "r")
        self._dec.thread_count = 1
        self.units = 0  # access units given

    def decode(self, unit: bytes) -> list[np.ndarray]:
        """The BGR frames this access unit completes (none before the first keyframe).

        Parameters
        ----------
        unit : bytes
            One access unit.
        """
        packet = av.Packet(unit)
        packet.pts = self.units
        self.units += 1
        try:
            return [f.to_ndarray(format="bgr24") for f in self._dec.decode(packet)]
        except av.error.InvalidDataError:
            return []  # a delta frame before any keyframe: nothing to decode against


def decode_h264(units: Iterable[bytes], max_pixels: int = 4096 * 4096) -> Iterator[tuple[int, np.ndarray]]:
    """Decode Annex B access units (as :class:`H264Encoder` makes them) to BGR frames:
    ``(k, frame)`` for the k-th unit (from 0) that decodes; units before the first keyframe,
    units that do not decode (damaged) and frames over ``max_pixels`` give nothing.

    Parameters
    ----------
    units : iterable of bytes
        Access units in stream order.
    max_pixels : int
        Larger frames (a damaged or crafted size) are not converted.
    """
    dec = av.CodecContext.create("h264", "r")
    dec.thread_count = 1
    k = -1

    def frames_of(packet: av.Packet | None) -> list[Any]:
        try:
            return list(dec.decode(packet))
        except av.error.FFmpegError:
            return []  # a delta frame before any keyframe, or a damaged unit: nothing to show

    for k, unit in enumerate(units):
        packet = av.Packet(unit)
        packet.pts = k
        for f in frames_of(packet):
            if 0 < f.width * f.height <= max_pixels:
                yield (f.pts if f.pts is not None else k), f.to_ndarray(format="bgr24")
    if k >= 0:
        for f in frames_of(None):
            if 0 < f.width * f.height <= max_pixels:
                yield (f.pts if f.pts is not None else k), f.to_ndarray(format="bgr24")


def psnr(a: np.ndarray, b: np.ndarray) -> float:
    """Peak signal-to-noise ratio of two 8-bit images, dB (inf when they are equal).

    Parameters
    ----------
    a, b : np.ndarray
        Images of the same shape, uint8.
    """
    if a.shape != b.shape:
        raise ValueError(f"PSNR of images of different shapes: {a.shape} and {b.shape}")
    mse = float(np.mean((a.astype(np.float32) - b.astype(np.float32)) ** 2))
    return math.inf if mse == 0 else 10 * math.log10(255.0**2 / mse)
