"""lfctl bench record: what recording costs a lockstep run, and what the video keeps.

examples/convoy.toml (camera sensing) with recording off, on without images, with 30 Hz
640x480 H.264 video (the default) and with 30 Hz JPEG images, in the same run, the four
interleaved and repeated (the median of each kept): real-time factor, the CPU seconds the
process spent per simulated second and its ratio to "off" (the convoy's one camera runs in
this process; CPU time is what other programs on the machine disturb least), file size per
simulated minute, the video's measured bitrate and keyframe spacing. Then what the frames keep: PSNR of each format's decoded
frames against the rendered ones (the same encoder settings as the log), and the tracker
replayed on each log's decoded frames (`lfctl replay`): its success and how often it still
finds the banner's four markers, beside the live tracker's on the rendered frames.
"""

from __future__ import annotations

import dataclasses
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

from lfctl.bench.common import print_json, print_table, run_as_script
from lfctl.config import Config, load_config
from lfctl.data import examples_dir
from lfctl.record.audit import audit
from lfctl.record.replay import replay
from lfctl.record.rtp import nal_units
from lfctl.record.video import H264Decoder, H264Encoder, psnr
from lfctl.record.writer import image_topic
from lfctl.sim.camera_sensor import CameraSample
from lfctl.sim.runner import run_scenario

__all__ = ["main", "quality"]

MODES = ("off", "no images", "h264", "jpeg")
IDR = 5  # H.264 NAL unit type of a keyframe


def _video_figures(path: Path, follower: str, duration_s: float) -> dict[str, float]:
    """Measured bitrate (kbit/s) and mean keyframe spacing (frames) of a log's video."""
    from foxglove_schemas_protobuf.CompressedVideo_pb2 import CompressedVideo

    msgs = audit(path).contents.messages.get(image_topic(follower, "h264"), [])
    units = [CompressedVideo.FromString(d).data for _, d in msgs]
    keys = [k for k, u in enumerate(units) if any(n[0] & 0x1F == IDR for n in nal_units(u))]
    return {
        "video_kbps": round(sum(len(u) for u in units) * 8 / duration_s / 1000, 1),
        "gop_frames": round(float(np.mean(np.diff(keys))), 1) if len(keys) > 1 else float(len(units)),
    }


def quality(cfg: Config, duration_s: float) -> dict[str, float]:
    """PSNR (dB) of H.264 and JPEG frames against the rendered ones, with the log's settings:
    each rendered frame is encoded and decoded as the recorder would, as it comes.

    Parameters
    ----------
    cfg : Config
        The scenario (``[recording]`` gives bitrate, GOP and JPEG quality).
    duration_s : float
        Simulated seconds to measure over.
    """
    rec = cfg.recording
    enc: dict[str, H264Encoder] = {}
    dec: dict[str, H264Decoder] = {}
    scores: dict[str, list[float]] = {"h264": [], "jpeg": []}

    def on_frame(follower: str, sample: CameraSample) -> None:
        frame = sample.frame
        if frame is None:
            return
        e = enc.get(follower)
        if e is None:
            e = enc[follower] = H264Encoder(
                frame.shape[1], frame.shape[0], cfg.sim.camera_rate_hz, rec.video_bitrate_kbps, rec.video_gop
            )
            dec[follower] = H264Decoder()
        scores["h264"] += [psnr(f, frame) for f in dec[follower].decode(e.encode(frame).data)]
        _ok, buf = cv2.imencode(".jpg", frame, [cv2.IMWRITE_JPEG_QUALITY, rec.jpeg_quality])
        scores["jpeg"].append(psnr(cv2.imdecode(buf, cv2.IMREAD_COLOR), frame))

    run_scenario(cfg, duration_s=duration_s, on_frame=on_frame)
    return {
        f"{k}_psnr_db_{stat}": round(float(fn(v)), 2)
        for k, v in scores.items()
        for stat, fn in (("mean", np.mean), ("min", np.min))
        if v
    }


def main(quick: bool = False) -> None:
    """Run the benchmark, print its tables and JSON line (``quick``: shorter runs)."""
    base = load_config(examples_dir() / "convoy.toml")
    duration = 15.0 if quick else 60.0
    base = dataclasses.replace(base, sim=dataclasses.replace(base.sim, duration_s=duration))
    follower = base.followers[0].name
    repeats = 1 if quick else 3
    runs: dict[str, list[tuple[float, float]]] = {m: [] for m in MODES}  # mode -> (wall s, CPU s)
    results: dict[str, dict[str, object]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(repeats):
            for mode in MODES:
                rec_cfg = dataclasses.replace(
                    base.recording,
                    dir=tmp,
                    images=mode in ("h264", "jpeg"),
                    image_format="jpeg" if mode == "jpeg" else "h264",
                    image_rate_hz=30.0,
                )
                cfg = dataclasses.replace(base, recording=rec_cfg)
                path = Path(tmp) / f"{mode.replace(' ', '_')}.mcap"
                t0, c0 = time.perf_counter(), time.process_time()
                report = run_scenario(cfg, record_to=None if mode == "off" else path)
                runs[mode].append((time.perf_counter() - t0, time.process_time() - c0))
                results[mode] = {
                    "mode": mode,
                    "mb_per_sim_minute": round(
                        (path.stat().st_size if mode != "off" else 0) / 1e6 * 60.0 / duration, 2
                    ),
                    "messages": report.log_messages,
                }
                del report
        cpu_off = float(np.median([c for _, c in runs["off"]]))
        for mode in MODES:
            wall, cpu = (float(np.median([r[k] for r in runs[mode]])) for k in (0, 1))
            results[mode] |= {
                "real_time_factor": round(duration / wall, 2),
                "cpu_s_per_sim_s": round(cpu / duration, 4),
                "cpu_ratio_vs_off": round(cpu / cpu_off, 3),
            }
            path = Path(tmp) / f"{mode.replace(' ', '_')}.mcap"
            if mode == "h264":
                results[mode] |= _video_figures(path, follower, duration)
            if mode in ("h264", "jpeg"):
                r = replay(path, "full", follower)
                assert r.recorded_success is not None and r.recorded_markers is not None  # (its own camera run)
                results[mode] |= {
                    "replayed_success": round(r.replayed_success, 3),
                    "live_success": round(r.recorded_success, 3),
                    "replayed_markers": round(r.replayed_markers, 3),
                    "live_markers": round(r.recorded_markers, 3),
                }
    rows = [
        (
            mode,
            rec["real_time_factor"],
            rec["cpu_s_per_sim_s"],
            rec["cpu_ratio_vs_off"],
            rec["mb_per_sim_minute"],
            rec["messages"],
            rec.get("video_kbps", "-"),
            rec.get("gop_frames", "-"),
            rec.get("replayed_markers", "-"),
            rec.get("live_markers", "-"),
        )
        for mode, rec in results.items()
    ]
    print_table(
        (
            "recording",
            "RTF",
            "CPU s / sim s",
            "CPU x off",
            "MB/sim min",
            "messages",
            "video kbit/s",
            "GOP frames",
            "markers found (decoded)",
            "markers found (live)",
        ),
        rows,
    )
    q = quality(base, 8.0 if quick else 20.0)
    print(
        f"\nPSNR against the rendered frames: H.264 {q.get('h264_psnr_db_mean')} dB mean, "
        f"{q.get('h264_psnr_db_min')} dB worst; JPEG q{base.recording.jpeg_quality} {q.get('jpeg_psnr_db_mean')} dB mean, "
        f"{q.get('jpeg_psnr_db_min')} dB worst"
    )
    print_json("record", {"repeats": repeats, "modes": list(results.values()), "quality": q})


if __name__ == "__main__":
    run_as_script(main, __doc__)
