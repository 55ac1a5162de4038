"""The bench's CAN hub as a process of its own: ``python -m onboard.protocol.hub --port P --channel C``.

A python-can-remote ``RemoteServer`` on loopback whose clients all join one in-hub ``virtual`` channel. It
runs apart from the simulation (:class:`onboard.protocol.bus.BenchHub` starts it), so a flood that keeps
the hub busy takes a core of its own, not the bench's GIL. Each client's acceptance filters
(``can_filters`` in its bus request, :func:`onboard.protocol.bus.open_bus`) are applied inside the hub, so
frames a node does not listen to never reach its process (what a CAN controller's acceptance filter does).

Protocol with the parent: ``{"host_port": P0}`` on stdout, a private port the parent joins first (so it
hears every frame any other node sends, also one sent by a node that started first); ``open`` on stdin
once joined; then ``{"port": P}`` once the public port listens (or ``{"error": ...}``). The hub stops when
its stdin closes (the parent ended, however it ended) or on SIGTERM. SIGINT is ignored: Ctrl-C in a
terminal reaches the whole process group and the parent decides.

The hub serves only live clients. What one client costs the hub, and for how long:

- two threads (python-can-remote's: one reads the client's socket, one forwards the bus to it) and one
  in-hub bus whose receive queue holds at most :data:`CLIENT_QUEUE_FRAMES` frames (beyond, a frame is
  dropped for that client and counted: a receive FIFO overrun), only frames its acceptance filters pass;
- every frame it sends, forwarded once to each other client whose filters pass it, as it comes (no send
  budget: a flooding client keeps the hub's own core busy, not the bench's, issue 12);
- nothing that outlives its connection: python-can-remote's periodic sends (``periodic_start``, a task in
  the hub sending for the client) are refused with the reason (an ``error`` event, which the client's
  ``recv`` raises as ``RemoteError``), and the client's in-hub bus is shut down however its connection ends
  (a close, a reset, a socket error in either thread). Before, a client whose socket broke while the hub
  was writing to it left its bus and its periodic task behind: 10 k frames/s for ever (issue 21, row 12).
"""

from __future__ import annotations

import argparse
import copy
import json
import queue
import signal
import sys
import threading
import time
from typing import Any, ClassVar

import can
from can.interfaces.virtual import VirtualBus
from can_remote.server import ClientRequestHandler, RemoteServerProtocol
from can_remote.websocket import WebSocket, WebsocketClosed, get_accept_key

from onboard.protocol.bus import LOOPBACK_HOSTS

#: Frames queued in the hub for one client at most; beyond, a frame is dropped for that client and counted
#: (a CAN controller's receive FIFO overrun), never queued without bound for a client that does not read.
CLIENT_QUEUE_FRAMES = 4096
#: The reason a periodic send is refused (what the client's ``recv`` raises).
PERIODIC_REFUSED = (
    "periodic sends are refused by this hub: a periodic task would outlive the client's connection; "
    "send each frame yourself"
)
#: The python-can interface name of :class:`AcceptanceVirtualBus` (an entry point in pyproject.toml).
INTERFACE = "isimi100_hub"


class AcceptanceVirtualBus(VirtualBus):
    """python-can's virtual bus with the receiver's acceptance filters applied when a frame is sent.

    The hub's clients each get one (python-can-remote opens a bus per client with the client's
    ``can_filters``); a frame is copied only into the queues of the clients whose filters pass it, so a
    flood of ids nobody listens to costs one filter check per client, not a copy, a queue and a send.
    """

    _by_queue: ClassVar[dict[int, AcceptanceVirtualBus]] = {}
    dropped: ClassVar[int] = 0

    def __init__(self, channel: Any = "channel-0", **kwargs: Any) -> None:
        kwargs["rx_queue_size"] = CLIENT_QUEUE_FRAMES  # whatever a client asks for in its bus request
        super().__init__(channel=channel, **kwargs)
        self._by_queue[id(self.queue)] = self

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        self._check_if_open()
        timestamp = time.time()
        for bus_queue in list(self.channel):
            if bus_queue is self.queue:
                continue
            receiver = self._by_queue.get(id(bus_queue))
            if receiver is not None and not receiver._matches_filters(msg):
                continue
            frame = copy.copy(msg)
            frame.timestamp = timestamp
            frame.channel = self.channel_id
            frame.is_rx = True
            try:
                bus_queue.put_nowait(frame)
            except queue.Full:
                AcceptanceVirtualBus.dropped += 1

    def _send_periodic_internal(self, *_args: Any, **_kwargs: Any) -> Any:
        """Refused (the hub's clients' protocol answers ``periodic_start`` itself; this is the backstop)."""
        raise can.CanOperationError(PERIODIC_REFUSED)

    def shutdown(self) -> None:
        self._by_queue.pop(id(self.queue), None)
        super().shutdown()


class LiveClientProtocol(RemoteServerProtocol):
    """python-can-remote's server side of one client, bound to the client's connection.

    The same protocol, with two differences: ``periodic_start`` is refused with :data:`PERIODIC_REFUSED`
    (``periodic_stop`` has nothing to stop), and the client's in-hub bus is shut down however the
    connection ends. python-can-remote's forwarding thread died on a broken socket before its bus shutdown,
    leaving the bus (its queue, and any periodic task) behind for ever.
    """

    def __init__(self, config: dict[str, Any], websocket: Any) -> None:
        self._bus_lock = threading.Lock()
        super().__init__(config, websocket)

    def _close_bus(self) -> None:
        with self._bus_lock:
            self.bus.shutdown()  # idempotent: once from each thread at most

    def run(self) -> None:
        try:
            super().run()
        finally:
            self.running = False
            self._close_bus()

    def terminate(self, exc: Exception) -> None:
        """Close with the reason; a socket already broken has nobody to tell."""
        try:
            super().terminate(exc)
        except OSError:
            pass

    def _send_to_client(self) -> None:
        try:
            while self.running:
                msg = self.bus.recv(0.5)
                if msg is not None:
                    self.send_msg(msg)
        except Exception:  # the client's socket broke (or its bus closed): the client is gone
            self.running = False
        finally:
            self._close_bus()

    def _receive_from_client(self) -> None:
        while self.running:
            try:
                event = self.recv()
            except WebsocketClosed:
                break
            if event is None:
                continue
            if isinstance(event, can.Message):
                self.bus.send(event)
            elif event.get("type") == "periodic_start":
                self.send_error(PERIODIC_REFUSED)


class LiveClientHandler(ClientRequestHandler):
    """python-can-remote's request handler, serving each websocket with :class:`LiveClientProtocol`."""

    def start_websocket(self) -> None:
        self.send_response(101)
        self.send_header("Upgrade", "WebSocket")
        self.send_header("Connection", "Upgrade")
        self.send_header("Sec-WebSocket-Accept", get_accept_key(self.headers["Sec-WebSocket-Key"]))
        offered = [p.strip() for p in self.headers.get("Sec-WebSocket-Protocol", "can.json.v1").split(",")]
        protocol = "can.binary+json.v1" if "can.binary+json.v1" in offered else "can.json.v1"
        self.send_header("Sec-WebSocket-Protocol", protocol)
        self.end_headers()
        client = LiveClientProtocol(self.server.config, WebSocket(None, protocol, sock=self.request))
        self.server.clients.append(client)
        try:
            client.run()
        finally:
            self.server.clients.remove(client)


def _server(host: str, port: int, channel: str) -> Any:
    """A python-can-remote server on ``host:port`` (0: a free one) serving :class:`LiveClientHandler`."""
    from can_remote import RemoteServer

    server = RemoteServer(host=host, port=port, interface=INTERFACE, channel=channel)
    server.RequestHandlerClass = LiveClientHandler
    return server


def _tell_parent(answer: dict[str, Any]) -> None:
    sys.stdout.write(json.dumps(answer) + "\n")
    sys.stdout.flush()


def _serve(server: Any) -> None:
    threading.Thread(target=server.serve_forever, name="can-hub", daemon=True).start()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m onboard.protocol.hub", description=__doc__)
    parser.add_argument("--host", default="127.0.0.1", choices=LOOPBACK_HOSTS)
    parser.add_argument("--port", type=int, default=0, help="TCP port (0: a free one, printed)")
    parser.add_argument("--channel", required=True, help="the in-hub virtual channel")
    args = parser.parse_args(argv)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if INTERFACE not in can.interfaces.VALID_INTERFACES:
        _tell_parent(
            {"error": f"python-can has no interface {INTERFACE!r}: reinstall the package (pip install -e .)"}
        )
        return 3
    # The parent joins first, through a port of its own, so it hears every frame any other node sends (a
    # node that starts first and sends at once must not talk to nobody); then the public port opens.
    private = _server(args.host, 0, args.channel)
    _serve(private)
    _tell_parent({"host_port": private.server_port})
    if sys.stdin.readline().strip() != "open":  # the parent ended (EOF) or gave up
        return 0
    private.shutdown()  # its one connection stays; nobody else comes in that way
    private.server_close()
    try:
        server = _server(args.host, args.port, args.channel)
    except OSError as exc:
        _tell_parent({"error": f"cannot listen on {args.host}:{args.port}: {exc.strerror or exc}"})
        return 3
    _serve(server)
    _tell_parent({"port": server.server_port})
    done = threading.Event()
    signal.signal(signal.SIGTERM, lambda _s, _f: done.set())  # before: SIGTERM's default, ending at once

    def parent_watch() -> None:
        sys.stdin.read()  # returns at EOF: the parent closed the pipe or ended
        done.set()

    threading.Thread(target=parent_watch, name="parent-watch", daemon=True).start()
    done.wait()
    server.shutdown()
    server.server_close()
    if AcceptanceVirtualBus.dropped:
        sys.stderr.write(
            f"CAN hub: {AcceptanceVirtualBus.dropped} frames dropped for clients that did not read\n"
        )
    return 0


if __name__ == "__main__":
    # run from the module python-can loads the bus class from (its entry point), not from __main__: one
    # AcceptanceVirtualBus, one count of the frames dropped
    from onboard.protocol.hub import main as module_main

    sys.exit(module_main())
