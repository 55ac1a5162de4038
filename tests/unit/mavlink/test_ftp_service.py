"""The FTP service's cost per request is bounded (an attacker's view): no re-sampling of the path, no
re-reading of a log for its CRC, and a reply budget for bursts, whatever the request rate."""

from __future__ import annotations

import os
import struct
from pathlib import Path
from typing import Any

import pytest
from pymavlink.dialects.v20 import common as mavlink

from auv_common import mavlink_ftp as ftp
from onboard.adapters.mavlink import ftp as service
from onboard.adapters.mavlink.api import VehicleSnapshot
from onboard.adapters.mavlink.peers import Sender
from onboard.core.planner.path import Path as PlannedPath
from onboard.core.planner.path import StraightSegment

GCS = Sender(255, 190, None)


class Wire:
    def __init__(self) -> None:
        self.out: list[ftp.Packet] = []

    def reply(self, msg: Any, to: Sender) -> None:
        self.out.append(ftp.Packet.decode(msg.payload))


def request(svc: service.FtpService, pkt: ftp.Packet, who: Sender = GCS) -> None:
    svc.handle(mavlink.MAVLink_file_transfer_protocol_message(0, 1, 1, pkt.encode()), who)


def make(
    tmp_path: Path, snapshot: VehicleSnapshot, clock: list[float] | None = None
) -> tuple[service.FtpService, Wire]:
    wire = Wire()
    tree = service.FileTree(lambda: snapshot, tmp_path)
    t = clock if clock is not None else [100.0]
    return service.FtpService(wire, tree, 1, 1, lambda: t[0]), wire  # type: ignore[arg-type]


def test_the_path_file_is_made_once_per_path(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = PlannedPath((StraightSegment(0.0, 0.0, 0.0, 500.0),), 1.0, 1.0)
    svc, wire = make(tmp_path, VehicleSnapshot(path=path, path_kind="goal", path_goal_index=0))
    made: list[int] = []
    real = service.path_document
    monkeypatch.setattr(service, "path_document", lambda s, v: made.append(v) or real(s, v))
    for seq in range(200):  # 200 opens and CRCs of the same path
        request(svc, ftp.Packet(2 * seq, 0, ftp.CRC32, 0, 0, 0, 0, b"@PATH/planned.json"))
        request(svc, ftp.Packet(2 * seq + 1, 0, ftp.RESET, 0, 0, 0, 0, b""))
    assert made == [1] and len(wire.out) == 400


def test_a_logs_crc_is_read_once_and_bursts_stay_in_the_reply_budget(tmp_path: Path) -> None:
    (tmp_path / "flight-20261202-000000.mcap").write_bytes(os.urandom(2_000_000))
    svc, wire = make(tmp_path, VehicleSnapshot())
    reads: list[int] = []
    real = service._OpenFile.crc32
    service._OpenFile.crc32 = lambda self: reads.append(1) or real(self)  # type: ignore[method-assign]
    try:
        for seq in range(50):
            request(svc, ftp.Packet(seq, 0, ftp.CRC32, 0, 0, 0, 0, b"logs/flight-20261202-000000.mcap"))
    finally:
        service._OpenFile.crc32 = real  # type: ignore[method-assign]
    assert len(reads) == 1 and len({p.data for p in wire.out}) == 1
    wire.out.clear()
    request(svc, ftp.Packet(100, 0, ftp.OPEN_RO, 0, 0, 0, 0, b"logs/flight-20261202-000000.mcap"))
    (opened,) = wire.out
    assert struct.unpack("<I", opened.data)[0] == 2_000_000
    wire.out.clear()
    # 500 burst requests in the same instant (the clock does not move): the first packet of each, and
    # no more than the budget's burst beyond that
    for seq in range(500):
        request(svc, ftp.Packet(101 + seq, opened.session, ftp.BURST_READ, 0, 0, 0, 239 * seq, b""))
    assert len(wire.out) <= 500 + 2 * service.BURST_PACKETS
    assert all(p.opcode == ftp.ACK for p in wire.out)


def test_a_repeated_burst_spends_the_budget_too(tmp_path: Path) -> None:
    (tmp_path / "flight-20261202-010000.mcap").write_bytes(os.urandom(200_000))
    svc, wire = make(tmp_path, VehicleSnapshot())
    request(svc, ftp.Packet(1, 0, ftp.OPEN_RO, 0, 0, 0, 0, b"logs/flight-20261202-010000.mcap"))
    (opened,) = wire.out
    wire.out.clear()
    burst = ftp.Packet(2, opened.session, ftp.BURST_READ, 0, 0, 0, 0, b"")
    for _ in range(500):  # the same request again and again (it looks like a resend)
        request(svc, burst)
    assert len(wire.out) <= 500 + 2 * service.BURST_PACKETS  # was 500 x 64 = 32000


def test_sessions_left_open_by_a_stopped_reader_are_closed_when_idle(tmp_path: Path) -> None:
    clock = [0.0]
    svc, wire = make(tmp_path, VehicleSnapshot(), clock)
    for i in range(service.MAX_SESSIONS):  # readers that opened and were stopped (other ids each)
        request(svc, ftp.Packet(1, 0, ftp.OPEN_RO, 0, 0, 0, 0, b"@PATH/planned.json"), Sender(200 + i, 190))
    assert len(svc.sessions) == service.MAX_SESSIONS
    wire.out.clear()
    request(svc, ftp.Packet(1, 0, ftp.OPEN_RO, 0, 0, 0, 0, b"@PATH/planned.json"), Sender(250, 190))
    assert wire.out[-1].opcode == ftp.NAK and wire.out[-1].data[0] == ftp.NO_SESSIONS
    clock[0] = service.SESSION_IDLE_S + 1.0
    request(svc, ftp.Packet(2, 0, ftp.OPEN_RO, 0, 0, 0, 0, b"@PATH/planned.json"), Sender(250, 190))
    assert wire.out[-1].opcode == ftp.ACK and len(svc.sessions) == 1


def test_only_flight_logs_are_served_newest_last(tmp_path: Path) -> None:
    for name in ("flight-20261202-010000.mcap", "flight-20261202-010000-2.mcap", "other.mcap"):
        (tmp_path / name).write_bytes(b"x")
    svc, wire = make(tmp_path, VehicleSnapshot())
    request(svc, ftp.Packet(1, 0, ftp.LIST, 0, 0, 0, 0, b"logs"))
    names = [e.split(b"\t")[0][1:].decode() for e in wire.out[-1].data.split(b"\0") if e]
    assert names == ["flight-20261202-010000.mcap", "flight-20261202-010000-2.mcap"]


def test_a_file_that_shrank_and_many_spoofed_ids_cost_nothing(tmp_path: Path) -> None:
    log = tmp_path / "flight-20261202-010000.mcap"
    log.write_bytes(os.urandom(10_000))
    svc, wire = make(tmp_path, VehicleSnapshot())
    request(svc, ftp.Packet(1, 0, ftp.OPEN_RO, 0, 0, 0, 0, b"logs/flight-20261202-010000.mcap"))
    (opened,) = wire.out
    log.write_bytes(b"")  # rotated or truncated under the reader
    request(svc, ftp.Packet(2, opened.session, ftp.BURST_READ, 0, 0, 0, 0, b""))
    assert wire.out[-1].opcode == ftp.NAK and wire.out[-1].data[0] == ftp.EOF
    for i in range(5000):  # a stranger cycling through ids: what is kept for resends stays bounded
        request(svc, ftp.Packet(1, 0, ftp.LIST, 0, 0, 0, 0, b"/"), Sender(i % 250 + 1, i // 250))
    assert len(svc._last) <= service.MAX_REMEMBERED
