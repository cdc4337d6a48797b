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
