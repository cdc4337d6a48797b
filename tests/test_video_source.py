"""A video source that would block for ever is refused: a named pipe or socket given as a
file, and a stream that never sends (within STREAM_TIMEOUT_S)."""

from __future__ import annotations

import itertools
import os
import re
import socket
from collections.abc import Callable
from pathlib import Path

import pytest
from support import rtp_camera

import lfctl.video
from lfctl.errors import ConfigError
from lfctl.video import VideoSource


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="named pipes")
def test_a_named_pipe_is_refused_at_once(tmp_path: Path) -> None:
    fifo = tmp_path / "cam.fifo"
    os.mkfifo(fifo)
    with pytest.raises(ConfigError, match="is a named pipe or socket, not a video file"):
        VideoSource(str(fifo))


def test_a_silent_stream_is_an_error_after_the_timeout(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(lfctl.video, "STREAM_TIMEOUT_S", 1.0)
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:  # a free port: nothing will send to it
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    with pytest.raises(ConfigError, match=r"cannot open video source 'udp://127.0.0.1:\d+' .*no stream within 1 s"):
        VideoSource(f"udp://127.0.0.1:{port}")


def test_shipped_clips_are_found_by_name_and_named_when_missing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from lfctl.data import footage_dir, resolve_footage

    monkeypatch.chdir(tmp_path)  # no footage folder here, as for a wheel's user
    shipped = str(footage_dir() / "bikes.mp4")
    assert resolve_footage("bikes.mp4") == shipped and resolve_footage("footage/bikes.mp4") == shipped
    (tmp_path / "bikes.mp4").write_bytes(b"mine")
    assert resolve_footage("bikes.mp4") == "bikes.mp4"  # a file here is the user's
    for given in ("0", "rtsp://10.0.0.2/cam", "clips/bikes.mp4", "nosuch.mp4"):
        assert resolve_footage(given) == given
    from lfctl.cli import main

    assert main(["track", "nosuch.mp4", "--max-frames", "1"]) == 2
    assert f"or a shipped clip by name, from {footage_dir()}" in capsys.readouterr().err


class FakeCamera:
    """A camera making a numbered frame every ``period_s`` (as a driver does, read or not):
    ``read`` waits for the next one; ``frames`` of them, then the end."""

    def __init__(self, period_s: float = 0.005, frames: int = 10**6, stuck: bool = False) -> None:
        import time

        self.period_s, self.frames, self.stuck = period_s, frames, stuck
        self.t0, self.made = time.monotonic(), 0
        self.opened, self.released = True, False

    def isOpened(self) -> bool:  # OpenCV's name
        return self.opened

    def read(self) -> tuple[bool, object]:
        import time

        import numpy as np

        if self.stuck:  # a driver that hangs in a read (an unplugged camera)
            time.sleep(3600)
        if self.released:
            raise AssertionError("read after release: OpenCV would crash here")
        if self.made >= self.frames:
            return False, None
        self.made += 1
        time.sleep(max(0.0, self.t0 + self.made * self.period_s - time.monotonic()))
        return True, np.full((4, 4, 3), self.made % 256, np.uint8) if self.made < 256 else np.full(
            (4, 4, 3), 255, np.uint8
        )

    def get(self, _prop: int) -> float:
        return 0.0

    def release(self) -> None:
        self.released = True


def wait_until(done: Callable[[], bool]) -> None:
    import time

    deadline = time.monotonic() + 30.0
    while not done():
        assert time.monotonic() < deadline
        time.sleep(0.001)


def test_a_slow_reader_of_a_live_camera_gets_its_newest_frame_and_the_rest_are_counted() -> None:
    from lfctl.video import LatestFrames

    camera = FakeCamera(period_s=0.001, frames=200)
    latest = LatestFrames(camera, timeout_s=5.0)
    taken: list[int] = []
    for _ in range(8):  # a reader slower than the camera: five frames made between its reads
        wait_until(lambda: camera.made >= (taken[-1] if taken else 0) + 5)
        frame = latest.next()
        assert frame is not None
        taken.append(int(frame[0, 0, 0]))
        assert camera.made - taken[-1] <= 1  # the newest (the reader may be making the next)
    assert all(b - a >= 4 for a, b in itertools.pairwise(taken))  # never an old one, nor one twice
    while latest.next() is not None:  # the rest, then the end
        taken.append(-1)
    assert latest.stop() and camera.made == 200
    assert len(taken) + latest.skipped == 200  # every frame taken or counted as passed over


def test_a_live_source_is_read_for_its_newest_frame_only_when_asked_and_a_file_never(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    import cv2

    cameras: list[FakeCamera] = []

    def opened(*_args: object) -> FakeCamera:
        cameras.append(FakeCamera(period_s=0.005, frames=100))
        return cameras[-1]

    monkeypatch.setattr(cv2, "VideoCapture", opened)
    with VideoSource("0", latest=True) as camera:
        assert camera.live
        first = camera.read()
        assert first is not None
        wait_until(lambda: cameras[-1].made >= int(first[0, 0, 0]) + 10)
        newer = camera.read()
        assert newer is not None and int(newer[0, 0, 0]) - int(first[0, 0, 0]) >= 9  # (the 10th may be in the making)
        assert camera.skipped >= 8
    assert cameras[-1].released
    with VideoSource("0") as camera:  # not asked: every frame in turn
        assert [int(camera.read()[0, 0, 0]) for _ in range(3)] == [1, 2, 3] and camera.skipped == 0
    video = tmp_path / "v.avi"
    video.write_bytes(b"x")
    with VideoSource(str(video), latest=True) as clip:  # a file: every frame in turn
        assert not clip.live and [int(clip.read()[0, 0, 0]) for _ in range(3)] == [1, 2, 3]


def test_closing_a_camera_stuck_in_its_driver_returns_and_does_not_release_it_under_the_read(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import time

    import cv2

    monkeypatch.setattr(lfctl.video, "STREAM_TIMEOUT_S", 0.3)
    stuck = FakeCamera(stuck=True)
    monkeypatch.setattr(cv2, "VideoCapture", lambda *_a: stuck)
    t0 = time.monotonic()
    with VideoSource("0", latest=True) as camera:
        assert camera.read() is None  # silent for the timeout: the source's end
    assert time.monotonic() - t0 < 3.0 and not stuck.released


def test_a_reader_waiting_when_the_camera_stops_is_told_at_once() -> None:
    import threading
    import time

    from lfctl.video import LatestFrames

    camera = FakeCamera(period_s=0.001, frames=3)
    latest = LatestFrames(camera, timeout_s=30.0)
    t0 = time.monotonic()
    taken = 0
    while latest.next() is not None:
        taken += 1
    assert 1 <= taken <= 3 and time.monotonic() - t0 < 10.0  # its end said at once, not after 30 s
    endless = FakeCamera(period_s=0.05)
    live = LatestFrames(endless, timeout_s=30.0)
    got: list[object] = []
    reader = threading.Thread(target=lambda: [got.append(live.next()) for _ in range(1000)])
    reader.start()
    wait_until(lambda: len(got) >= 2)
    assert live.stop()
    reader.join(10.0)
    assert not reader.is_alive() and got[-1] is None


# -- RTP: the stream a rover's camera (or lfctl sim --video) sends ---------------------------------
@pytest.mark.integration
def test_an_rtp_stream_is_read_by_its_port_and_by_its_session_description(tmp_path: Path) -> None:
    import glob
    import tempfile

    import cv2
    import numpy as np

    from lfctl.record.rtp import sdp

    cards = []  # a camera streaming at 30 Hz: a grey card with a red square moving
    for k in range(100):
        frame = np.full((240, 320, 3), 128, np.uint8)
        cv2.rectangle(frame, (40 + k, 80), (100 + k, 140), (0, 0, 255), -1)
        cards.append(frame)
    with rtp_camera(cards) as port:
        (tmp_path / "camera.sdp").write_text(sdp("127.0.0.1", port))
        made = os.path.join(tempfile.gettempdir(), "lfctl-rtp-*.sdp")  # the descriptions made for rtp://
        for source in (f"rtp://127.0.0.1:{port}", f"rtp://localhost:{port}", str(tmp_path / "camera.sdp")):
            before, left = os.environ.get("OPENCV_FFMPEG_CAPTURE_OPTIONS"), set(glob.glob(made))
            with VideoSource(source) as video:
                assert video.live
                frames = [video.read() for _ in range(20)]
            assert os.environ.get("OPENCV_FFMPEG_CAPTURE_OPTIONS") == before
            assert set(glob.glob(made)) <= left  # none left behind
            assert all(f is not None and f.shape == (240, 320, 3) for f in frames), source
            red = frames[-1][:, :, 2].astype(int) - frames[-1][:, :, 1]  # type: ignore[index]
            assert (red > 100).sum() > 2000  # the square, decoded


@pytest.mark.parametrize(
    ("source", "said"),
    [
        ("rtp://", "an RTP source is rtp://HOST:PORT"),
        ("rtp://127.0.0.1:5600/live", "an RTP source is rtp://HOST:PORT"),
        ("rtp://127.0.0.1", "'127.0.0.1'"),
        ("rtp://127.0.0.1:0", "needs the port it arrives on"),
        ("rtp://127.0.0.1:65535", "below 65535 (RTCP takes the next)"),  # (port + 1 overflowed)
        ("rtp://no-such-host.invalid:5600", "cannot resolve 'no-such-host.invalid'"),
    ],
)
def test_an_rtp_source_that_is_not_host_and_port_is_refused(source: str, said: str) -> None:
    with pytest.raises(ConfigError, match=re.escape(said)):
        VideoSource(source)


def test_a_session_description_with_no_video_is_refused(tmp_path: Path) -> None:
    audio = tmp_path / "radio.sdp"
    audio.write_text("v=0\r\ns=radio\r\nc=IN IP4 127.0.0.1\r\nt=0 0\r\nm=audio 5004 RTP/AVP 0\r\n")
    with pytest.raises(ConfigError, match="no session description of a video stream"):
        VideoSource(audio)
    with pytest.raises(ConfigError, match="cannot read the session description"):
        VideoSource(tmp_path / "missing.sdp")


def test_an_rtp_port_another_reader_holds_is_named() -> None:
    # a second lfctl follow on the stream's port was told "no stream within 10 s"
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as held:
        held.bind(("127.0.0.1", 0))
        port = held.getsockname()[1]
        with pytest.raises(ConfigError, match=rf"cannot receive on 127\.0\.0\.1:{port} .*another reader holds it"):
            VideoSource(f"rtp://127.0.0.1:{port}")


def test_an_ipv6_rtp_address_is_described_as_one() -> None:
    from lfctl.video import sdp

    assert "c=IN IP6 ::1\r\n" in sdp("::1", 5600) and "c=IN IP4 127.0.0.1\r\n" in sdp("127.0.0.1", 5600)


# -- a camera that is not there yet, or stops: tried again ----------------------------------------


class _Opened:
    """A stand-in for an open live source: its first frame, and whether it was closed."""

    live, skipped = True, 0

    def __init__(self, *_args: object, **_kwargs: object) -> None:
        self.closed = False

    def read(self, timeout_s: float | None = None) -> object:
        return "frame"

    def close(self, wait_s: float | None = None) -> None:
        self.closed = True


def test_a_camera_not_there_yet_is_waited_for_and_said(monkeypatch: pytest.MonkeyPatch) -> None:
    from lfctl.video import SourceNotReady, open_live

    tries: list[object] = []

    def source(name: object, latest: bool = False, timeout_s: float | None = None) -> _Opened:
        tries.append(name)
        if len(tries) < 3:
            raise SourceNotReady(f"cannot open camera {name} with OpenCV (no such camera, or it is busy)")
        return _Opened()

    monkeypatch.setattr(lfctl.video, "REOPEN_S", 0.01)
    monkeypatch.setattr(lfctl.video, "VideoSource", source)
    said: list[str] = []
    video, first = open_live("0", None, said.append)
    assert isinstance(video, _Opened) and first == "frame" and tries == ["0", "0", "0"]
    assert said == ["cannot open camera 0 with OpenCV (no such camera, or it is busy)"]  # once: not every try


def test_a_camera_device_not_there_is_given_up_after_the_wait_and_a_missing_file_at_once(tmp_path: Path) -> None:
    from lfctl.video import open_live

    with pytest.raises(ConfigError, match=r"no camera device /dev/lfctl-no-such-camera .*\(waited 0\.\d s for it\)"):
        open_live("/dev/lfctl-no-such-camera", 0.2)
    said: list[str] = []
    with pytest.raises(ConfigError, match="does not exist"):
        open_live(str(tmp_path / "missing.mp4"), None, said.append)  # (None: it would wait for ever)
    assert said == []


def test_a_stopped_camera_is_opened_again_on_its_own_thread_and_handed_over_once() -> None:
    import threading

    from lfctl.video import Reopening

    tries: list[int] = []
    opened = _Opened()
    ready = threading.Event()

    def opener() -> _Opened:
        tries.append(1)
        if len(tries) < 2:
            raise ConfigError("no RTP stream yet")
        ready.set()
        return opened

    reopening = Reopening(opener)  # type: ignore[arg-type]
    assert ready.wait(5)
    got: list[object] = []
    wait_until(lambda: got.append(reopening.take()) or got[-1] is opened)
    assert reopening.take() is None and reopening.why == "no RTP stream yet"
    reopening.stop()
    assert not opened.closed  # handed over: the taker closes it
    left = _Opened()
    again = Reopening(lambda: left)  # type: ignore[arg-type,return-value]
    wait_until(lambda: not again._thread.is_alive())
    again.stop()
    assert left.closed  # opened, never taken: closed when the tries end


def test_a_stream_waited_for_is_tried_within_what_is_left_of_the_wait() -> None:
    # each try at a stream that sends nothing took FFmpeg's 10 s to open and 10 s for a first
    # frame, so --camera-wait 1 gave up after 20 s: the tries are shortened to fit the wait
    from lfctl.video import open_live

    probe = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    probe.bind(("127.0.0.1", 0))
    port = probe.getsockname()[1]
    probe.close()  # a free port: nothing will send to it
    with pytest.raises(ConfigError, match=r"within 0\.\d+ s.*\(waited \d+\.\d s for it\)"):
        open_live(f"rtp://127.0.0.1:{port}", 1.0)


def test_a_stream_is_decoded_without_frames_held_back_by_decoding_threads() -> None:
    import time

    import numpy as np

    # each frame a grey level of its own: the newest frame decoded says which one it is
    cards = [np.full((240, 320, 3), 4 * k, np.uint8) for k in range(60)]
    with (
        rtp_camera(cards, sending=lambda k: k < 60) as port,
        VideoSource(f"rtp://127.0.0.1:{port}", latest=True, timeout_s=5.0) as video,
    ):
        assert video.read() is not None
        time.sleep(3.0)  # the camera has sent its 60 frames (2 s at 30 Hz) and stopped
        newest = video.read(timeout_s=0.5)
        assert newest is not None
        # FFmpeg's H.264 parser holds the last frame until the next begins; decoding threads
        # held one more each past the first (two threads here: frame 57, a frame more behind)
        assert round(float(newest.mean()) / 4) == 58
