"""Hostile MAVLink datagrams for the link fuzz benchmark and tests: random bytes; valid
MAVLink 1 and 2 frames of every message id the dialect defines with hostile field values
(NaN, infinities, extremes); mutated frames; truncated frames; bad CRCs; unknown message ids;
signed frames with forged signatures. Seeded: the same seed gives the same datagrams."""

from __future__ import annotations

import math
import random
import struct
from collections.abc import Iterator

from pymavlink.dialects.v20 import ardupilotmega as mav

__all__ = ["datagrams"]

#: float values no sender should send and every receiver must survive
HOSTILE_FLOATS = (math.nan, math.inf, -math.inf, 1e38, -1e38, 0.0, -1.0, 1.0, 65535.0, 2.0**31)
KINDS = ("random", "v1", "v2", "mutated", "truncated", "bad_crc", "unknown_id", "signed")


def _codecs() -> tuple[mav.MAVLink, mav.MAVLink, mav.MAVLink]:
    v2 = mav.MAVLink(None, srcSystem=255, srcComponent=190)
    v1 = mav.MAVLink(None, srcSystem=255, srcComponent=190)
    v1.WIRE_PROTOCOL_VERSION = "1.0"
    signed = mav.MAVLink(None, srcSystem=255, srcComponent=190)
    signed.signing.secret_key = bytes(range(32))  # not the vehicle's key: the signatures are forged
    signed.signing.sign_outgoing = True
    signed.signing.timestamp = 1
    return v1, v2, signed


def _frame(rnd: random.Random, codec: mav.MAVLink, classes: list[type]) -> bytearray | None:
    cls = rnd.choice(classes)
    args: list[object] = []
    for typ, length in zip(cls.fieldtypes, cls.array_lengths, strict=False):
        if typ in ("float", "double"):
            v: object = rnd.choice(HOSTILE_FLOATS)
        elif typ == "char":
            v = bytes(rnd.randrange(256) for _ in range(max(1, length)))
        else:
            v = rnd.choice((0, 1, 2, 127, 255, rnd.randrange(256)))
        args.append([v] * length if length and typ != "char" else v)
    try:
        return bytearray(cls(*args).pack(codec))
    except Exception:  # a value this field cannot hold: try another message
        return None


def datagrams(seed: int, n: int) -> Iterator[bytes]:
    """``n`` hostile datagrams, the kinds in turn (see :data:`KINDS`).

    Parameters
    ----------
    seed : int
        The random seed.
    n : int
        How many.
    """
    rnd = random.Random(seed)
    v1, v2, signed = _codecs()
    classes = [c for c in mav.mavlink_map.values() if hasattr(c, "fieldnames")]
    made = 0
    while made < n:
        kind = KINDS[made % len(KINDS)]
        if kind == "random":
            out: bytes | bytearray | None = bytes(rnd.randrange(256) for _ in range(rnd.randrange(1, 300)))
        else:
            codec = {"v1": v1, "signed": signed}.get(kind, v2)
            out = _frame(rnd, codec, classes)
            if out is None:
                continue
            if kind == "mutated" and len(out) > 12:
                out[rnd.randrange(10, len(out) - 2)] ^= 1 << rnd.randrange(8)
            elif kind == "truncated":
                out = out[: rnd.randrange(1, len(out))]
            elif kind == "bad_crc":
                out[-2] ^= 0xFF
            elif kind == "unknown_id" and out[0] == 0xFD:
                out[7:10] = rnd.randrange(60000, 2**24).to_bytes(3, "little")
                crc = mav.x25crc(out[1:-2])
                crc.accumulate(struct.pack("B", 0))
                out[-2:] = struct.pack("<H", crc.crc)
        made += 1
        yield bytes(out)
