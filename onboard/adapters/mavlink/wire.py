"""Robust datagram decoding and MAVLink 2 signing: every datagram on its own, signature before timestamp.

pymavlink's parser is a stream parser: a truncated datagram leaves bytes in its buffer that swallow the
start of the next one. Here each datagram is split into frames by their declared lengths and each frame is
decoded on its own; a frame that fails (bad CRC, bad length, truncated) is counted, and the scan resumes at
the next start marker after its first byte, so a valid packet behind garbage is still found.

Signing: :class:`auv_common.mavlink_signing.SigningVerifier` (shared with the ground station) checks the
HMAC before the timestamp.
"""

from __future__ import annotations

from dataclasses import dataclass

from pymavlink.dialects.v20 import common as mavlink

from auv_common.mavlink_signing import (
    IFLAG_SIGNED,
    MAGIC_V2,
    SIGNATURE_LEN,
    SigningVerifier,
    signing_timestamp_now,
)

__all__ = [
    "MAGIC_V1",
    "MAGIC_V2",
    "UNSIGNED_ALLOWED",
    "RxStats",
    "SigningVerifier",
    "accept_frame",
    "decode_datagram",
    "signing_timestamp_now",
]

MAGIC_V1 = 0xFE

#: The messages taken unsigned while signing is on, as the spec allows: a radio cannot sign its RADIO_STATUS,
#: and a HEARTBEAT says nothing. Neither makes its sender a peer nor keeps a GCS link alive (an unsigned
#: heartbeat is no sign of the operator); nothing unsigned can command, upload or set.
UNSIGNED_ALLOWED = frozenset({mavlink.MAVLINK_MSG_ID_HEARTBEAT, mavlink.MAVLINK_MSG_ID_RADIO_STATUS})
#: A datagram longer than this is dropped unread (counted): a ground station sends one frame (at most 280
#: bytes) per datagram, a few at most; 64 kB of garbage would cost the link's thread 0.2 s to scan.
MAX_DATAGRAM_BYTES = 2048
#: A datagram is read no further after this many malformed spots (a genuine one has none).
MAX_MALFORMED_PER_DATAGRAM = 4


def accept_frame(
    frame: bytes,
    msg: mavlink.MAVLink_message,
    stats: RxStats,
    verifier: SigningVerifier | None,
    secure: bool = False,
) -> bool:
    """Whether a decoded frame is used: always without signing; with it, when signed with our key and fresh
    (``msg.get_signed()`` then True), or unsigned and in :data:`UNSIGNED_ALLOWED` (counted), or an
    unsigned SETUP_SIGNING over a secure endpoint (``secure``: how a lost key is replaced)."""
    if verifier is None:
        return True
    if frame[0] != MAGIC_V2 or not frame[2] & IFLAG_SIGNED:
        mid = msg.get_msgId()
        if mid in UNSIGNED_ALLOWED or (secure and mid == mavlink.MAVLINK_MSG_ID_SETUP_SIGNING):
            stats.unsigned_accepted += 1
            return True
    if not verifier.verify(frame, stats):
        return False
    msg._signed = True  # checked by us (pymavlink's own flag stays False without its key)
    return True


@dataclass
class RxStats:
    """Receive counters (read by tests and reported in SYS_STATUS)."""

    datagrams: int = 0
    packets: int = 0
    malformed: int = 0  # bad CRC, bad length, truncated, garbage bytes before a marker
    unknown: int = 0  # well-formed but not in the common dialect
    unsigned_rejected: int = 0
    unsigned_accepted: int = 0  # HEARTBEAT / RADIO_STATUS taken unsigned while signing is on
    bad_signature: int = 0
    old_timestamp: int = 0
    shed: int = 0  # datagrams (TCP: messages, after parsing) dropped: the sender's receive share was used up
    shed_from_peers: int = 0  # of those, from known peers (the rest from strangers)
    peers_refused: int = 0  # new addresses (TCP connections) refused as peers: the table was full
    oversize: int = 0  # datagrams longer than MAX_DATAGRAM_BYTES, dropped unread


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
    data: bytes, stats: RxStats, verifier: SigningVerifier | None = None, secure: bool = False
) -> list[tuple[mavlink.MAVLink_message, bytes]]:
    """All valid messages in one datagram, each with its raw frame; everything else is counted. A datagram
    over :data:`MAX_DATAGRAM_BYTES` is not read, one is read no further after
    :data:`MAX_MALFORMED_PER_DATAGRAM` malformed spots (``secure``: see :func:`accept_frame`)."""
    stats.datagrams += 1
    out: list[tuple[mavlink.MAVLink_message, bytes]] = []
    if len(data) > MAX_DATAGRAM_BYTES:
        stats.oversize += 1
        return out
    parser = mavlink.MAVLink(None)  # fresh per datagram: no state carries over
    i, n = 0, len(data)
    malformed_before = stats.malformed
    while i < n:
        if stats.malformed - malformed_before >= MAX_MALFORMED_PER_DATAGRAM:
            break
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
        if not accept_frame(frame, msg, stats, verifier, secure):
            continue
        stats.packets += 1
        out.append((msg, frame))
    return out
