"""lfctl bench record: what recording costs a lockstep run.

examples/convoy.toml (camera sensing) with recording off, on without images, and on with
30 Hz 640x480 JPEG images, in the same run: real-time factor, slowdown against "off",
writer throughput, file size per simulated minute, and the cost of one recorded camera tick
(JPEG encode + write) against the 33 ms a 30 Hz --realtime run allows.
"""

from __future__ import annotations

import dataclasses
import sys
import tempfile
import time
from pathlib import Path

from lfctl.bench.common import print_json, print_table
from lfctl.config import load_config
from lfctl.data import examples_dir
from lfctl.sim.runner import run_scenario

__all__ = ["main"]


def main(quick: bool = False) -> None:
    """Run the benchmark, print its table and JSON line (``quick``: shorter runs)."""
    base = load_config(examples_dir() / "convoy.toml")
    duration = 15.0 if quick else 60.0
    base = dataclasses.replace(base, sim=dataclasses.replace(base.sim, duration_s=duration))
    rows, results = [], []
    off_rtf = None
    with tempfile.TemporaryDirectory() as tmp:
        for mode in ("off", "no images", "30 Hz images"):
            rec_cfg = dataclasses.replace(base.recording, dir=tmp, images=mode == "30 Hz images", image_rate_hz=30.0)
            cfg = dataclasses.replace(base, recording=rec_cfg)
            t0 = time.perf_counter()
            if mode == "off":
                report = run_scenario(cfg)
                size, messages, cam_ms = 0, 0, None
            else:
                path = Path(tmp) / f"{mode.replace(' ', '_')}.mcap"
                report = run_scenario(cfg, record_to=path)
                size, messages = path.stat().st_size, report.log_messages
                extra = report.result.extra
                ticks = round(duration * cfg.sim.camera_rate_hz)
                images = round(duration * cfg.recording.image_rate_hz) if cfg.recording.images else 0
                # writing each tick's messages (mean), plus encoding its JPEG (done by the
                # camera's process, beside the tracker; its mean per image)
                encode_ms = float(extra["encode_s"]) / images * 1000 if images else 0.0  # type: ignore[arg-type]
                cam_ms = float(extra["record_camera_s"]) / ticks * 1000 + encode_ms  # type: ignore[arg-type]
            wall = time.perf_counter() - t0
            rtf = duration / wall
            off_rtf = off_rtf or rtf
            mb = size / 1e6
            rec = {
                "mode": mode,
                "real_time_factor": round(rtf, 2),
                "slowdown_ratio_vs_off": round(off_rtf / rtf, 3),
                "file_mb": round(mb, 2),
                "mb_per_sim_minute": round(mb * 60.0 / duration, 2),
                "messages": messages,
                "writer_mb_per_s": round(mb / wall, 2),
                "messages_per_s": round(messages / wall, 1),
                "camera_tick_record_ms_mean": round(cam_ms, 2) if cam_ms is not None else None,
            }
            results.append(rec)
            rows.append(tuple(rec.values()))
            del report
    print_table(
        ("recording", "RTF", "slowdown x", "file MB", "MB/sim min", "messages", "MB/s", "msg/s", "ms per camera tick"),
        rows,
    )
    img = results[-1]["camera_tick_record_ms_mean"]
    if img is not None:
        print(
            f"\nrecording one 30 Hz camera tick with its JPEG costs {img:.1f} ms of the 33.3 ms a --realtime frame allows"
        )
    print_json("record", results)


if __name__ == "__main__":
    main("--quick" in sys.argv)
