"""MAVLink 2 signing: a key from a passphrase, and signing set up on a MAVLink object."""

from __future__ import annotations

import hashlib
import hmac
import time
import types
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mav

__all__ = [
    "VerifyingMAVLink",
    "advance_signing_clock",
    "setup_signing",
    "signing_clock",
    "signing_key_from_passphrase",
]

#: the signing timestamp counts 10 us units since 2015-01-01 00:00 UTC
SIGNING_EPOCH_UNIX_S = 1420070400
#: a new stream's timestamp may lag our clock by at most a minute (10 us units)
REPLAY_WINDOW_10US = 60 * 100_000


def signing_key_from_passphrase(passphrase: str | None) -> bytes | None:
    """The 32-byte signing key of a passphrase (SHA-256, as MAVProxy's ``signing setup``);
    None (no signing) for no or an empty passphrase.

    Parameters
    ----------
    passphrase : str or None
        The shared secret.
    """
    return hashlib.sha256(passphrase.encode()).digest() if passphrase else None


def setup_signing(m: Any, key: bytes) -> None:
    """Sign what ``m`` sends with ``key`` and refuse unsigned packets it receives.

    Parameters
    ----------
    m : pymavlink MAVLink object
        The codec to set up.
    key : bytes
        The 32-byte secret key.
    """
    m.signing.secret_key = key
    m.signing.sign_outgoing = True
    m.signing.link_id = 0
    m.signing.timestamp = signing_clock(time.time())
    m.signing.allow_unsigned_callback = lambda _mav, _msgid: False
    # verify before any replay state changes (see VerifyingMAVLink), on any pymavlink object
    m.check_signature = types.MethodType(VerifyingMAVLink.check_signature, m)


class VerifyingMAVLink(mav.MAVLink):
    """A pymavlink parser whose signature check changes nothing until the signature holds.

    pymavlink records a stream's timestamp before it verifies the signature, so one forged
    packet with a far-future timestamp locks the real sender out, and a forged copy sent
    ahead of a genuine packet burns it. Here the signature is checked first; only a verified
    packet moves its stream's timestamp (per link id, system and component) and our clock.
    A new stream is taken when its timestamp is at most a minute behind our clock, which
    starts from the wall clock, so a capture from an earlier run is refused.
    """

    def check_signature(self, msgbuf: bytearray, srcSystem: int, srcComponent: int) -> bool:
        """Whether a signed packet is genuine and new (pymavlink calls this while decoding).

        Parameters
        ----------
        msgbuf : bytearray
            The whole packet, signature included.
        srcSystem, srcComponent : int
            Its sender.
        """
        key = self.signing.secret_key
        if key is None or len(msgbuf) < 13:
            return False
        digest = hashlib.sha256(bytes(key) + bytes(msgbuf[:-6])).digest()[:6]
        if not hmac.compare_digest(digest, bytes(msgbuf[-6:])):
            return False
        tlow, thigh = self.mav_sign_unpacker.unpack(msgbuf[-12:-6])
        timestamp = tlow + (thigh << 32)
        stream = (msgbuf[-13], srcSystem, srcComponent)
        last = self.signing.stream_timestamps.get(stream)
        if last is not None:
            if timestamp <= last:
                return False  # a replay
        elif timestamp + REPLAY_WINDOW_10US < self.signing.timestamp:
            return False  # a new stream from more than a minute ago: an old capture
        self.signing.stream_timestamps[stream] = timestamp
        self.signing.timestamp = max(self.signing.timestamp, timestamp)
        return True


def signing_clock(now_unix_s: float) -> int:
    """The MAVLink signing timestamp of a wall-clock time: 10 us units since 2015-01-01.

    Parameters
    ----------
    now_unix_s : float
        Seconds since the Unix epoch.
    """
    return int((now_unix_s - SIGNING_EPOCH_UNIX_S) * 1e5)


def advance_signing_clock(signing: Any, now_unix_s: float) -> None:
    """Move a signing state's clock up to the wall clock (never back), as ArduPilot does on
    GPS time, so the replay window follows real time in a long run.

    Parameters
    ----------
    signing : pymavlink MAVLinkSigning
        The state to advance.
    now_unix_s : float
        Seconds since the Unix epoch.
    """
    signing.timestamp = max(signing.timestamp, signing_clock(now_unix_s))
