"""The recorder's one JSON encoder against ``json.dumps`` with the options it stands for."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from lfctl.record.writer import _ENCODER, _jsonable

PAYLOADS = [
    {"t_s": 1.5, "a": 1, "b": -2.25, "s": 'x\u00e9"y', "n": None, "ok": True},
    {"np_f": np.float64(0.1), "np_i": np.int32(-7), "arr": np.arange(4.0), "raw": b"\x00\xffab"},
    {"nested": {"l": [1, 2.5, [np.float32(0.5)]], "t": (1, 2)}, "big": 10**20, "tiny": 5e-324},
]


@pytest.mark.parametrize("payload", PAYLOADS)
def test_the_shared_encoder_writes_what_json_dumps_wrote(payload: dict) -> None:
    plain = json.dumps(payload, separators=(",", ":"), allow_nan=False, default=_jsonable)
    assert _ENCODER.encode(payload) == plain


@pytest.mark.parametrize("bad", [math.nan, math.inf, np.float64("nan")])
def test_the_shared_encoder_refuses_nan_as_json_dumps_did(bad: float) -> None:
    with pytest.raises(ValueError):
        json.dumps({"x": bad}, separators=(",", ":"), allow_nan=False, default=_jsonable)
    with pytest.raises(ValueError):
        _ENCODER.encode({"x": bad})
