"""A video source that would block for ever is refused: a named pipe or socket given as a
file, and a stream that never sends (within STREAM_TIMEOUT_S)."""

from __future__ import annotations

import os
import socket
from pathlib import Path

import pytest

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
