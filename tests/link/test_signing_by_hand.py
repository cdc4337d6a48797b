"""MAVLink 2 signing (lfctl.link.signing) packet by packet: pymavlink's own signer makes the
packets, at timestamps the tests choose, and a receiver set up by setup_signing takes or
refuses each. The clocks are set by hand (10 us units since 2015-01-01), not read."""

from __future__ import annotations

import hashlib

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mav
from pymavlink.generator.mavcrc import x25crc

from lfctl.link.signing import (
    REPLAY_WINDOW_10US,
    advance_signing_clock,
    setup_signing,
    signing_clock,
    signing_key_from_passphrase,
)

KEY = signing_key_from_passphrase("rover convoy")
T0 = 38_000_000_000_000  # 2027-01-16 in 10 us units since 2015 (12.04 years); 48 bits hold 2^48 = 2.8e14


def signer(key: bytes = KEY, link_id: int = 0, system: int = 1) -> mav.MAVLink:
    s = mav.MAVLink(None, srcSystem=system, srcComponent=1)
    s.signing.secret_key, s.signing.sign_outgoing, s.signing.link_id = key, True, link_id
    return s


def packet(s: mav.MAVLink, timestamp: int) -> bytes:
    s.signing.timestamp = timestamp
    return bytes(s.heartbeat_encode(10, 8, 0, 0, 4).pack(s))


def receiver(clock: int = T0) -> mav.MAVLink:
    r = mav.MAVLink(None)
    setup_signing(r, KEY)
    r.signing.timestamp = clock
    return r


def takes(r: mav.MAVLink, data: bytes) -> bool:
    try:
        return [m.get_type() for m in r.parse_buffer(data) or []] == ["HEARTBEAT"]
    except mav.MAVError as e:
        assert "signature" in str(e)
        return False


def test_the_key_is_the_passphrases_sha256_and_no_passphrase_is_no_signing() -> None:
    assert hashlib.sha256(b"rover convoy").digest() == KEY and len(KEY) == 32
    assert signing_key_from_passphrase("") is None and signing_key_from_passphrase(None) is None


def test_the_signing_clock_counts_10_us_since_2015() -> None:
    # 2015-01-01 00:00 UTC is 1420070400 s after the Unix epoch; one second later: 100000
    assert signing_clock(1420070400.0) == 0
    assert signing_clock(1420070401.0) == 100_000
    assert signing_clock(1420070400.00125) == 125


def test_a_genuine_packet_is_taken_and_moves_the_clock_to_its_timestamp() -> None:
    r = receiver()
    assert takes(r, packet(signer(), T0 + 500))
    assert r.signing.timestamp == T0 + 500


def with_crc(data: bytearray) -> bytes:
    """The packet with its CRC made good again (X.25 over the header after the magic and the
    payload, then the message's CRC extra: 50 for HEARTBEAT), as a forger would."""
    n = 10 + data[1]
    crc = x25crc(bytes(data[1:n]))
    crc.accumulate(bytes([mav.MAVLink_heartbeat_message.crc_extra]))
    data[n : n + 2] = crc.crc.to_bytes(2, "little")
    return bytes(data)


def test_one_flipped_bit_in_what_the_signature_covers_is_refused() -> None:
    # 10 header bytes, 9 of payload, 2 of CRC, then the link id, 6 of timestamp, 6 of signature
    good = bytearray(packet(signer(), T0 + 1))
    assert takes(receiver(), with_crc(bytearray(good)))  # the CRC rewrite alone changes nothing
    for at in (4, 5, 6, 14, 21, 22, 27):  # sequence, sender system and component, payload, link id, timestamp
        bad = bytearray(good)
        bad[at] ^= 0x01
        assert not takes(receiver(), with_crc(bad)), at
    for at in (-6, -1):  # the signature's first and last bytes
        bad = bytearray(good)
        bad[at] ^= 0x01
        assert not takes(receiver(), bytes(bad)), at


def test_a_packet_signed_with_another_key_is_refused_and_changes_nothing() -> None:
    # a forger's packet stamped far ahead: refused, and neither our clock nor the stream's
    # last timestamp moves, so the real sender's next packet is still taken
    r = receiver()
    assert not takes(r, packet(signer(key=b"\x01" * 32), T0 + 10**12))
    assert r.signing.timestamp == T0 and not r.signing.stream_timestamps
    assert takes(r, packet(signer(), T0 + 2))


def test_a_replay_and_an_older_packet_of_the_same_stream_are_refused() -> None:
    r, s = receiver(), signer()
    first = packet(s, T0 + 100)
    assert takes(r, first)
    assert not takes(r, first)  # the same packet again
    assert not takes(r, packet(s, T0 + 100))  # the same timestamp
    assert not takes(r, packet(s, T0 + 99))  # older
    assert takes(r, packet(s, T0 + 101))


def test_each_link_id_and_system_is_its_own_stream() -> None:
    r = receiver()
    assert takes(r, packet(signer(link_id=0), T0 + 100))
    assert takes(r, packet(signer(link_id=1), T0 + 50))  # another link: its own last timestamp
    assert takes(r, packet(signer(system=2), T0 + 50))  # another system likewise
    assert set(r.signing.stream_timestamps) == {(0, 1, 1), (1, 1, 1), (0, 2, 1)}  # (link, system, component)


def test_a_new_stream_may_lag_our_clock_by_a_minute_and_no_more() -> None:
    # a minute is 60 * 100000 units: a first packet exactly that far behind is taken, one unit
    # further is a capture from before (refused)
    assert takes(receiver(), packet(signer(), T0 - REPLAY_WINDOW_10US))
    assert not takes(receiver(), packet(signer(), T0 - REPLAY_WINDOW_10US - 1))
    # a new stream behind our clock does not take the clock back with it
    r = receiver()
    assert takes(r, packet(signer(), T0 - 100)) and r.signing.timestamp == T0
    assert REPLAY_WINDOW_10US == 6_000_000


def test_an_unsigned_packet_is_refused() -> None:
    plain = mav.MAVLink(None, srcSystem=1, srcComponent=1)
    assert not takes(receiver(), bytes(plain.heartbeat_encode(10, 8, 0, 0, 4).pack(plain)))


def test_the_clock_advances_to_the_wall_clock_and_never_back() -> None:
    r = receiver(clock=T0)
    advance_signing_clock(r.signing, 1420070400.0 + T0 / 1e5 + 2.0)  # 2 s later
    assert r.signing.timestamp == T0 + 200_000
    advance_signing_clock(r.signing, 1420070400.0)  # 2015: not back
    assert r.signing.timestamp == T0 + 200_000


@pytest.mark.parametrize("length", [0, 12])
def test_a_packet_too_short_to_hold_a_signature_is_refused_by_the_check(length: int) -> None:
    r = receiver()
    assert r.check_signature(bytearray(length), 1, 1) is False
