"""MAVLink 2 signing: a key from a passphrase, and signing set up on a MAVLink object."""

from __future__ import annotations

import hashlib
import time
from typing import Any

__all__ = ["setup_signing", "signing_key_from_passphrase"]

#: the signing timestamp counts 10 us units since 2015-01-01 00:00 UTC
SIGNING_EPOCH_UNIX_S = 1420070400


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
    m.signing.timestamp = int((time.time() - SIGNING_EPOCH_UNIX_S) * 1e5)
    m.signing.allow_unsigned_callback = lambda _mav, _msgid: False
