"""MAVLink 2 signing checked the safe way round, for the vehicle and the ground station alike.

pymavlink records a signed packet's timestamp before it compares the signature, so one forged packet with a
future timestamp would lock the real peer out. :class:`SigningVerifier` checks the HMAC first and only then
the timestamp (https://mavlink.io/en/guide/message_signing.html): per stream (link id, system, component)
increasing; a new stream at most a minute behind the local time; and never at or below ``floor``, the newest
timestamp accepted before a restart (persisted by the caller through ``on_advance``).
"""

from __future__ import annotations

import hashlib
import hmac
import struct
import time
from collections.abc import Callable
from typing import Protocol

MAGIC_V2 = 0xFD
IFLAG_SIGNED = 0x01
SIGNATURE_LEN = 13
_EPOCH_2015_S = 1420070400.0
MAX_NEW_STREAM_LAG = 6_000_000  # 60 s in 10 us units, as the spec recommends


def signing_timestamp_now() -> int:
    """Current signing timestamp: 10 us units since 2015-01-01 UTC."""
    return int((time.time() - _EPOCH_2015_S) * 100_000)


class SigningCounters(Protocol):
    """Where the verifier counts what it refuses (the vehicle's RxStats, the ground station's)."""

    unsigned_rejected: int
    bad_signature: int
    old_timestamp: int


class SigningVerifier:
    """MAVLink 2 signature check with per-stream timestamps, HMAC verified before any timestamp is kept."""

    def __init__(self, key: bytes, floor: int = 0, on_advance: Callable[[int], None] | None = None) -> None:
        """``floor``: the newest timestamp accepted before a restart (persisted): no packet at or below it
        is accepted, on any stream (a replay across the restart). ``on_advance(ts)`` is called with each
        newer timestamp accepted, before the packet is used (the caller persists it)."""
        if len(key) != 32:
            raise ValueError("a MAVLink signing key has 32 bytes")
        self._key = key
        self._streams: dict[tuple[int, int, int], int] = {}
        self.floor = floor
        self.accepted = floor  # the newest timestamp accepted (and handed to on_advance)
        self._on_advance = on_advance

    def verify(self, frame: bytes, stats: SigningCounters) -> bool:
        """True if ``frame`` (one whole MAVLink 2 packet) is signed with our key and is fresh."""
        if frame[0] != MAGIC_V2 or not frame[2] & IFLAG_SIGNED or len(frame) < 12 + SIGNATURE_LEN:
            stats.unsigned_rejected += 1
            return False
        expected = hashlib.sha256(self._key + frame[:-6]).digest()[:6]
        if not hmac.compare_digest(expected, frame[-6:]):
            stats.bad_signature += 1
            return False
        link_id = frame[-13]
        tlow, thigh = struct.unpack("<IH", frame[-12:-6])
        ts = tlow + (thigh << 32)
        stream = (link_id, frame[5], frame[6])
        last = self._streams.get(stream)
        now = max(self.accepted, signing_timestamp_now())  # the local time: the clock, or what was seen
        if (
            ts <= self.floor
            or (last is not None and ts <= last)
            or (last is None and ts + MAX_NEW_STREAM_LAG < now)
        ):
            stats.old_timestamp += 1
            return False
        if ts > self.accepted:
            if self._on_advance is not None:
                self._on_advance(ts)  # persisted before the packet is used
            self.accepted = ts
        self._streams[stream] = ts
        return True
