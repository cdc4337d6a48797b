"""`lfctl follow` against a vehicle endpoint on loopback UDP: a rendered banner video as the
camera, GUIDED setpoints out, formation status reported."""

from __future__ import annotations

import time

import pytest

from lfctl.cli import main
from lfctl.link.endpoint import MODES, VehicleEndpoint
from lfctl.link.signing import signing_key_from_passphrase

pytestmark = pytest.mark.integration


@pytest.mark.parametrize("passphrase", [None, "convoy-7"])
def test_follow_drives_a_guided_rover_from_video(
    banner_video, standing_rover, capsys: pytest.CaptureFixture[str], passphrase: str | None
) -> None:
    # with a passphrase the rover signs and takes only signed packets: the companion must sign
    video = banner_video(40)
    received: list[tuple[float, float]] = []
    names: set[str] = set()

    def commanded(rover: VehicleEndpoint) -> None:
        cmd = rover.guided_command()
        if cmd is not None:
            received.append(cmd)

    with standing_rover(signing_key_from_passphrase(passphrase), commanded) as rover:
        rover.tap = lambda d, m, raw: names.add(m.get_type()) if d == "in" else None
        rc = main(
            [
                "follow",
                "--mavlink",
                f"udpout:127.0.0.1:{rover.link.port}",
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
        time.sleep(0.2)  # the last setpoints reach the rover
    assert rc == 0 and "sent" in capsys.readouterr().out
    assert rover.mode == MODES["GUIDED"] and rover.armed
    assert {"SET_POSITION_TARGET_LOCAL_NED", "NAMED_VALUE_FLOAT"} <= names
    assert max(v for v, _ in received) > 0.05  # the leader is ~1.8 m away: drive towards the slot
    g = rover.guided  # left stopped: the last target is zero speed and zero turn rate
    assert g is not None and g.kind == "rate" and (g.speed_mps, g.yaw_rate_radps) == (0.0, 0.0)
