"""SETUP_SIGNING and the unsigned messages signing allows (issue 12, item 2), on a real link (sockets, the
I/O thread, the core), with MavClient as the ground station."""

from __future__ import annotations

import socket
import time
from pathlib import Path

import pytest
from pymavlink.dialects.v20 import common as mavlink

from auv_common.mavlink_signing import signing_timestamp_now
from groundstation.mavclient import LinkError, MavClient
from tests.waiting import wait_until

from .conftest import Vehicle

KEY = bytes(range(100, 132))
NEW_KEY = bytes(range(200, 232))


def _vehicle(state: Path) -> Vehicle:
    return Vehicle(
        state,
        endpoints=("udpin:127.0.0.1:0", "tcpin:127.0.0.1:0"),
        secure_endpoints=("tcpin:127.0.0.1:0",),
    ).start()


def _client(url: str, key: bytes | None = None) -> MavClient:
    c = MavClient(url, signing_key=key, system_id=210)
    c.heartbeat()
    c.wait_heartbeat(3.0)
    return c


def _setup(c: MavClient, key: bytes, timestamp: int) -> str:
    """Send SETUP_SIGNING and return the vehicle's STATUSTEXT about it."""
    t = time.monotonic()
    c.send(mavlink.MAVLink_setup_signing_message(1, 1, key, timestamp))
    deadline = time.monotonic() + 3.0
    while time.monotonic() < deadline:
        c.recv(0.1)
        for text in c.texts_since(t):
            if "SETUP_SIGNING" in text.text or "signing" in text.text:
                return text.text
    return ""


def _answers(url: str, key: bytes | None) -> bool:
    """Whether a ground station with ``key`` (None: unsigned) gets an answer to a parameter read."""
    c = MavClient(url, signing_key=key, system_id=211)
    try:
        c.heartbeat()
        return c.param_get("LIM_RPS_MAX", resend_s=0.3, retries=3) > 0
    except LinkError:
        return False
    finally:
        c.close()


def test_setup_signing_over_a_secure_endpoint_turns_signing_on_and_survives_a_restart(tmp_path: Path) -> None:
    v = _vehicle(tmp_path / "state")
    udp, tcp = f"udpout:127.0.0.1:{v.link.ports[0]}", f"tcp:127.0.0.1:{v.link.ports[1]}"
    try:
        # GIVEN a vehicle without signing WHEN an unsigned SETUP_SIGNING comes over UDP (not secure)
        c = _client(udp)
        text = _setup(c, KEY, signing_timestamp_now())
        c.close()
        # THEN it is refused, saying why, and nothing changed
        assert "refused" in text and "secure" in text, text
        assert _answers(udp, None)
        # WHEN the same comes over the secure endpoint (TCP on loopback here, a USB serial on a vehicle)
        c = _client(tcp)
        c.mav.signing.secret_key = KEY  # the station signs with the key it sets, from now on
        c.mav.signing.sign_outgoing = True
        c.mav.signing.timestamp = signing_timestamp_now()
        c.send(mavlink.MAVLink_setup_signing_message(1, 1, KEY, signing_timestamp_now()))
        c.close()
        wait_until(lambda: v.link.transport.signing, what="signing on")
        # THEN only signed messages are taken: an unsigned station gets no answer, a signed one does
        assert not _answers(udp, None)
        assert _answers(udp, KEY)
        stats = v.link.stats()
        assert stats["unsigned_rejected"] > 0 and stats["unsigned_accepted"] > 0  # its heartbeats taken
    finally:
        v.stop()
    # and after a restart the key set by SETUP_SIGNING is the key (it wins over the configured one)
    v = _vehicle(tmp_path / "state")
    udp = f"udpout:127.0.0.1:{v.link.ports[0]}"
    try:
        assert not _answers(udp, None)
        assert _answers(udp, KEY)
    finally:
        v.stop()


def test_a_signed_setup_signing_rotates_the_key_and_an_all_zero_one_turns_signing_off(tmp_path: Path) -> None:
    (tmp_path / "key").write_text(KEY.hex())
    v = Vehicle(tmp_path / "state", signing_key_file=str(tmp_path / "key")).start()
    udp = f"udpout:127.0.0.1:{v.port}"
    try:
        # an unsigned SETUP_SIGNING over a link that is not secure: refused (the station holds no key)
        c = _client(udp, KEY)
        raw = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        unsigned = mavlink.MAVLink(None, 66, 1)
        raw.sendto(
            mavlink.MAVLink_setup_signing_message(1, 1, NEW_KEY, 0).pack(unsigned), ("127.0.0.1", v.port)
        )
        raw.close()
        wait_until(lambda: v.link.stats()["unsigned_rejected"] >= 1, what="the unsigned SETUP_SIGNING read")
        assert _answers(udp, KEY)
        # signed with the current key: the key is rotated
        c.send(mavlink.MAVLink_setup_signing_message(1, 1, NEW_KEY, signing_timestamp_now()))
        c.close()
        wait_until(lambda: _answers(udp, NEW_KEY), 20.0, "answers to the new key")
        assert not _answers(udp, KEY)
        # an all-zero key and timestamp, signed with the key: signing off
        c = _client(udp, NEW_KEY)
        c.send(mavlink.MAVLink_setup_signing_message(1, 1, bytes(32), 0))
        c.close()
        wait_until(lambda: not v.link.transport.signing, what="signing off")
        assert _answers(udp, None)
    finally:
        v.stop()


@pytest.mark.parametrize("forged_years", [1, 100])
def test_a_forged_far_future_timestamp_does_not_lock_the_ground_station_out(
    tmp_path: Path, forged_years: int
) -> None:
    (tmp_path / "key").write_text(KEY.hex())
    v = Vehicle(tmp_path / "state", signing_key_file=str(tmp_path / "key")).start()
    try:
        # GIVEN an attacker without the key, signing with a wrong key at a timestamp years ahead
        attacker = mavlink.MAVLink(None, 255, 190)
        attacker.signing.secret_key = bytes(32)
        attacker.signing.sign_outgoing = True
        attacker.signing.timestamp = signing_timestamp_now() + forged_years * 365 * 86400 * 100_000
        raw = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        for _ in range(5):
            raw.sendto(
                mavlink.MAVLink_param_request_read_message(1, 1, b"LIM_RPS_MAX", -1).pack(attacker),
                ("127.0.0.1", v.port),
            )
        raw.close()
        # THEN its packets are refused as badly signed, and the real ground station is answered
        wait_until(lambda: v.link.stats()["bad_signature"] >= 5, what="5 packets refused as badly signed")
        assert _answers(f"udpout:127.0.0.1:{v.port}", KEY)
    finally:
        v.stop()


def test_with_signing_on_unsigned_heartbeats_make_no_peers_and_a_lost_key_is_replaced_over_usb(
    tmp_path: Path,
) -> None:
    from onboard.adapters.mavlink.transport import MAX_PEERS

    (tmp_path / "key").write_text(KEY.hex())
    v = Vehicle(
        tmp_path / "state",
        signing_key_file=str(tmp_path / "key"),
        endpoints=("udpin:127.0.0.1:0", "tcpin:127.0.0.1:0"),
        secure_endpoints=("tcpin:127.0.0.1:0",),
    ).start()
    udp, tcp = f"udpout:127.0.0.1:{v.link.ports[0]}", f"tcp:127.0.0.1:{v.link.ports[1]}"
    try:
        # GIVEN more unsigned heartbeat senders than the peer table holds
        unsigned = mavlink.MAVLink(None, 66, 1)
        beat = mavlink.MAVLink_heartbeat_message(6, 8, 0, 0, 0, 3).pack(unsigned)
        socks = [socket.socket(socket.AF_INET, socket.SOCK_DGRAM) for _ in range(MAX_PEERS + 4)]
        for s in socks:
            s.sendto(beat, ("127.0.0.1", v.link.ports[0]))
        # THEN they are taken (counted) but none is a peer, and the ground station with the key is answered
        wait_until(lambda: v.link.stats()["unsigned_accepted"] >= len(socks), what="every heartbeat read")
        assert v.link.stats()["peers_refused"] == 0
        assert _answers(udp, KEY)
        for s in socks:
            s.close()
        # WHEN the key is lost: an unsigned SETUP_SIGNING over the secure endpoint sets a new one
        c = _client(tcp)
        c.send(mavlink.MAVLink_setup_signing_message(1, 1, NEW_KEY, signing_timestamp_now()))
        c.close()
        wait_until(lambda: _answers(udp, NEW_KEY), 20.0, "answers to the new key")
        assert not _answers(udp, KEY)
    finally:
        v.stop()
