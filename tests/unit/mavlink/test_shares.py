"""Receive shares of the vehicle's MAVLink transport (issue 12, item 4): real sockets, a fake clock."""

from __future__ import annotations

import socket
from typing import Any

from pymavlink.dialects.v20 import common as mavlink

from auv_common.token_bucket import TokenBucket
from hil_sim.scenario import free_udp_port
from onboard.adapters.mavlink.config import MavlinkConfig
from onboard.adapters.mavlink.peers import Sender
from onboard.adapters.mavlink.transport import MAX_PEERS, Transport
from tests.unit.mavlink.linkkit import Clock


def _heartbeat(system_id: int) -> bytes:
    mav = mavlink.MAVLink(None, system_id, 190)
    return bytes(mavlink.MAVLink_heartbeat_message(6, 8, 0, 0, 0, 3).pack(mav))


def _corrupt(system_id: int) -> bytes:
    frame = bytearray(_heartbeat(system_id))
    frame[12] ^= 0x10  # a payload bit: the CRC no longer matches
    return bytes(frame)


class _Vehicle:
    def __init__(self, **config: Any) -> None:
        self.port = free_udp_port()
        self.clock = Clock()
        self.heard: list[Sender] = []
        cfg = MavlinkConfig(endpoints=(f"udpin:127.0.0.1:{self.port}",), **config)
        self.transport = Transport(cfg, self.clock, lambda _m, sender, _t: self.heard.append(sender))
        self.transport.open()

    def pump(self) -> None:
        while self.transport.wait(0.05) and self._pending():
            pass

    def _pending(self) -> bool:
        s = self.transport._sockets[0].sock
        try:
            s.recv(1, socket.MSG_PEEK)
        except BlockingIOError:
            return False
        return True

    def close(self) -> None:
        self.transport.close()


def _socket() -> socket.socket:
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    return s


def test_a_known_peer_keeps_its_share_while_strangers_flood() -> None:
    vehicle = _Vehicle(rx_peer_per_s=100, rx_strangers_per_s=50)
    gcs, flooders = _socket(), [_socket() for _ in range(8)]
    try:
        gcs.sendto(_heartbeat(201), ("127.0.0.1", vehicle.port))
        vehicle.pump()
        assert [s.system_id for s in vehicle.heard] == [201]  # learned: a peer now
        # WHEN 8 strangers send 400 corrupt heartbeats and the peer 15, all within the same instant
        for k in range(400):
            flooders[k % 8].sendto(_corrupt(66), ("127.0.0.1", vehicle.port))
            if k % 27 == 0:
                gcs.sendto(_heartbeat(201), ("127.0.0.1", vehicle.port))
        vehicle.pump()
        rx = vehicle.transport.rx
        # THEN every one of the peer's got through; of the strangers' only what was left of their shared
        # burst (50/s x 0.2 s = 10, one taken by the peer's first heartbeat) was parsed (and found malformed),
        # the rest dropped unparsed
        assert [s.system_id for s in vehicle.heard[1:]] == [201] * 15
        assert (rx.shed, rx.shed_from_peers) == (391, 0) and rx.malformed > 0
    finally:
        vehicle.close()
        for s in (gcs, *flooders):
            s.close()


def test_each_sender_of_valid_messages_becomes_a_peer_with_a_share_of_its_own() -> None:
    vehicle = _Vehicle(rx_peer_per_s=100, rx_strangers_per_s=50)
    socks = [_socket() for _ in range(3)]
    try:
        for _ in range(60):  # 60 each, in the same instant: the first as a stranger, then the burst (20)
            for k, s in enumerate(socks):
                s.sendto(_heartbeat(10 + k), ("127.0.0.1", vehicle.port))
        vehicle.pump()
        ids = [s.system_id for s in vehicle.heard]
        assert [ids.count(10 + k) for k in range(3)] == [21, 21, 21]
        assert vehicle.transport.rx.shed_from_peers == 3 * 39
    finally:
        vehicle.close()
        for s in socks:
            s.close()


def test_a_full_table_of_live_peers_is_never_emptied_for_a_newcomer() -> None:
    vehicle = _Vehicle()
    socks = [_socket() for _ in range(MAX_PEERS + 4)]
    try:
        for s in socks:
            s.sendto(_heartbeat(100), ("127.0.0.1", vehicle.port))
            vehicle.pump()
        learned = vehicle.transport._sockets[0].peers
        assert set(learned) == {s.getsockname() for s in socks[:MAX_PEERS]}
        assert vehicle.transport.rx.peers_refused == 4
        # the first peers fall silent for longer than the expiry: then a newcomer takes a place
        vehicle.clock.t += 31.0
        socks[-1].sendto(_heartbeat(100), ("127.0.0.1", vehicle.port))
        vehicle.pump()
        assert socks[-1].getsockname() in learned
    finally:
        vehicle.close()
        for s in socks:
            s.close()


def test_a_token_bucket_refills_at_its_rate_up_to_its_burst() -> None:
    bucket = TokenBucket(10.0, 2.0)
    assert [bucket.take(0.0) for _ in range(3)] == [True, True, False]
    assert bucket.take(0.05) is False and bucket.take(0.1) is True  # 0.1 s: one token back
    assert [bucket.take(100.0) for _ in range(3)] == [True, True, False]  # never more than the burst
    assert bucket.take(50.0) is False  # the clock going back adds nothing ...
    assert bucket.take(50.1) is True  # ... and the refill goes on from there (not from 100 s)


def test_a_datagram_too_long_is_not_read_and_one_of_many_frames_spends_a_token_each() -> None:
    vehicle = _Vehicle(rx_peer_per_s=100, rx_strangers_per_s=50)
    gcs, stranger = _socket(), _socket()
    try:
        gcs.sendto(_heartbeat(201), ("127.0.0.1", vehicle.port))
        vehicle.pump()
        # a stranger's 60 kB of markers (0.2 s to scan) is dropped unread
        stranger.sendto(b"\xfe" * 60_000, ("127.0.0.1", vehicle.port))
        # the peer packs 60 heartbeats in one datagram: its share's burst (20) is taken, the rest shed
        gcs.sendto(_heartbeat(201) * 60, ("127.0.0.1", vehicle.port))
        vehicle.pump()
        rx = vehicle.transport.rx
        assert rx.oversize == 1 and rx.malformed == 0
        assert len(vehicle.heard) == 1 + 20 and rx.shed_from_peers == 40
    finally:
        vehicle.close()
        gcs.close()
        stranger.close()


def test_a_datagram_of_garbage_is_read_no_further_than_a_few_malformed_spots() -> None:
    from onboard.adapters.mavlink.wire import MAX_MALFORMED_PER_DATAGRAM, RxStats, decode_datagram

    stats = RxStats()
    assert decode_datagram(b"\xfe\x01" * 1000, stats) == []
    assert stats.malformed == MAX_MALFORMED_PER_DATAGRAM
