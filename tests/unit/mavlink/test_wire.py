"""Datagram decoding (each datagram on its own, garbage counted) and signing (signature before timestamp)."""

from __future__ import annotations

import struct

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pymavlink.dialects.v20 import common as mavlink

from onboard.adapters.mavlink.wire import RxStats, SigningVerifier, decode_datagram, signing_timestamp_now

KEY = bytes(range(32))


class _Sink:
    def __init__(self) -> None:
        self.buf = b""

    def write(self, b: bytes) -> None:
        self.buf += bytes(b)


def packet(
    msg: mavlink.MAVLink_message, key: bytes | None = None, ts: int | None = None, sysid: int = 255
) -> bytes:
    sink = _Sink()
    mav = mavlink.MAVLink(sink, sysid, 190)
    if key is not None:
        mav.signing.secret_key = key
        mav.signing.sign_outgoing = True
        mav.signing.timestamp = signing_timestamp_now() if ts is None else ts
    mav.send(msg)
    return sink.buf


HB = mavlink.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3)
COUNT = mavlink.MAVLink_mission_count_message(1, 1, 3, 0)


def test_valid_packets_decode_and_are_counted() -> None:
    st_ = RxStats()
    out = decode_datagram(packet(HB) + packet(COUNT), st_)
    assert [m.get_type() for m, _ in out] == ["HEARTBEAT", "MISSION_COUNT"]
    assert st_.packets == 2 and st_.malformed == 0


def test_valid_packet_after_truncated_one_is_understood() -> None:
    # GIVEN a truncated datagram WHEN the next datagram holds a valid packet THEN it is decoded
    st_ = RxStats()
    full = packet(COUNT)
    assert decode_datagram(full[:7], st_) == []
    ((m, _),) = decode_datagram(full, st_)
    assert m.get_type() == "MISSION_COUNT" and m.count == 3
    # and inside one datagram a cut packet followed by a valid one is skipped, not swallowing it
    out = decode_datagram(packet(HB)[:9] + full, st_)
    assert [x.get_type() for x, _ in out] == ["MISSION_COUNT"]
    assert st_.malformed >= 2


@settings(max_examples=400, deadline=None)
@given(st.binary(max_size=300))
def test_random_bytes_never_crash(data: bytes) -> None:
    st_ = RxStats()
    out = decode_datagram(data, st_)
    assert all(m.get_type() != "BAD_DATA" for m, _ in out)


@settings(max_examples=400, deadline=None)
@given(st.integers(0, 10_000), st.integers(0, 7))
def test_bit_flipped_packets_are_rejected_and_counted(pos: int, bit: int) -> None:
    raw = bytearray(packet(COUNT))
    i = pos % len(raw)
    raw[i] ^= 1 << bit
    st_ = RxStats()
    out = decode_datagram(bytes(raw), st_)
    # a flipped bit is caught by the CRC (or frames differently); never a changed MISSION_COUNT
    assert all(not (m.get_type() == "MISSION_COUNT" and m.count != 3) for m, _ in out)
    if not out:
        assert st_.malformed + st_.unknown >= 1


def test_signing_accepts_signed_and_rejects_unsigned_and_wrong_key() -> None:
    v = SigningVerifier(KEY)
    st_ = RxStats()
    assert len(decode_datagram(packet(COUNT, KEY), st_, v)) == 1
    assert decode_datagram(packet(COUNT), st_, v) == []
    assert decode_datagram(packet(COUNT, bytes(32)), st_, v) == []
    assert st_.unsigned_rejected == 1 and st_.bad_signature == 1


def test_forged_future_timestamp_does_not_lock_out_the_real_gcs() -> None:
    # GIVEN a forged packet with a far-future timestamp and a wrong signature, from the GCS's ids
    v = SigningVerifier(KEY)
    st_ = RxStats()
    future = signing_timestamp_now() + 10**12
    assert decode_datagram(packet(COUNT, bytes([7]) * 32, ts=future), st_, v) == []
    # WHEN the real GCS sends with the current time THEN it is still accepted
    assert len(decode_datagram(packet(COUNT, KEY), st_, v)) == 1


def test_replayed_packet_and_stale_new_stream_rejected() -> None:
    v = SigningVerifier(KEY)
    st_ = RxStats()
    p = packet(COUNT, KEY)
    assert len(decode_datagram(p, st_, v)) == 1
    assert decode_datagram(p, st_, v) == []  # same timestamp again
    old = packet(COUNT, KEY, ts=signing_timestamp_now() - 10**8, sysid=200)  # new stream, 1000 s old
    assert decode_datagram(old, st_, v) == []
    assert st_.old_timestamp == 2


def test_the_persisted_floor_refuses_a_replay_on_a_new_stream_and_each_advance_is_handed_on() -> None:
    # GIVEN a packet accepted before a restart, whose timestamp the vehicle persisted (the floor)
    saved: list[int] = []
    p = packet(COUNT, KEY)
    before = SigningVerifier(KEY, on_advance=saved.append)
    assert len(decode_datagram(p, RxStats(), before)) == 1 and len(saved) == 1
    # WHEN the restarted vehicle (no streams in memory) sees it again
    after = SigningVerifier(KEY, floor=saved[-1], on_advance=saved.append)
    st_ = RxStats()
    # THEN it is refused, though a new stream within a minute of now would otherwise pass
    assert decode_datagram(p, st_, after) == [] and st_.old_timestamp == 1
    # and a fresh packet passes and advances the floor that is persisted
    fresh = packet(COUNT, KEY, ts=saved[-1] + 1)
    assert len(decode_datagram(fresh, st_, after)) == 1 and saved[-1] == after.accepted


def test_signature_bytes_layout_matches_spec() -> None:
    p = packet(COUNT, KEY)
    assert p[2] & 1 and len(p) == 10 + p[1] + 2 + 13
    ts_low, ts_high = struct.unpack("<IH", p[-12:-6])
    assert abs((ts_low + (ts_high << 32)) - signing_timestamp_now()) < 10**6


def test_verifier_needs_32_byte_key() -> None:
    with pytest.raises(ValueError):
        SigningVerifier(b"short")
