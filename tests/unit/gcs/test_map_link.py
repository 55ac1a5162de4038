"""The map's link thread at its edges, with a stand-in client: the path file read or not, a failure shown."""

from __future__ import annotations

import json
import threading
from typing import Any

import pytest
from pymavlink.dialects.v20 import common as mavlink

from groundstation.map.server import NO_READER_NOTE, LiveLink
from groundstation.map.state import PLANNED_PATH_FILE, MapModel
from groundstation.mavclient import LinkError
from groundstation.mission_files import goal_item, obstacle_item

PATH = {"version": 4, "kind": "loiter", "goal_index": 1, "frame": "local_ned", "points_m": [[1, 2, 3]]}


class Client:
    """What the link uses of MavClient; ``read`` answers read_file (bytes, or an exception to raise)."""

    def __init__(self, read: bytes | Exception | None = None, recv_error: Exception | None = None) -> None:
        self.target = (1, 1)
        self.on_message: Any = None
        self.read, self.recv_error = read, recv_error
        self.downloads: list[int] = []

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
    def read_file(self, path: str, on_other: Any = None) -> bytes:
        assert path == PLANNED_PATH_FILE
        if isinstance(self.read, Exception):
            raise self.read
        assert self.read is not None
        return self.read


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
    assert pic.plan["goals"][0]["yaw_deg"] == 45.0 and pic.plan["obstacles"][0]["radius_m"] == 0.5
    assert (
        pic.path is not None
        and "link failed" in pic.telemetry["note"]
        and "socket closed" in pic.telemetry["note"]
    )


def test_the_websocket_refuses_a_page_of_another_origin() -> None:
    """A page of another site, open in the operator's browser, cannot read the vehicle through the map."""
    import asyncio

    import aiohttp
    from aiohttp.test_utils import TestClient, TestServer

    from groundstation.map.server import LiveSource, make_app

    async def go() -> tuple[int, bool]:
        app = make_app(LiveSource(MapModel(), threading.Lock(), "test"), live=False)
        async with TestClient(TestServer(app)) as client:
            upgrade = {"Upgrade": "websocket", "Connection": "Upgrade", "Sec-WebSocket-Version": "13",
                       "Sec-WebSocket-Key": "dGhlIHNhbXBsZSBub25jZQ=="}  # fmt: skip
            bad = await client.get("/ws", headers={"Origin": "http://evil.example", **upgrade})
            own = str(client.make_url("/")).rstrip("/")
            ws = await client.ws_connect("/ws", headers={"Origin": own})
            hello = await ws.receive(timeout=5)
            await ws.close()
            return bad.status, hello.type == aiohttp.WSMsgType.TEXT

    status, ok = asyncio.run(go())
    assert status == 403 and ok
