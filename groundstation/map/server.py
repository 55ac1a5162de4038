"""``auv-gcs map``: the vehicle on a map in the browser, live or replayed from a tlog, served on 127.0.0.1.

One aiohttp server on one port serves the page (``/``), its static files (``/static/``) and a websocket
(``/ws``); nothing comes from elsewhere (no CDN, no map tiles). Every request must name the map in its Host
header (``127.0.0.1:PORT`` or ``localhost:PORT``, PORT the one served: another site's name rebound to
127.0.0.1 is refused, 403), and a websocket must come from the map's own origin (another site's page in the
operator's browser is refused, 403).

Live: one thread (:class:`LiveLink`) owns the :class:`~groundstation.mavclient.MavClient`: every message it
receives, also during a download or a file read, goes through its ``on_message`` hook into the
:class:`~groundstation.map.state.MapModel`; it asks the vehicle for its GPS_GLOBAL_ORIGIN at the start (the
vehicle streams it too: global items are drawn about it), downloads the mission and the fence at the start
and whenever the model says they may have changed, and once a second asks the CRC-32 of the vehicle's
planned path file (MAVLink FTP CalcFileCRC32: a few bytes), reading the file only when it changed. The
server pushes the model's picture to every page at most 10 times a second (when something changed, else
once a second); a picture that cannot be sent to a page is logged and that page dropped (closed: it
connects again), the others go on.

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
import zlib
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

from aiohttp import WSCloseCode, WSMsgType, web
from pymavlink.dialects.v20 import common as mavlink
from rich.text import Text

from groundstation.link import LinkError
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
from groundstation.mavclient import MavClient
from groundstation.messages import Msg
from groundstation.text import labelled
from groundstation.tlog import read_tlog

log = logging.getLogger(__name__)

STATIC_DIR = Path(__file__).with_name("static")
PUSH_PERIOD_S = 0.1  # at most 10 updates a second to a page
IDLE_PUSH_PERIOD_S = 1.0  # an update a second when nothing changed (the link's age moves on)
PATH_PERIOD_S = 1.0
RETRY_S = 2.0
NO_READER_NOTE = "the planned path is not shown: this ground station cannot read the vehicle's files yet"
#: The names the map answers to in a request's Host header (with the port it serves on).
HOST_NAMES = ("127.0.0.1", "localhost")

Done = Callable[[dict[str, Any], str | Text], None]


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
        self._path_crc: int | None = None  # CRC-32 of the path file as last read whole (None: read it)

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
        self._request_origin()
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

    def _request_origin(self) -> None:
        """Ask the vehicle for its GPS_GLOBAL_ORIGIN now (it streams it every few seconds too; the answer
        comes in through the model like every message). Not waited for: the stream is the fallback."""
        ts, tc = self.client.target
        self.client.send(
            mavlink.MAVLink_command_long_message(
                ts, tc, mavlink.MAV_CMD_REQUEST_MESSAGE, 0, mavlink.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN,
                0, 0, 0, 0, 0, 0,
            )
        )  # fmt: skip

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
        """The vehicle's planned path file into the model: its CRC-32 asked first, the file read only when
        that differs from the CRC of the file last read whole (or the vehicle computes none)."""
        # (no on_other: the client's on_message hook already sees every message that comes during the read)
        reader = getattr(self.client, "read_file", None)
        path: dict[str, Any] | None = None
        note = ""
        if reader is None:
            note = NO_READER_NOTE
        else:
            known, self._path_crc = self._path_crc, None  # kept only by a check or a read that succeeds
            try:
                crc = file_crc32(self.client, PLANNED_PATH_FILE)
                if crc is not None and crc == known:
                    self._path_crc = known
                    return  # the same file: the model has it
                raw = reader(PLANNED_PATH_FILE)
                path = parse_planned(raw)
                self._path_crc = zlib.crc32(raw)
            except LinkError as exc:
                note = f"no planned path: {exc}"
            except ValueError as exc:
                note = str(exc)
        if note != self._note:
            log.info("%s", note or "the planned path is read")
            self._note = note
        with self.lock:
            self.model.set_path(path, note)


def file_crc32(client: Any, path: str) -> int | None:
    """CalcFileCRC32 of a vehicle file (:meth:`MavClient.file_crc32`), None when the client or the vehicle
    cannot compute one (then the file is read every time). Raises :class:`LinkError` for a missing file
    or no answer."""
    own = getattr(client, "file_crc32", None)
    if own is None:
        return None
    crc = own(path)
    return None if crc is None else int(crc)


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


Handler = Callable[[web.Request], Awaitable[web.StreamResponse]]


def _host_ok(request: web.Request) -> bool:
    """True if the request's Host header is ``127.0.0.1:PORT`` or ``localhost:PORT``, PORT the one this
    connection came in on (the port served)."""
    sockname = request.transport.get_extra_info("sockname") if request.transport is not None else None
    if not sockname:
        return False
    port = sockname[1]
    return request.host in {f"{name}:{port}" for name in HOST_NAMES}


@web.middleware
async def _only_our_host(request: web.Request, handler: Handler) -> web.StreamResponse:
    """DNS rebinding: another site's page whose name its DNS now gives as 127.0.0.1 is of the same origin
    as that name, but its requests name it in the Host header: refused, on every route."""
    if not _host_ok(request):
        return web.Response(status=403, text="not the map's host name (127.0.0.1 or localhost)")
    return await handler(request)


def make_app(source: Source, *, live: bool) -> web.Application:
    """The page, its static files and the websocket; live: a task pushes pictures to every page."""
    pages: set[_Page] = set()
    tasks: list[asyncio.Task[None]] = []
    closing: set[asyncio.Task[Any]] = set()
    app = web.Application(middlewares=[_only_our_host])
    index = (STATIC_DIR / "index.html").read_bytes()

    def drop(page: _Page, why: str) -> None:
        """Send that page nothing more, and close its websocket (its page connects again) in the
        background: a close waits for the page's answer, the other pages do not."""
        pages.discard(page)
        task = asyncio.ensure_future(page.ws.close(code=WSCloseCode.INTERNAL_ERROR, message=why.encode()))
        closing.add(task)
        task.add_done_callback(closing.discard)

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
            try:
                await _send(page, source.picture(None))
            except (ConnectionError, RuntimeError):
                return ws
            except Exception:  # as in the pusher: this page is not sent this picture, and connects again
                log.exception("the map cannot send a picture to a page")
                await ws.close(code=WSCloseCode.INTERNAL_ERROR, message=b"cannot send this picture")
                return ws
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
                    pages.discard(page)  # gone
                except Exception:  # this picture (a NaN, say): this page, not the map, stops
                    log.exception("the map cannot send a picture to a page: that page is dropped")
                    drop(page, "the ground station cannot send this picture")

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
    done({"ok": False, "error": text}, labelled("error:", "red", text))
    sys.stdout.flush()
    return 2


def _load_replay(path: Path) -> list[Picture]:
    pictures = replay_pictures(messages_of(read_tlog(path)))
    if not pictures:
        raise ValueError(f"{path}: not a tlog (no MAVLink packet in it)")
    if not any(p.telemetry["vehicle"] is not None for p in pictures):
        raise ValueError(f"{path}: no position of a vehicle in it: nothing to replay")
    return pictures


def run(args: argparse.Namespace, client_factory: Callable[[], MavClient], done: Done, *, host: str) -> int:
    """Serve the map on ``host`` until SIGINT / SIGTERM. ``client_factory`` opens the link (not called for
    ``--tlog``); ``done(data, text)`` reports (``auv-gcs``'s output). Exit 0 stopped by SIGTERM, 130 by
    SIGINT, 2 when the port cannot be served, the tlog not read or the link not opened (LinkError / OSError
    from ``client_factory`` are the caller's to report)."""
    pictures: list[Picture] | None = None
    if args.tlog is not None:
        try:
            pictures = _load_replay(args.tlog)
        except (OSError, ValueError) as exc:
            return _error(done, str(exc))
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    try:
        sock.bind((host, args.port))
        sock.listen(64)
    except (OSError, OverflowError) as exc:  # taken, not ours to take, or no port number at all
        sock.close()
        return _error(done, f"cannot serve on {host}:{args.port}: {getattr(exc, 'strerror', None) or exc}")
    url = f"http://{host}:{sock.getsockname()[1]}/"
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
