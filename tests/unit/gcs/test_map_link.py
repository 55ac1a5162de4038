"""The map's link thread and server at their edges, with a stand-in client: the path file read (only when
its CRC changed) or not, a failure shown, the origin asked for; a bad picture, another origin or host."""

from __future__ import annotations

import asyncio
import json
import logging
import math
import struct
import threading
import time
import zlib
from typing import Any

import pytest
from pymavlink.dialects.v20 import common as mavlink

from auv_common import mavlink_ftp as ftp
from groundstation.ftp_client import FtpClient
from groundstation.link import LinkError
from groundstation.map.server import NO_READER_NOTE, LiveLink, make_app
from groundstation.map.state import PLANNED_PATH_FILE, MapModel, Picture
from groundstation.mission_files import goal_item, obstacle_item

PATH = {"version": 4, "kind": "loiter", "goal_index": 1, "frame": "local_ned", "points_m": [[1, 2, 3]]}


class Client:
    """What the link uses of MavClient; ``read`` answers read_file (bytes, or an exception to raise)."""

    def __init__(self, read: bytes | Exception | None = None, recv_error: Exception | None = None) -> None:
        self.target = (1, 1)
        self.on_message: Any = None
        self.read, self.recv_error = read, recv_error
        self.downloads: list[int] = []
        self.sent: list[Any] = []

    def send(self, msg: Any) -> None:
        self.sent.append(msg)

    def wait_heartbeat(self, timeout_s: float) -> None:
        return None

    def download(self, mission_type: int) -> list[Any]:
        self.downloads.append(mission_type)
        if mission_type == mavlink.MAV_MISSION_TYPE_MISSION:
            return [goal_item(5.0, 1.0, 2.0, 45.0)]
        return [obstacle_item(1.0, 1.0, 0.5)]

    def recv(self, timeout_s: float) -> None:
        raise self.recv_error or AssertionError("recv_error not set")


class ReadingClient(Client):
    reads = 0

    def read_file(self, path: str, on_other: Any = None) -> bytes:
        assert path == PLANNED_PATH_FILE
        self.reads += 1
        if isinstance(self.read, Exception):
            raise self.read
        assert self.read is not None
        return self.read


class _OwnCrc(FtpClient):
    """The ground station's own ``FtpClient.file_crc32`` over the stand-in's FTP request."""

    def __init__(self, stand_in: CrcClient) -> None:
        self.stand_in = stand_in

    def request(self, opcode: int, **kw: Any) -> ftp.Packet:
        return self.stand_in._ftp(opcode, **kw)


class CrcClient(ReadingClient):
    """A client with the ground station's own ``file_crc32`` over a stand-in FTP request (the vehicle
    answers CalcFileCRC32 of ``read``'s bytes, or ``nak``'s error code)."""

    def file_crc32(self, path: str, on_other: Any = None) -> int | None:
        return _OwnCrc(self).file_crc32(path, on_other)

    def __init__(self, read: bytes | Exception | None = None, nak: int | None = None) -> None:
        super().__init__(read)
        self.nak = nak
        self.crc_requests = 0

    def _ftp(self, opcode: int, *, data: bytes = b"", on_other: Any = None, **_: Any) -> ftp.Packet:
        assert opcode == ftp.CRC32 and data == PLANNED_PATH_FILE.encode()
        self.crc_requests += 1
        if self.nak is not None:
            return ftp.Packet(2, 0, ftp.NAK, 1, ftp.CRC32, 0, 0, bytes([self.nak]))
        if isinstance(self.read, Exception):
            raise self.read
        assert self.read is not None
        return ftp.Packet(2, 0, ftp.ACK, 4, ftp.CRC32, 0, 0, struct.pack("<I", zlib.crc32(self.read)))


def _link(client: Client) -> tuple[LiveLink, MapModel]:
    model = MapModel()
    return LiveLink(client, model, threading.Lock()), model  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("client", "kind", "note"),
    [
        (ReadingClient(json.dumps(PATH).encode()), "loiter", ""),
        (ReadingClient(LinkError(f"no such file on the vehicle: {PLANNED_PATH_FILE}")), None, "no such file"),
        (ReadingClient(b"{not json"), None, "not JSON"),
        (Client(), None, NO_READER_NOTE),  # a client that cannot read files: no path, and the page says so
    ],
)
def test_the_path_file_is_read_or_the_page_says_why_not(client: Client, kind: str | None, note: str) -> None:
    link, model = _link(client)
    link._read_path()
    pic = model.picture(0.0)
    assert (pic.path["kind"] if pic.path else None) == kind
    assert note in pic.telemetry["note"] and (note or pic.telemetry["note"] == "")


def path_doc(version: int) -> bytes:
    return json.dumps({**PATH, "version": version}).encode()


def test_the_path_file_is_read_only_when_the_vehicle_s_crc_of_it_changed() -> None:
    # GIVEN a vehicle that answers the CRC32 of its path file
    client = CrcClient(path_doc(1))
    link, model = _link(client)
    # WHEN the link looks at the file three times while it stays the same
    for _ in range(3):
        link._read_path()
    # THEN it asked for the CRC each time and read the file once
    assert (client.crc_requests, client.reads) == (3, 1)
    assert model.picture(0.0).path["version"] == 1 and model.path_version == 1
    # WHEN the vehicle plans a new path
    client.read = path_doc(2)
    link._read_path()
    link._read_path()
    # THEN it is read once more and shown
    assert (client.crc_requests, client.reads) == (5, 2) and model.picture(0.0).path["version"] == 2


def test_a_path_file_that_is_gone_is_told_by_its_crc_and_read_again_when_back() -> None:
    client = CrcClient(path_doc(1))
    link, model = _link(client)
    link._read_path()
    client.nak = ftp.FILE_NOT_FOUND  # the vehicle flies no path
    link._read_path()
    pic = model.picture(0.0)
    assert pic.path is None and "no such file on the vehicle" in pic.telemetry["note"] and client.reads == 1
    client.nak = None  # the same file back: it is read (what the page shows is no file)
    link._read_path()
    assert model.picture(0.0).path["version"] == 1 and client.reads == 2


def test_a_vehicle_without_crc32_has_its_path_file_read_every_time() -> None:
    client = CrcClient(path_doc(1), nak=ftp.UNKNOWN_COMMAND)
    link, model = _link(client)
    link._read_path()
    link._read_path()
    assert client.reads == 2 and model.picture(0.0).path["version"] == 1


def test_a_path_file_not_read_whole_is_read_again_though_its_crc_is_the_same() -> None:
    client = CrcClient(path_doc(1))
    link, model = _link(client)
    client.read_file = lambda path, on_other=None: b"{torn"  # type: ignore[method-assign]
    link._read_path()
    assert model.picture(0.0).path is None
    del client.read_file  # the file reads whole again
    link._read_path()
    assert client.reads == 1 and model.picture(0.0).path["version"] == 1


def test_the_link_downloads_the_plans_then_a_failure_is_shown_not_swallowed() -> None:
    # GIVEN a vehicle whose link breaks after the first plans and path were read
    client = ReadingClient(json.dumps(PATH).encode(), recv_error=OSError("socket closed"))
    link, model = _link(client)
    # WHEN the link thread runs
    link.run(threading.Event())
    # THEN it followed the client's vehicle, downloaded mission and fence, read the path, and the page shows
    # that the link failed
    pic = model.picture(0.0)
    assert model.vehicle == (1, 1) and client.downloads == [0, 1] and client.on_message is not None
    # AND it asked the vehicle for its GPS_GLOBAL_ORIGIN (the origin of the global items it draws)
    (ask,) = [m for m in client.sent if m.get_type() == "COMMAND_LONG"]
    assert (ask.target_system, ask.command) == (1, mavlink.MAV_CMD_REQUEST_MESSAGE)
    assert ask.param1 == mavlink.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN
    assert pic.plan["goals"][0]["yaw_deg"] == 45.0 and pic.plan["obstacles"][0]["radius_m"] == 0.5
    assert (
        pic.path is not None
        and "link failed" in pic.telemetry["note"]
        and "socket closed" in pic.telemetry["note"]
    )


def test_the_websocket_refuses_a_page_of_another_origin_and_every_route_another_host() -> None:
    """A page of another site, open in the operator's browser, cannot read the vehicle through the map:
    not by a cross-site websocket (Origin), nor by a name of its own rebound to 127.0.0.1 (DNS rebinding:
    the page is then of the same origin, but the Host header names that site)."""
    import aiohttp
    from aiohttp.test_utils import TestClient, TestServer

    from groundstation.map.server import LiveSource

    async def go() -> tuple[dict[str, int], bool]:
        app = make_app(LiveSource(MapModel(), threading.Lock(), "test"), live=False)
        async with TestClient(TestServer(app, host="127.0.0.1")) as client:
            port = client.port
            upgrade = {"Upgrade": "websocket", "Connection": "Upgrade", "Sec-WebSocket-Version": "13",
                       "Sec-WebSocket-Key": "dGhlIHNhbXBsZSBub25jZQ=="}  # fmt: skip
            rebound = f"evil.example:{port}"
            asks = {
                "ws from another origin": ("/ws", {"Origin": "http://evil.example", **upgrade}),
                "ws of a rebound name": ("/ws", {"Host": rebound, "Origin": f"http://{rebound}", **upgrade}),
                "page of a rebound name": ("/", {"Host": rebound}),
                "static of a rebound name": ("/static/map.js", {"Host": rebound}),
                "page of another port": ("/", {"Host": f"127.0.0.1:{port + 1}"}),
                "page without the port": ("/", {"Host": "localhost"}),
                "page on localhost": ("/", {"Host": f"localhost:{port}"}),
                "page on 127.0.0.1": ("/", {"Host": f"127.0.0.1:{port}"}),
            }
            status = {}
            for what, (route, headers) in asks.items():
                async with client.get(route, headers=headers) as r:
                    status[what] = r.status
            own = str(client.make_url("/")).rstrip("/")
            ws = await client.ws_connect("/ws", headers={"Origin": own})
            hello = await ws.receive(timeout=5)
            await ws.close()
            return status, hello.type == aiohttp.WSMsgType.TEXT

    status, ok = asyncio.run(go())
    assert status == {
        "ws from another origin": 403,
        "ws of a rebound name": 403,
        "page of a rebound name": 403,
        "static of a rebound name": 403,
        "page of another port": 403,
        "page without the port": 403,
        "page on localhost": 200,
        "page on 127.0.0.1": 200,
    }
    assert ok


class FlakySource:
    """A live source whose pictures change every time (each is pushed) and carry a NaN while ``bad``."""

    def __init__(self) -> None:
        self.model = MapModel()
        self.bad = False
        self.n = 0

    def hello(self) -> dict[str, Any]:
        return {"type": "hello", "mode": "live", "source": "test"}

    def picture(self, t_s: float | None) -> Picture:
        self.n += 1
        pic = self.model.picture(time.time())
        telemetry = {**pic.telemetry, "load": math.nan if self.bad else 0.5, "n": self.n}
        return Picture(pic.t_s, self.n, telemetry, pic.plan_version, pic.plan, pic.path_version, pic.path,
                       pic.track_epoch, pic.track, pic.track_len)  # fmt: skip


def test_a_picture_that_cannot_be_sent_drops_that_page_not_the_map(caplog: pytest.LogCaptureFixture) -> None:
    import aiohttp
    from aiohttp.test_utils import TestClient, TestServer

    async def updates(ws: aiohttp.ClientWebSocketResponse, n: int, timeout_s: float) -> list[Any]:
        got = []
        while len(got) < n:
            m = await ws.receive(timeout=timeout_s)
            if m.type != aiohttp.WSMsgType.TEXT:
                return got
            got.append(json.loads(m.data))
        return got

    async def go() -> tuple[list[Any], list[Any]]:
        source = FlakySource()
        app = make_app(source, live=True)  # type: ignore[arg-type]
        async with TestClient(TestServer(app, host="127.0.0.1")) as client:
            # GIVEN a page that gets its updates
            first = await client.ws_connect("/ws")
            assert len(await updates(first, 3, 2.0)) == 3  # hello, the first picture, one pushed
            # WHEN a picture cannot be sent (a NaN: no JSON)
            source.bad = True
            # THEN that page is dropped (its websocket closed: it connects again): read until it is
            dropped = await updates(first, 100, 10.0)
            # AND once the pictures are good again, a page gets them pushed: the map goes on
            source.bad = False
            second = await client.ws_connect("/ws")
            got = await updates(second, 4, 3.0)
            await second.close()
            await first.close()
            return dropped, got

    with caplog.at_level(logging.ERROR, logger="groundstation.map.server"):
        dropped, got = asyncio.run(go())
    assert all(m["telemetry"]["load"] == 0.5 for m in dropped if m["type"] == "update")
    assert [m["type"] for m in got] == ["hello", "update", "update", "update"]
    assert any("cannot send" in r.getMessage() for r in caplog.records)
