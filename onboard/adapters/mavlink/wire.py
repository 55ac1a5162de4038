"""Robust datagram decoding and MAVLink 2 signing: every datagram on its own, signature before timestamp.

pymavlink's parser is a stream parser: a truncated datagram leaves bytes in its buffer that swallow the
start of the next one. Here each datagram is split into frames by their declared lengths and each frame is
decoded on its own; a frame that fails (bad CRC, bad length, truncated) is counted, and the scan resumes at
the next start marker after its first byte, so a valid packet behind garbage is still found.

pymavlink records a signed packet's timestamp before it compares the signature, so one forged packet with a
future timestamp would lock the real ground station out. :class:`SigningVerifier` checks the HMAC first and
only then the timestamp (https://mavlink.io/en/guide/message_signing.html).
"""

from __future__ import annotations

import hashlib
import hmac
import struct
import time
from collections.abc import Callable
from dataclasses import dataclass

from pymavlink.dialects.v20 import common as mavlink

MAGIC_V1 = 0xFE
MAGIC_V2 = 0xFD
IFLAG_SIGNED = 0x01
SIGNATURE_LEN = 13
_EPOCH_2015_S = 1420070400.0
MAX_NEW_STREAM_LAG = 6_000_000  # 60 s in 10 us units, as the spec recommends


def signing_timestamp_now() -> int:
    """Current signing timestamp: 10 us units since 2015-01-01 UTC."""
    return int((time.time() - _EPOCH_2015_S) * 100_000)


@dataclass
class RxStats:
    """Receive counters (read by tests and reported in SYS_STATUS)."""

    datagrams: int = 0
    packets: int = 0
    malformed: int = 0  # bad CRC, bad length, truncated, garbage bytes before a marker
    unknown: int = 0  # well-formed but not in the common dialect
    unsigned_rejected: int = 0
    bad_signature: int = 0
    old_timestamp: int = 0
    shed: int = 0  # datagrams dropped unparsed because the receive budget was used up


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
        self.timestamp = max(signing_timestamp_now(), floor)
        self._on_advance = on_advance

    def verify(self, frame: bytes, stats: RxStats) -> bool:
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
        now = max(self.timestamp, signing_timestamp_now())
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
        self.timestamp = max(self.timestamp, ts)
        return True


def _frame_length(data: bytes, i: int) -> int | None:
    """Declared length of the frame starting at ``data[i]`` (None if even the header is cut off)."""
    n = len(data) - i
    if data[i] == MAGIC_V2:
        if n < 3:
            return None
        return 10 + data[i + 1] + 2 + (SIGNATURE_LEN if data[i + 2] & IFLAG_SIGNED else 0)
    if n < 2:
        return None
    return 6 + data[i + 1] + 2


def decode_datagram(
    data: bytes, stats: RxStats, verifier: SigningVerifier | None = None
) -> list[tuple[mavlink.MAVLink_message, bytes]]:
    """All valid messages in one datagram, each with its raw frame; everything else is counted."""
    stats.datagrams += 1
    out: list[tuple[mavlink.MAVLink_message, bytes]] = []
    parser = mavlink.MAVLink(None)  # fresh per datagram: no state carries over
    i, n = 0, len(data)
    while i < n:
        if data[i] not in (MAGIC_V1, MAGIC_V2):
            j = i + 1
            while j < n and data[j] not in (MAGIC_V1, MAGIC_V2):
                j += 1
            stats.malformed += 1
            i = j
            continue
        length = _frame_length(data, i)
        if length is None or i + length > n:
            stats.malformed += 1  # truncated: skip this marker, look for another
            i += 1
            continue
        frame = bytes(data[i : i + length])
        if data[i] == MAGIC_V2 and data[i + 2] & ~IFLAG_SIGNED:
            stats.malformed += 1
            i += 1
            continue
        try:
            msg = parser.decode(bytearray(frame))
        except Exception:  # pymavlink raises MAVError, struct.error, ... on damaged frames
            stats.malformed += 1
            i += 1
            continue
        if isinstance(msg, mavlink.MAVLink_unknown) or msg.get_type() == "BAD_DATA":
            # pymavlink cannot check the CRC of an unknown id, so its length is not trusted either
            stats.unknown += 1
            i += 1
            continue
        i += length
        if verifier is not None and not verifier.verify(frame, stats):
            continue
        stats.packets += 1
        out.append((msg, frame))
    return out
