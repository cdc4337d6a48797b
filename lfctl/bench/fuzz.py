"""Hostile MAVLink datagrams for the link fuzz benchmark and tests: random bytes; valid
MAVLink 1 and 2 frames of every message id the dialect defines with hostile field values
(NaN, infinities, the edges of each integer type, values of the field's enum: real commands,
modes and frames); frames of the messages a vehicle handles, addressed to it; mutated
frames; truncated frames; bad CRCs; unknown message ids; signed frames with forged
signatures. Seeded: the same seed gives the same datagrams."""

from __future__ import annotations

import math
import random
import struct
from collections.abc import Iterator

from pymavlink.dialects.v20 import ardupilotmega as mav

from lfctl.link.endpoint import VehicleEndpoint

__all__ = ["datagrams"]

#: float values no sender should send and every receiver must survive
HOSTILE_FLOATS = (math.nan, math.inf, -math.inf, 1e38, -1e38, 0.0, -1.0, 1.0, 65535.0, 2.0**31)
KINDS = ("random", "v1", "v2", "handled", "mutated", "truncated", "bad_crc", "unknown_id", "signed")
#: the systems and components the "handled" frames are addressed to: everyone, the vehicles
#: a run numbers from 1, their autopilot and their companion
TARGET_SYSTEMS = (0, 1, 2)
TARGET_COMPONENTS = (0, 1, 191)


def _codecs() -> tuple[mav.MAVLink, mav.MAVLink, mav.MAVLink]:
    v2 = mav.MAVLink(None, srcSystem=255, srcComponent=190)
    v1 = mav.MAVLink(None, srcSystem=255, srcComponent=190)
    v1.WIRE_PROTOCOL_VERSION = "1.0"
    signed = mav.MAVLink(None, srcSystem=255, srcComponent=190)
    signed.signing.secret_key = bytes(range(32))  # not the vehicle's key: the signatures are forged
    signed.signing.sign_outgoing = True
    signed.signing.timestamp = 1
    return v1, v2, signed


def _integer(rnd: random.Random, typ: str, enum: str | None) -> int:
    """A value for an integer field: one its enum defines (half the time, when it has one: a
    real command or frame reaches the code that handles it), else an edge of its type or
    anything in its range."""
    if enum is not None and enum in mav.enums and rnd.random() < 0.5:
        return rnd.choice([k for k in mav.enums[enum] if not mav.enums[enum][k].name.endswith("_ENUM_END")])
    bits = int(typ.removeprefix("u").removeprefix("int").removesuffix("_t"))
    lo, hi = (-(2 ** (bits - 1)), 2 ** (bits - 1) - 1) if not typ.startswith("u") else (0, 2**bits - 1)
    return rnd.choice((0, 1, 2, 127, 255, lo, hi, rnd.randint(lo, hi), rnd.randrange(256)))


def _frame(rnd: random.Random, codec: mav.MAVLink, classes: list[type], addressed: bool = False) -> bytearray | None:
    cls = rnd.choice(classes)
    # fieldnames and fieldtypes are in the definition's order, array_lengths in the wire's
    lengths = dict(zip(cls.ordered_fieldnames, cls.array_lengths, strict=True))
    enums = getattr(cls, "fieldenums_by_name", {})
    args: list[object] = []
    for name, typ in zip(cls.fieldnames, cls.fieldtypes, strict=True):
        length = lengths[name]
        if typ in ("float", "double"):
            # a hostile value, or a small whole number (a command's message id, mode, item)
            v: object = rnd.choice(HOSTILE_FLOATS) if rnd.random() < 0.7 else float(rnd.randrange(600))
        elif typ == "char":
            v = bytes(rnd.randrange(256) for _ in range(max(1, length)))
        elif addressed and name == "target_system":
            v = rnd.choice(TARGET_SYSTEMS)
        elif addressed and name == "target_component":
            v = rnd.choice(TARGET_COMPONENTS)
        else:
            v = _integer(rnd, typ, enums.get(name))
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
    handled = [c for c in classes if hasattr(VehicleEndpoint, f"_on_{c.msgname.lower()}")]
    made = 0
    while made < n:
        kind = KINDS[made % len(KINDS)]
        if kind == "random":
            out: bytes | bytearray | None = bytes(rnd.randrange(256) for _ in range(rnd.randrange(1, 300)))
        else:
            codec = {"v1": v1, "signed": signed}.get(kind, v2)
            out = _frame(rnd, codec, handled, addressed=True) if kind == "handled" else _frame(rnd, codec, classes)
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
