"""``auv-gcs map``: the vehicle on a map in the browser, live or replayed from a tlog, served on 127.0.0.1.

One aiohttp server on one port serves the page (``/``), its static files (``/static/``) and a websocket
(``/ws``); nothing comes from elsewhere (no CDN, no map tiles).

Live: one thread (:class:`LiveLink`) owns the :class:`~groundstation.mavclient.MavClient`: every message it
receives, also during a download or a file read, goes through its ``on_message`` hook into the
:class:`~groundstation.map.state.MapModel`; it downloads the mission and the fence at the start and whenever
the model says they may have changed, and reads the vehicle's planned path file once a second. The server
pushes the model's picture to every page at most 10 times a second (when something changed, else once a
second).

Replay (``--tlog FILE``): the recording is turned into pictures at load (the same model); the page's slider
and play button ask for the picture at a time (``{"type": "seek", "t_s": ...}``).

Messages to the page: ``{"type": "hello", "mode": "live" | "replay", ...}`` once, then ``{"type": "update",
...}`` (:func:`~groundstation.map.state.update_for`).
"""

from __future__ import annotations

import argparse
import asyncio
import json
import logging
import signal
import socket
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

from aiohttp import WSMsgType, web
from pymavlink.dialects.v20 import common as mavlink

from groundstation.map import HOST
from groundstation.map.state import (
    PLANNED_PATH_FILE,
    MapModel,
    Picture,
    Sent,
    messages_of,
    parse_planned,
    picture_at,
    replay_pictures,
    update_for,
)
from groundstation.mavclient import LinkError, MavClient, Msg
from groundstation.tlog import read_tlog

log = logging.getLogger(__name__)

STATIC_DIR = Path(__file__).with_name("static")
PUSH_PERIOD_S = 0.1  # at most 10 updates a second to a page
IDLE_PUSH_PERIOD_S = 1.0  # an update a second when nothing changed (the link's age moves on)
PATH_PERIOD_S = 1.0
RETRY_S = 2.0
NO_READER_NOTE = "the planned path is not shown: this ground station cannot read the vehicle's files yet"

Done = Callable[[dict[str, Any], str], None]


class Source(Protocol):
    """Where pictures come from: the live model or a replay's pictures."""

    def hello(self) -> dict[str, Any]: ...

    def picture(self, t_s: float | None) -> Picture: ...


class LiveSource:
    """The live model's picture now (``t_s`` is ignored)."""

    def __init__(self, model: MapModel, lock: threading.Lock, url: str) -> None:
        self.model, self.lock, self.url = model, lock, url

    def hello(self) -> dict[str, Any]:
        return {"type": "hello", "mode": "live", "source": self.url}

    def picture(self, t_s: float | None) -> Picture:
        with self.lock:
            return self.model.picture(time.time())


class ReplaySource:
    """The pictures of a recording; ``t_s`` None: the first."""

    def __init__(self, pictures: list[Picture], name: str) -> None:
        self.pictures, self.name = pictures, name

    def hello(self) -> dict[str, Any]:
        return {
            "type": "hello",
            "mode": "replay",
            "source": self.name,
            "t0_s": self.pictures[0].t_s,
            "t1_s": self.pictures[-1].t_s,
        }

    def picture(self, t_s: float | None) -> Picture:
        return picture_at(self.pictures, self.pictures[0].t_s if t_s is None else t_s)


class LiveLink:
    """The thread that owns the client: telemetry into the model (under ``lock``), the plans downloaded at
    the start and when they may have changed, the vehicle's planned path read every ``path_period_s``."""

    def __init__(
        self,
        client: MavClient,
        model: MapModel,
        lock: threading.Lock,
        *,
        path_period_s: float = PATH_PERIOD_S,
        retry_s: float = RETRY_S,
    ) -> None:
        self.client, self.model, self.lock = client, model, lock
        self.path_period_s, self.retry_s = path_period_s, retry_s
        self._note = ""

    def _on_message(self, msg: Msg) -> None:
        with self.lock:
            self.model.apply(time.time(), msg)

    def run(self, stop: threading.Event) -> None:
        """Until ``stop`` is set: wait for the vehicle, then keep the model up to date. A failure of this
        thread is logged and shown on the page (the map would otherwise just go stale)."""
        try:
            self._run(stop)
        except Exception as exc:
            log.exception("the map's link failed")
            with self.lock:
                self.model.note = f"the ground station's link failed: {exc!r} (restart auv-gcs map)"
                self.model.seq += 1

    def _run(self, stop: threading.Event) -> None:
        c = self.client
        c.on_message = self._on_message
        while not stop.is_set():
            try:
                c.wait_heartbeat(1.0)
                break
            except LinkError:
                continue
        if stop.is_set():
            return
        with self.lock:
            self.model.vehicle = c.target
        log.info("vehicle %d/%d is there", *c.target)
        plans_due = path_due = 0.0
        while not stop.is_set():
            now = time.monotonic()
            with self.lock:
                if self.model.take_refresh():
                    plans_due = now
            if now >= plans_due:
                plans_due = now + (float("inf") if self._download() else self.retry_s)
            if now >= path_due:
                path_due = now + self.path_period_s
                self._read_path()
            c.recv(0.1)

    def _download(self) -> bool:
        try:
            mission = self.client.download(mavlink.MAV_MISSION_TYPE_MISSION)
            fence = self.client.download(mavlink.MAV_MISSION_TYPE_FENCE)
        except LinkError as exc:
            log.warning("cannot download the plans (again in %g s): %s", self.retry_s, exc)
            return False
        with self.lock:
            self.model.set_plan(mavlink.MAV_MISSION_TYPE_MISSION, mission)
            self.model.set_plan(mavlink.MAV_MISSION_TYPE_FENCE, fence)
        return True

    def _read_path(self) -> None:
        # (no on_other: the client's on_message hook already sees every message that comes during the read)
        reader = getattr(self.client, "read_file", None)
        path: dict[str, Any] | None = None
        note = ""
        if reader is None:
            note = NO_READER_NOTE
        else:
            try:
                path = parse_planned(reader(PLANNED_PATH_FILE))
            except LinkError as exc:
                note = f"no planned path: {exc}"
            except ValueError as exc:
                note = str(exc)
        if note != self._note:
            log.info("%s", note or "the planned path is read")
            self._note = note
        with self.lock:
            self.model.set_path(path, note)


@dataclass(eq=False)  # one per websocket, kept in a set by identity
class _Page:
    ws: web.WebSocketResponse
    sent: Sent | None = None
    seq: int = -1
    t_sent: float = 0.0
    lock: asyncio.Lock = field(default_factory=asyncio.Lock)


def _dumps(data: dict[str, Any]) -> str:
    return json.dumps(data, allow_nan=False, separators=(",", ":"))


async def _send(page: _Page, pic: Picture) -> None:
    async with page.lock:
        msg, page.sent = update_for(pic, page.sent)
        page.seq, page.t_sent = pic.seq, time.monotonic()
        await page.ws.send_str(_dumps(msg))


def make_app(source: Source, *, live: bool) -> web.Application:
    """The page, its static files and the websocket; live: a task pushes pictures to every page."""
    pages: set[_Page] = set()
    tasks: list[asyncio.Task[None]] = []
    app = web.Application()
    index = (STATIC_DIR / "index.html").read_bytes()

    async def page_handler(_request: web.Request) -> web.Response:
        return web.Response(body=index, content_type="text/html", charset="utf-8")

    async def no_icon(_request: web.Request) -> web.Response:
        return web.Response(status=204)

    async def ws_handler(request: web.Request) -> web.StreamResponse:
        origin = request.headers.get("Origin")
        if origin is not None and origin != f"{request.scheme}://{request.host}":
            # another site's page in the operator's browser may not read the vehicle (cross-site websocket)
            return web.Response(status=403, text="websocket from another origin")
        ws = web.WebSocketResponse(heartbeat=10.0)
        await ws.prepare(request)
        page = _Page(ws)
        pages.add(page)
        try:
            await ws.send_str(_dumps(source.hello()))
            await _send(page, source.picture(None))
            async for m in ws:
                if m.type != WSMsgType.TEXT:
                    continue
                try:
                    data = json.loads(m.data)
                    t_s = float(data["t_s"]) if data.get("type") == "seek" else None
                except (ValueError, KeyError, TypeError, AttributeError):
                    continue
                if t_s is not None and not live:
                    await _send(page, source.picture(t_s))
        finally:
            pages.discard(page)
        return ws

    async def pusher() -> None:
        while True:
            await asyncio.sleep(PUSH_PERIOD_S)
            if not pages:
                continue
            pic = source.picture(None)
            now = time.monotonic()
            for page in list(pages):
                if page.seq == pic.seq and now - page.t_sent < IDLE_PUSH_PERIOD_S:
                    continue
                try:
                    await _send(page, pic)
                except (ConnectionError, RuntimeError):
                    pages.discard(page)

    async def start_pusher(app: web.Application) -> None:
        if live:
            tasks.append(asyncio.create_task(pusher()))

    async def close_pages(app: web.Application) -> None:
        for task in tasks:
            task.cancel()
        for page in list(pages):
            await page.ws.close(code=1001, message=b"server stopping")

    app.router.add_get("/", page_handler)
    app.router.add_get("/favicon.ico", no_icon)
    app.router.add_get("/ws", ws_handler)
    app.router.add_static("/static/", STATIC_DIR)
    app.on_startup.append(start_pusher)
    app.on_shutdown.append(close_pages)
    return app


def _error(done: Done, text: str) -> int:
    from rich.markup import escape

    done({"ok": False, "error": text}, f"[red]error:[/] {escape(text)}")
    sys.stdout.flush()
    return 2


def _load_replay(path: Path) -> list[Picture]:
    pictures = replay_pictures(messages_of(read_tlog(path)))
    if not pictures:
        raise ValueError(f"{path}: not a tlog (no MAVLink packet in it)")
    if not any(p.telemetry["vehicle"] is not None for p in pictures):
        raise ValueError(f"{path}: no position of a vehicle in it: nothing to replay")
    return pictures


def run(args: argparse.Namespace, client_factory: Callable[[], MavClient], done: Done) -> int:
    """Serve the map until SIGINT / SIGTERM. ``client_factory`` opens the link (not called for ``--tlog``);
    ``done(data, text)`` reports (``auv-gcs``'s output). Exit 0 stopped by SIGTERM, 130 by SIGINT, 2 when
    the port cannot be served, the tlog not read or the link not opened (LinkError / OSError from
    ``client_factory`` are the caller's to report)."""
    pictures: list[Picture] | None = None
    if args.tlog is not None:
        try:
            pictures = _load_replay(args.tlog)
        except (OSError, ValueError) as exc:
            return _error(done, str(exc))
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    try:
        sock.bind((HOST, args.port))
        sock.listen(64)
    except (OSError, OverflowError) as exc:  # taken, not ours to take, or no port number at all
        sock.close()
        return _error(done, f"cannot serve on {HOST}:{args.port}: {getattr(exc, 'strerror', None) or exc}")
    url = f"http://{HOST}:{sock.getsockname()[1]}/"
    if pictures is not None:
        source: Source = ReplaySource(pictures, args.tlog.name)
        return asyncio.run(_serve(sock, source, None, url, done, {"mode": "replay", "tlog": str(args.tlog)}))
    try:
        client = client_factory()
    except BaseException:
        sock.close()
        raise
    lock = threading.Lock()
    model = MapModel()
    link = LiveLink(client, model, lock)
    stop = threading.Event()
    thread = threading.Thread(target=link.run, args=(stop,), name="map-link", daemon=True)
    thread.start()
    try:
        return asyncio.run(
            _serve(sock, LiveSource(model, lock, args.connect), stop, url, done, {"mode": "live"})
        )
    finally:
        stop.set()
        thread.join(2.0)
        client.close()


async def _serve(
    sock: socket.socket,
    source: Source,
    stop_link: threading.Event | None,
    url: str,
    done: Done,
    extra: dict[str, Any],
) -> int:
    """Serve on ``sock`` until SIGINT (130) or SIGTERM (0); ``stop_link`` (live) is set on the way out."""
    app = make_app(source, live=stop_link is not None)
    runner = web.AppRunner(app, access_log=None, handle_signals=False, shutdown_timeout=1.0)
    await runner.setup()
    await web.SockSite(runner, sock).start()
    done({"ok": True, "url": url, **extra}, f"map on {url} (Ctrl-C stops it)")
    sys.stdout.flush()
    loop = asyncio.get_running_loop()
    stopped: asyncio.Future[int] = loop.create_future()

    def stop(code: int) -> None:
        if not stopped.done():
            stopped.set_result(code)

    loop.add_signal_handler(signal.SIGINT, stop, 130)
    loop.add_signal_handler(signal.SIGTERM, stop, 0)
    try:
        return await stopped
    finally:
        if stop_link is not None:
            stop_link.set()
        await runner.cleanup()
