"""The colour conversion in front of x264: hand-worked BT.601 studio-range values, chroma as
each 2 x 2 block's mean, and the same planes (within rounding) as swscale, PyAV's own; the
fast paths (chroma straight into its planes, one multiply-add for the studio range, the
encoder's reused zero-copy buffer) against plain references."""

from __future__ import annotations

import av
import cv2
import numpy as np
import pytest

from lfctl.record.video import _STUDIO_ALPHA, _STUDIO_BETA, _STUDIO_CHROMA, H264Encoder, bgr_to_i420, psnr


def planes(i420: np.ndarray, h: int, w: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    flat, n = i420.reshape(-1), h * w
    return (
        flat[:n].reshape(h, w),
        flat[n : n + n // 4].reshape(h // 2, w // 2),
        flat[n + n // 4 :].reshape(h // 2, w // 2),
    )


@pytest.mark.parametrize(
    ("bgr", "yuv"),
    [
        # Y = 16 + 219 (0.299 R + 0.587 G + 0.114 B) / 255; U = 128 + 224 * 0.5 (B - Y') / (1 - 0.114) / 255,
        # V = 128 + 224 * 0.5 (R - Y') / (1 - 0.299) / 255 (Y' the unscaled luma)
        ((0, 0, 0), (16, 128, 128)),
        ((255, 255, 255), (235, 128, 128)),
        ((0, 0, 255), (81.5, 90.2, 240.0)),  # red: Y' 76.2, B - Y' = -76.2, R - Y' = 178.8
        ((255, 0, 0), (41.0, 240.0, 109.8)),  # blue: Y' 29.1, B - Y' = 225.9, R - Y' = -29.1
    ],
)
def test_plain_colours_take_bt601_studio_range_values(bgr: tuple[int, int, int], yuv: tuple[float, ...]) -> None:
    frame = np.empty((4, 6, 3), np.uint8)
    frame[:] = bgr
    y, u, v = planes(bgr_to_i420(frame), 4, 6)
    for plane, want in zip((y, u, v), yuv, strict=True):
        assert np.all(np.abs(plane.astype(float) - want) <= 1.0), (plane, want)


def test_a_chroma_sample_is_its_blocks_mean_not_one_pixel() -> None:
    frame = np.full((2, 2, 3), 96, np.uint8)
    frame[0, 0] = (96, 96, 255)  # one reddish pixel of four: the mean is (96, 96, 135.75)
    _, u, v = planes(bgr_to_i420(frame), 2, 2)
    # Y' = 0.299 * 135.75 + 0.701 * 96 = 107.88; U = 128 + 0.8784 * 0.5643 * (96 - 107.88) = 122.1,
    # V = 128 + 0.8784 * 0.7133 * (135.75 - 107.88) = 145.5 (the top-left pixel alone: 104.4, 197.9)
    assert abs(int(u[0, 0]) - 122.1) <= 1.0 and abs(int(v[0, 0]) - 145.5) <= 1.0


@pytest.mark.parametrize(("h", "w"), [(480, 640), (242, 322)])
def test_the_planes_match_swscale_within_rounding(h: int, w: int) -> None:
    rng = np.random.default_rng(7)
    blocks = rng.integers(0, 256, (h // 8 + 1, w // 8 + 1, 3)).astype(np.uint8)
    smooth = np.ascontiguousarray(blocks[np.arange(h) // 8][:, np.arange(w) // 8])  # flat 8 x 8 blocks
    ours = bgr_to_i420(smooth)
    theirs = av.VideoFrame.from_ndarray(smooth, format="bgr24").reformat(format="yuv420p").to_ndarray()
    assert ours.shape == theirs.shape == (h * 3 // 2, w)
    d = np.abs(ours.astype(int) - theirs.astype(int))
    assert d[:h].max() <= 1  # luma: rounding only
    assert np.median(d[h:]) <= 1  # chroma: rounding inside the blocks (swscale filters across their edges)
    back = av.VideoFrame.from_ndarray(ours, format="yuv420p").to_ndarray(format="bgr24")
    assert psnr(back, smooth) > 35.0


@pytest.mark.parametrize(
    ("shape", "dtype", "says"),
    [((3, 4, 3), np.uint8, "even, non-zero frame size, got 4x3"), ((4, 4, 4), np.uint8, "uint8 BGR image"),
     ((4, 4, 3), np.float32, "uint8 BGR image")],
)  # fmt: skip
def test_what_is_not_an_even_bgr_image_is_named(shape: tuple[int, ...], dtype: type, says: str) -> None:
    with pytest.raises(ValueError, match=says):
        bgr_to_i420(np.zeros(shape, dtype))


def reference_i420(frame: np.ndarray) -> np.ndarray:
    """The conversion written plainly: OpenCV's I420 Y plane, then each 2 x 2 block's mean
    colour as full-range YCrCb, mapped to studio range by the table, copied plane by plane."""
    h, w = frame.shape[:2]
    out = cv2.cvtColor(frame, cv2.COLOR_BGR2YUV_I420)
    mean = cv2.resize(frame, (w // 2, h // 2), interpolation=cv2.INTER_AREA)
    ycrcb = _STUDIO_CHROMA[cv2.cvtColor(mean, cv2.COLOR_BGR2YCrCb)]
    flat, n = out.reshape(-1), h * w
    flat[n : n + n // 4] = ycrcb[:, :, 2].ravel()
    flat[n + n // 4 :] = ycrcb[:, :, 1].ravel()
    return out


@pytest.mark.parametrize(("h", "w"), [(2, 2), (4, 6), (122, 162), (240, 320), (480, 640), (10, 1000)])
def test_the_conversion_equals_the_plain_reference(h: int, w: int) -> None:
    rng = np.random.default_rng(h * 1000 + w)
    frames = [
        rng.integers(0, 256, (h, w, 3), dtype=np.uint8),
        np.full((h, w, 3), 255, np.uint8),
        np.zeros((h, w, 3), np.uint8),
        rng.integers(0, 256, (h, 2 * w, 3), dtype=np.uint8)[:, ::2],  # not contiguous
    ]
    for frame in frames:
        want = reference_i420(np.ascontiguousarray(frame))
        assert np.array_equal(bgr_to_i420(frame), want)
        out = rng.integers(0, 256, (h * 3 // 2, w), dtype=np.uint8)  # stale contents are all replaced
        assert bgr_to_i420(frame, out) is out
        assert np.array_equal(out, want)


def test_an_out_array_of_another_shape_is_refused() -> None:
    with pytest.raises(ValueError, match="C-contiguous uint8"):
        bgr_to_i420(np.zeros((4, 6, 3), np.uint8), np.zeros((6, 4), np.uint8))


@pytest.mark.parametrize("n", [1, 7, 16, 33, 256, 256 * 37 + 5])
def test_the_studio_multiply_add_is_the_table_for_every_level(n: int) -> None:
    # every length: OpenCV's vector loop and its scalar tail both see all 256 levels
    levels = np.resize(np.arange(256, dtype=np.uint8), n)
    got = cv2.convertScaleAbs(levels, alpha=_STUDIO_ALPHA, beta=_STUDIO_BETA).ravel()
    assert np.array_equal(got, _STUDIO_CHROMA[levels])


@pytest.mark.parametrize(("h", "w"), [(240, 320), (122, 162)])
def test_the_encoders_reused_buffer_gives_the_bytes_of_fresh_copies(h: int, w: int) -> None:
    # the encoder hands x264 one buffer it overwrites frame after frame (zero-copy where the
    # height allows it): were any frame read after the next one is written, the bytes would
    # differ from an encoder given a fresh copy of every frame
    rng = np.random.default_rng(3)
    tiles = rng.integers(0, 256, (h // 4 + 8, w // 4 + 8, 3)).astype(np.uint8)
    ours, reference = H264Encoder(w, h, 30.0, 400, gop=10), H264Encoder(w, h, 30.0, 400, gop=10)
    frame = np.empty((h, w, 3), np.uint8)
    for k in range(40):
        frame[:] = cv2.resize(tiles[k % 8 :, k % 5 :][: h // 4, : w // 4], (w, h), interpolation=cv2.INTER_NEAREST)
        got = ours.encode(frame)
        vf = av.VideoFrame.from_ndarray(reference_i420(frame.copy()), format="yuv420p")
        vf.pts = k
        want = b"".join(bytes(p) for p in reference._cc.encode(vf))
        assert got.data == want, k
