"""`lfctl follow` against a vehicle endpoint on loopback UDP: a rendered banner video as the
camera, GUIDED setpoints out, formation status reported."""

from __future__ import annotations

import threading
import time

import pytest

from lfctl.cli import main
from lfctl.link.endpoint import MODES, VehicleEndpoint
from lfctl.link.signing import signing_key_from_passphrase
from lfctl.link.transport import UdpLink

pytestmark = pytest.mark.integration


@pytest.mark.parametrize("passphrase", [None, "convoy-7"])
def test_follow_drives_a_guided_rover_from_video(
    banner_video, capsys: pytest.CaptureFixture[str], passphrase: str | None
) -> None:
    # with a passphrase the rover signs and takes only signed packets: the companion must sign
    video = banner_video(40)
    udp = UdpLink(("127.0.0.1", 0))
    key = signing_key_from_passphrase(passphrase)
    rover = VehicleEndpoint("rover", 1, udp, (12.96, 77.67, 900.0), signing_key=key)
    received: list[tuple[float, float]] = []
    names: set[str] = set()
    rover.tap = lambda d, m, raw: names.add(m.get_type()) if d == "in" else None
    stop = threading.Event()
    t0 = time.monotonic()

    def run() -> None:
        while not stop.is_set():
            rover.tick(
                time.monotonic() - t0,
                {"north_m": 0.0, "east_m": 0.0, "yaw_rad": 0.0, "speed_mps": 0.0, "yaw_rate_radps": 0.0},
            )
            cmd = rover.guided_command()
            if cmd is not None:
                received.append(cmd)
            time.sleep(0.005)

    th = threading.Thread(target=run, daemon=True)
    th.start()
    try:
        rc = main(
            [
                "follow",
                "--mavlink",
                f"udpout:127.0.0.1:{udp.port}",
                "--camera",
                str(video),
                "--arm",
                "--max-frames",
                "30",
                "--timeout",
                "5",
                *(["--signing-passphrase", passphrase] if passphrase else []),
            ]
        )
    finally:
        time.sleep(0.2)
        stop.set()
        th.join(timeout=2)
        udp.close()
    assert rc == 0 and "sent" in capsys.readouterr().out
    assert rover.mode == MODES["GUIDED"] and rover.armed
    assert {"SET_POSITION_TARGET_LOCAL_NED", "NAMED_VALUE_FLOAT"} <= names
    assert max(v for v, _ in received) > 0.05  # the leader is ~1.8 m away: drive towards the slot
    g = rover.guided  # left stopped: the last target is zero speed and zero turn rate
    assert g is not None and g.kind == "rate" and (g.speed_mps, g.yaw_rate_radps) == (0.0, 0.0)
