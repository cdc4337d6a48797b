"""packet_record's fast path for plain int and finite float fields against _jsonable on
every field (what it did before), on packets with every kind of field value."""

from __future__ import annotations

import json
import math

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mav

from lfctl.link.endpoint import _jsonable, packet_record
from lfctl.link.port import pack_next


def _plain_fields(msg) -> dict:
    return {k: _jsonable(getattr(msg, k)) for k in msg.get_fieldnames()}


def _messages() -> list:
    nan, inf = math.nan, math.inf
    return [
        mav.MAVLink_heartbeat_message(10, 3, 81, 15, 4, 3),
        mav.MAVLink_local_position_ned_message(1234, 1.5, -2.25, 0.0, nan, inf, -inf),
        mav.MAVLink_attitude_message(99, 0.1, -0.2, 3.0, 1e-300, -0.0, 2.5),
        mav.MAVLink_statustext_message(4, b"Fence breached: radius", 7, 1),
        mav.MAVLink_statustext_message(6, "caf\u00e9".encode() + b"\xff", 0, 0),
        mav.MAVLink_home_position_message(1, 2, 3, 0.5, nan, 0.0, [1, 0, 0, 0], 0, 0, 0),
        mav.MAVLink_param_value_message(b"WP_SPEED", 2.0, 9, 200, 3),
        mav.MAVLink_command_long_message(1, 1, 400, 0, 1.0, nan, inf, 0.0, 0.0, 0.0, 0.0),
    ]


@pytest.mark.parametrize("direction", ["in", "out"])
def test_fields_are_what_jsonable_gives_on_every_field(direction: str) -> None:
    link = mav.MAVLink(None, srcSystem=1, srcComponent=1)
    for msg in _messages():
        raw = pack_next(msg, link)
        decoded = mav.MAVLink(None).parse_buffer(raw)[0]
        for m in (msg, decoded):
            rec = packet_record(direction, m, raw)
            plain = _plain_fields(m)
            assert json.dumps(rec["fields"], allow_nan=False) == json.dumps(plain, allow_nan=False)
            for k, v in rec["fields"].items():
                assert type(v) is type(plain[k])


def test_nan_and_infinite_floats_become_strings() -> None:
    msg = mav.MAVLink_local_position_ned_message(1, 1.0, 2.0, 0.0, math.nan, math.inf, -math.inf)
    raw = pack_next(msg, mav.MAVLink(None, srcSystem=1, srcComponent=1))
    fields = packet_record("out", msg, raw)["fields"]
    assert fields["vx"] == "nan" and fields["vy"] == "inf" and fields["vz"] == "-inf"
    assert fields["x"] == 1.0 and fields["time_boot_ms"] == 1
