"""MAVLink FTP, read only, on the vehicle's real link: the planned path and the flight logs.

Our ground station's reader (``MavClient.read_file`` / ``list_dir``) and raw FILE_TRANSFER_PROTOCOL requests
against an in-process vehicle on UDP; MAVProxy's ``ftp`` module (a third-party reader) in test_mavproxy.py.
"""

from __future__ import annotations

import itertools
import json
import os
import struct
import subprocess
import sys
import time
import zlib
from pathlib import Path

import pytest
from pymavlink.dialects.v20 import common as mavlink

from auv_common import mavlink_ftp as ftp
from groundstation.mavclient import LinkError, MavClient
from groundstation.mission_files import goal_item
from tests.integration.mavlink.conftest import Vehicle


def raw(c: MavClient, pkt: ftp.Packet, t: float = 2.0) -> list[ftp.Packet]:
    """Send one FTP packet as is; every FTP reply within ``t`` (or until a burst completes)."""
    c.send(mavlink.MAVLink_file_transfer_protocol_message(0, 1, 1, pkt.encode()))
    out: list[ftp.Packet] = []
    t_end = time.monotonic() + t
    while time.monotonic() < t_end:
        m = c.recv(0.05)
        if m is not None and m.get_type() == "FILE_TRANSFER_PROTOCOL":
            out.append(ftp.Packet.decode(m.payload))
            if out[-1].req_opcode != ftp.BURST_READ or out[-1].burst_complete:
                break
    return out


def test_the_planned_path_is_a_file_any_ground_station_can_read(vehicle: Vehicle) -> None:
    with vehicle.client() as c:
        # GIVEN a vehicle with no path yet
        doc = json.loads(c.read_file("@PATH/planned.json"))
        assert doc["points_m"] == [] and doc["kind"] == "" and doc["frame"] == "local_ned"
        # WHEN a mission is uploaded, armed and started (the planner makes a path to goal 0)
        assert c.upload([goal_item(60.0, 20.0, 2.0, None)]).ok
        assert c.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1.0) == mavlink.MAV_RESULT_ACCEPTED
        assert c.command(mavlink.MAV_CMD_MISSION_START, 0.0) == mavlink.MAV_RESULT_ACCEPTED
        t_end = time.monotonic() + 5.0
        while not doc["points_m"] and time.monotonic() < t_end:
            time.sleep(0.2)
            doc = json.loads(c.read_file("@PATH/planned.json"))
        # THEN the file holds that path: to the goal, every 0.5 m, a new version
        assert doc["kind"] == "goal" and doc["goal_index"] == 0 and doc["version"] >= 2
        pts = doc["points_m"]
        assert len(pts) >= doc["length_m"] / 0.5 and doc["length_m"] > 60.0
        assert pts[-1][:2] == pytest.approx([60.0, 20.0], abs=0.05) and pts[-1][2] == pytest.approx(2.0)
        steps = [((b[0] - a[0]) ** 2 + (b[1] - a[1]) ** 2) ** 0.5 for a, b in itertools.pairwise(pts)]
        assert max(steps) <= 0.5 + 1e-3
        # AND its CRC-32 (what the map asks before it reads again) is that of its bytes
        assert c.file_crc32("@PATH/planned.json") == zlib.crc32(c.read_file("@PATH/planned.json"))
        # AND the directory lists it with its size
        assert c.list_dir("/") == [("D", "@PATH", 0), ("D", "logs", 0)]
        ((kind, name, size),) = c.list_dir("@PATH")
        assert (kind, name) == ("F", "planned.json") and size > 100


def test_flight_logs_are_listed_and_downloaded_whole(tmp_path: Path) -> None:
    logs = tmp_path / "state" / "logs"
    logs.mkdir(parents=True)
    big = os.urandom(100_000)
    (logs / "flight-20261202-010000.mcap").write_bytes(big)
    (logs / "notes.txt").write_text("not a log")
    (tmp_path / "state" / "secret.json").write_text("{}")
    v = Vehicle(tmp_path / "state").start()
    try:
        with v.client() as c:
            assert c.list_dir("logs") == [("F", "flight-20261202-010000.mcap", 100_000)]
            seen: list[int] = []
            got = c.read_file("logs/flight-20261202-010000.mcap", progress=lambda d, n: seen.append(d))
            assert got == big and seen[-1] == 100_000
            # only what is listed is served: no other file of the state directory, no way out of logs/
            for path in ("logs/notes.txt", "logs/../secret.json", "secret.json", "/etc/passwd", "logs/"):
                with pytest.raises(LinkError, match="no such file on the vehicle"):
                    c.read_file(path)
            with pytest.raises(LinkError, match="no such directory"):
                c.list_dir("/etc")
    finally:
        v.stop()


def test_ftp_is_read_only_bounded_and_idempotent(vehicle: Vehicle) -> None:
    with vehicle.client() as c:
        # every write opcode is refused: FileProtected
        for op in sorted(ftp.WRITE_OPS):
            (r,) = raw(c, ftp.Packet(10 + op, 0, op, 4, 0, 0, 0, b"logs"))
            assert r.opcode == ftp.NAK and r.data[0] == ftp.FILE_PROTECTED and r.seq == 11 + op
        (r,) = raw(c, ftp.Packet(40, 0, 99, 0, 0, 0, 0, b""))
        assert r.opcode == ftp.NAK and r.data[0] == ftp.UNKNOWN_COMMAND
        # a re-sent OpenFileRO (its reply lost) gets the same reply: one session, not two
        open_req = ftp.Packet(50, 0, ftp.OPEN_RO, 0, 0, 0, 0, b"@PATH/planned.json")
        (a,) = raw(c, open_req)
        (b,) = raw(c, open_req)
        assert a == b and a.opcode == ftp.ACK and len(vehicle.link.ftp.sessions) == 1
        size = struct.unpack("<I", a.data)[0]
        # a burst read returns the whole (small) file, the last packet marked complete
        burst = raw(c, ftp.Packet(51, a.session, ftp.BURST_READ, 0, 0, 0, 0, b""))
        assert b"".join(p.data for p in burst) == c.read_file("@PATH/planned.json")[:size]
        assert burst[-1].burst_complete == 1
        # sessions are bounded, and another station cannot read or close ours
        for i in range(ftp_max := 4):
            raw(c, ftp.Packet(60 + i, 0, ftp.OPEN_RO, 0, 0, 0, 0, b"@PATH/planned.json"))
        assert len(vehicle.link.ftp.sessions) == ftp_max
        (full,) = raw(c, ftp.Packet(70, 0, ftp.OPEN_RO, 0, 0, 0, 0, b"@PATH/planned.json"))
        assert full.opcode == ftp.NAK and full.data[0] == ftp.NO_SESSIONS
        with vehicle.client(system_id=254) as other:
            (r,) = raw(other, ftp.Packet(1, a.session, ftp.READ, 10, 0, 0, 0, b""))
            assert r.opcode == ftp.NAK and r.data[0] == ftp.INVALID_SESSION
        (r,) = raw(c, ftp.Packet(80, 0, ftp.RESET, 0, 0, 0, 0, b""))
        assert r.opcode == ftp.ACK and vehicle.link.ftp.sessions == {}


def test_auv_gcs_logs_lists_and_downloads_the_newest(tmp_path: Path) -> None:
    logs = tmp_path / "state" / "logs"
    logs.mkdir(parents=True)
    old, new = os.urandom(5_000), os.urandom(30_000)
    (logs / "flight-20261201-090000.mcap").write_bytes(old)
    (logs / "flight-20261202-010000.mcap").write_bytes(new)
    v = Vehicle(tmp_path / "state").start()
    gcs = [sys.executable, "-m", "groundstation", "--connect", f"udpout:127.0.0.1:{v.port}", "--json",
           "--tlog-dir", str(tmp_path / "tlogs")]  # fmt: skip
    try:
        listed = subprocess.run([*gcs, "logs"], capture_output=True, text=True, timeout=30, check=False)
        assert listed.returncode == 0, listed.stderr
        assert json.loads(listed.stdout.splitlines()[-1])["logs"] == [
            {"name": "flight-20261201-090000.mcap", "size": 5_000},
            {"name": "flight-20261202-010000.mcap", "size": 30_000},
        ]
        got = subprocess.run(
            [*gcs, "logs", "get", "-o", str(tmp_path)],
            capture_output=True,
            text=True,
            timeout=30,
            check=False,
        )
        assert got.returncode == 0, got.stderr
        assert (tmp_path / "flight-20261202-010000.mcap").read_bytes() == new
        bad = subprocess.run([*gcs, "logs", "get", "nope.mcap"], capture_output=True, text=True, timeout=30)
        assert bad.returncode == 2 and "no such file on the vehicle: logs/nope.mcap" in bad.stdout
    finally:
        v.stop()
