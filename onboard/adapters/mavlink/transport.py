"""Sockets, peers, the selector, signing, the receive shares and the send fan-out (the I/O thread's tools).

:class:`Transport` owns the endpoint sockets (``udpout``, ``udpin``, ``tcpin`` and its connections), decodes
every UDP datagram on its own (:func:`onboard.adapters.mavlink.wire.decode_datagram`) with the signature
checked before the timestamp, learns the peers that speak to it (at most :data:`MAX_PEERS` per socket,
first come, kept while they speak, forgotten after :data:`PEER_EXPIRY_S`) and sends every message to every
peer (but the links given as ``exclude``: those with a stream rate of their own), or a reply to the one link
its request came over (:class:`~onboard.adapters.mavlink.peers.Sender` carries it: a transfer belongs to one
peer, not to a pair of ids two ground stations may share). :meth:`Transport.wake` (any thread) interrupts
:meth:`Transport.wait`.

Per link (a learned UDP address, the ``udpout`` target, one TCP connection; see
:mod:`~onboard.adapters.mavlink.peers`): its receive share (below), its output budget and, in
:mod:`~onboard.adapters.mavlink.telemetry`, its stream rates.

Output budgets (what one peer asks for never costs another its telemetry): every known peer has its own
token bucket of ``tx_peer_per_s`` messages, and the replies to addresses that are no peer share one; a
message to a peer beyond its budget is dropped for that peer alone (counted as ``tx_shed``; a reply to one
link is dropped before it is encoded), the others still get it.

TCP connections: a connection that sends no MAVLink message for ``tcp_idle_timeout_s`` is closed, and when
:data:`MAX_PEERS` connections are open, the one silent longest gives way to a new one if it has been silent
for ``tcp_evict_idle_s`` (a live ground station speaks every second, so silent connections never lock a
new station out, and a flood of connections never pushes a live one out).

Receive shares (floods starve no one): every known peer (a learned address, the ``udpout`` target, each TCP
connection, at most :data:`MAX_PEERS` of them) has its own token bucket of ``rx_peer_per_s`` and all other
addresses share one of ``rx_strangers_per_s``; a datagram beyond its sender's share is dropped unparsed
(counted as ``shed``), and one of many frames spends a token for each. With signing on, only a signed
message makes its sender a peer.
A socket is read until empty, at most :data:`READ_BATCH` datagrams per wake-up, so the kernel's buffer does
not overflow (which would drop the genuine ground station's datagrams with the flood's) and the timers keep
running between batches.

STATUSTEXT: :meth:`Transport.statustext` maps a core :class:`~onboard.core.commands.Severity` to
MAV_SEVERITY (the one table, :data:`MAV_SEVERITY`) and splits a text longer than 50 bytes into chunks with
a common non-zero ``id`` and ``chunk_seq`` 0, 1, ... (MAVLink 2; the last chunk ends with a NUL, so a text
that fills its last chunk exactly is followed by an empty one).
"""

from __future__ import annotations

import itertools
import logging
import selectors
import socket
from collections.abc import Callable, Collection
from dataclasses import dataclass, field
from typing import Any

from pymavlink.dialects.v20 import common as mavlink

from auv_common.token_bucket import TokenBucket
from onboard.adapters.mavlink.config import MavlinkConfig, parse_endpoint
from onboard.adapters.mavlink.peers import Addr, Link, Sender
from onboard.adapters.mavlink.wire import (
    RxStats,
    SigningVerifier,
    accept_frame,
    decode_datagram,
    signing_timestamp_now,
)
from onboard.core.commands import Severity

log = logging.getLogger(__name__)

PEER_EXPIRY_S = 30.0
MAX_PEERS = 16
READ_BATCH = 256
#: A share's burst: this many seconds of its rate at once.
SHARE_BURST_S = 0.2
STATUSTEXT_LEN = 50
OnMessage = Callable[[mavlink.MAVLink_message, Sender, float], None]

#: The one mapping of the core's note severities to MAV_SEVERITY.
MAV_SEVERITY: dict[Severity, int] = {
    Severity.CRITICAL: mavlink.MAV_SEVERITY_CRITICAL,
    Severity.ERROR: mavlink.MAV_SEVERITY_ERROR,
    Severity.WARNING: mavlink.MAV_SEVERITY_WARNING,
    Severity.NOTICE: mavlink.MAV_SEVERITY_NOTICE,
    Severity.INFO: mavlink.MAV_SEVERITY_INFO,
}


def addressed_to(msg: mavlink.MAVLink_message, system_id: int, component_id: int) -> bool:
    """True if ``msg`` targets (system_id, component_id) or broadcasts (0); messages without a target too."""
    ts = int(getattr(msg, "target_system", 0))
    tc = int(getattr(msg, "target_component", 0))
    return ts in (0, system_id) and tc in (0, component_id)


def statustext_chunks(text: str, chunk_id: int) -> list[tuple[bytes, int, int]]:
    """(text bytes, id, chunk_seq) of the STATUSTEXT messages for ``text``; one with id 0 if it fits."""
    raw = text.encode("ascii", "replace")
    if len(raw) <= STATUSTEXT_LEN:
        return [(raw, 0, 0)]
    chunks = [raw[i : i + STATUSTEXT_LEN] for i in range(0, len(raw), STATUSTEXT_LEN)]
    if len(chunks[-1]) == STATUSTEXT_LEN:
        chunks.append(b"")  # the NUL that ends the text
    return [(c, chunk_id, k) for k, c in enumerate(chunks)]


_serials = itertools.count(1)


@dataclass
class _Socket:
    kind: str
    sock: socket.socket
    fixed: Addr | None = None
    peers: dict[Addr, float] = field(default_factory=dict)  # learned address -> last rx (monotonic)
    shares: dict[Addr, TokenBucket] = field(default_factory=dict)  # learned address -> its receive share
    share: TokenBucket | None = None  # the share of the fixed address (udpout) or of the TCP connection
    budgets: dict[Addr, TokenBucket] = field(default_factory=dict)  # learned address -> its output budget
    budget: TokenBucket | None = None  # the output budget of the fixed address or of the TCP connection
    last_rx_s: float = 0.0  # a TCP connection: when it last sent a MAVLink message (or was accepted)
    stream_parser: Any = None  # for TCP connections
    server: bool = False
    secure: bool = False  # one of [mavlink] secure_endpoints (a TCP connection: its server's)
    serial: int = field(default_factory=lambda: next(_serials))


class _Fanout:
    """File-like sink for pymavlink's ``MAVLink.send``: one packet to every peer of every socket."""

    def __init__(self, transport: Transport) -> None:
        self.transport = transport

    def write(self, buf: bytes) -> None:
        self.transport._send_raw(bytes(buf))


class Transport:
    """The endpoint's sockets and the MAVLink encoder. All but :meth:`wake` run on the I/O thread."""

    def __init__(
        self,
        config: MavlinkConfig,
        clock: Callable[[], float],
        on_message: OnMessage,
        signing_key: bytes | None = None,
        signing_floor: int = 0,
        on_signing_advance: Callable[[int], None] | None = None,
    ) -> None:
        """``signing_key``: the MAVLink 2 signing key (None: signing off); ``signing_floor`` /
        ``on_signing_advance``: the persisted newest signing timestamp accepted, and where a newer one goes
        (:class:`~auv_common.mavlink_signing.SigningVerifier`); the vehicle's own outgoing timestamps start
        above the floor too."""
        self.config = config
        self._clock = clock
        self.on_message = on_message
        self.rx = RxStats()
        self.tx_packets = 0
        self.tx_errors = 0
        self.tx_shed = 0  # messages not sent to a peer: beyond its output budget
        self.tcp_closed_idle = 0  # TCP connections closed (or evicted) because they said nothing
        self._mav = mavlink.MAVLink(_Fanout(self), config.system_id, config.component_id)
        self._verifier: SigningVerifier | None = None
        self._on_signing_advance = on_signing_advance
        self.set_signing(signing_key, signing_floor)
        self._sockets: list[_Socket] = []
        self._selector: selectors.BaseSelector | None = None
        self._wake_r: socket.socket | None = None
        self._wake_w: socket.socket | None = None
        self._strangers = self._new_share(config.rx_strangers_per_s)
        self._strangers_tx = self._new_share(config.tx_peer_per_s)
        self._text_id = 0
        self._route: Link | None = None  # set while send(msg, link) encodes: the one destination
        self._exclude: Collection[Link] = ()  # set while send(msg, exclude=...) encodes: links left out

    # ---- lifecycle -----------------------------------------------------------------------------
    def open(self) -> None:
        """Open the sockets of every configured endpoint (and the wake-up pair)."""
        sel = selectors.DefaultSelector()
        for spec in self.config.endpoints:
            kind, host, port = parse_endpoint(spec)
            if kind == "tcpin":
                srv = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
                srv.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
                srv.bind((host, port))
                srv.listen(4)
                srv.setblocking(False)
                s = _Socket(kind, srv, server=True)
            else:
                sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 20)
                if kind == "udpin":
                    sock.bind((host, port))
                    s = _Socket(kind, sock)
                else:
                    sock.bind(("0.0.0.0", 0))
                    # by address, as recvfrom gives it back (a name would never match, and be learned again)
                    fixed = (socket.gethostbyname(host), port)
                    s = _Socket(kind, sock, fixed=fixed, share=self._peer_share(), budget=self._peer_budget())
                sock.setblocking(False)
            s.secure = spec in self.config.secure_endpoints
            self._sockets.append(s)
            sel.register(s.sock, selectors.EVENT_READ, s)
        self._wake_r, self._wake_w = socket.socketpair()
        self._wake_r.setblocking(False)
        self._wake_w.setblocking(False)
        sel.register(self._wake_r, selectors.EVENT_READ, None)
        self._selector = sel

    def close(self) -> None:
        for s in self._sockets:
            s.sock.close()
        self._sockets.clear()
        for w in (self._wake_r, self._wake_w):
            if w is not None:
                w.close()
        self._wake_r = self._wake_w = None
        if self._selector is not None:
            self._selector.close()
            self._selector = None

    @property
    def ports(self) -> list[int]:
        """Local ports of the endpoint's sockets (after :meth:`open`), in config order."""
        return [s.sock.getsockname()[1] for s in self._sockets if s.kind != "tcpconn"]

    @property
    def signing(self) -> bool:
        """Whether signing is on (every message but :data:`~onboard.adapters.mavlink.wire.UNSIGNED_ALLOWED`
        must then be signed with the key)."""
        return self._verifier is not None

    def set_signing(self, key: bytes | None, floor: int = 0) -> None:
        """Sign and verify with ``key`` from now on (None: signing off). No timestamp at or below ``floor``
        or below any accepted before is accepted; the vehicle's own timestamps go on increasing."""
        if key is None:
            self._verifier = None
            self._mav.signing.sign_outgoing = False
            self._mav.signing.secret_key = None
            return
        if self._verifier is not None:
            floor = max(floor, self._verifier.accepted)
        self._verifier = SigningVerifier(key, floor, self._on_signing_advance)
        self._mav.signing.secret_key = key
        self._mav.signing.link_id = self.config.signing_link_id
        self._mav.signing.sign_outgoing = True
        self._mav.signing.timestamp = max(self._mav.signing.timestamp, signing_timestamp_now(), floor + 1)

    def is_secure(self, link: Link | None) -> bool:
        """Whether ``link`` came over one of ``[mavlink] secure_endpoints``."""
        if link is None:
            return False
        return any(s.serial == link[0] and s.secure for s in self._sockets)

    def wake(self) -> None:
        """Interrupt :meth:`wait` (thread-safe; a no-op before :meth:`open`)."""
        w = self._wake_w
        if w is None:
            return
        try:
            w.send(b"\0")
        except OSError:  # full (already woken) or closed
            pass

    # ---- receive -------------------------------------------------------------------------------
    def wait(self, timeout_s: float) -> bool:
        """Wait up to ``timeout_s`` for input and dispatch every message received; False once closed."""
        sel = self._selector
        if sel is None:
            return False
        try:
            ready = sel.select(timeout_s)
        except (OSError, ValueError):
            return False
        self._close_idle_tcp(self._clock())
        for key, _ in ready:
            if key.data is None:
                self._drain_wake()
            else:
                self._read(key.data)
        return True

    def _drain_wake(self) -> None:
        r = self._wake_r
        if r is None:
            return
        try:
            while r.recv(4096):
                pass
        except OSError:
            pass

    @staticmethod
    def _new_share(rate_per_s: int) -> TokenBucket:
        return TokenBucket(float(rate_per_s), max(1.0, rate_per_s * SHARE_BURST_S))

    def _peer_share(self) -> TokenBucket:
        return self._new_share(self.config.rx_peer_per_s)

    def _peer_budget(self) -> TokenBucket:
        return self._new_share(self.config.tx_peer_per_s)

    def links(self) -> set[Link]:
        """The links of the known peers now (learned UDP addresses, ``udpout`` targets, TCP connections)."""
        out: set[Link] = set()
        for s in self._sockets:
            if s.kind == "tcpconn":
                out.add((s.serial, None))
            elif not s.server:
                out.update((s.serial, addr) for addr in s.peers)
                if s.fixed is not None:
                    out.add((s.serial, s.fixed))
        return out

    def _share_of(self, s: _Socket, addr: Addr) -> tuple[TokenBucket, bool]:
        """The receive share a datagram from ``addr`` spends, and whether it is a known peer's."""
        if addr == s.fixed and s.share is not None:
            return s.share, True
        share = s.shares.get(addr)
        if share is not None:
            return share, True
        return self._strangers, False

    def _dispatch(self, msg: mavlink.MAVLink_message, now: float, link: Link) -> None:
        try:
            self.on_message(msg, Sender(msg.get_srcSystem(), msg.get_srcComponent(), link), now)
        except Exception:  # never let one message kill the link
            log.exception("MAVLink message %s failed", msg.get_type())

    def _read(self, s: _Socket) -> None:
        if s.server:
            try:
                conn, _addr = s.sock.accept()
            except OSError:
                return
            now = self._clock()
            if not self._room_for_connection(now):
                self.rx.peers_refused += 1  # as many live connections as UDP peers: no more
                conn.close()
                return
            conn.setblocking(False)
            parser = mavlink.MAVLink(None)
            parser.robust_parsing = True
            c = _Socket(
                "tcpconn",
                conn,
                stream_parser=parser,
                share=self._peer_share(),
                budget=self._peer_budget(),
                secure=s.secure,
                last_rx_s=now,
            )
            self._sockets.append(c)
            assert self._selector is not None
            self._selector.register(conn, selectors.EVENT_READ, c)
            return
        if s.kind == "tcpconn":
            self._read_tcp(s)
            return
        for _ in range(READ_BATCH):  # bounded per wake-up so timers keep running under a flood
            try:
                data, addr = s.sock.recvfrom(65535)
            except (BlockingIOError, InterruptedError):
                return
            except OSError:
                return
            now = self._clock()
            share, known = self._share_of(s, addr)
            if not share.take(now):
                self.rx.shed += 1
                self.rx.shed_from_peers += known
                continue
            frames = decode_datagram(data, self.rx, self._verifier, s.secure)
            for k, (msg, _frame) in enumerate(frames):
                if k and not share.take(now):  # a datagram of many frames spends a token for each
                    self.rx.shed += len(frames) - k
                    self.rx.shed_from_peers += known * (len(frames) - k)
                    break
                if msg.get_signed() or self._verifier is None:  # with signing, only the signed make peers
                    self._learn(s, addr, now)
                self._dispatch(msg, now, (s.serial, addr))

    def _read_tcp(self, s: _Socket) -> None:
        try:
            data = s.sock.recv(65536)
        except (BlockingIOError, InterruptedError):
            return
        except OSError:
            data = b""
        if not data:
            self._close_tcp(s)
            return
        now = self._clock()
        msgs = s.stream_parser.parse_buffer(data) or []
        for msg in msgs:
            if s.share is not None and not s.share.take(now):
                self.rx.shed += 1
                self.rx.shed_from_peers += 1
                continue
            if msg.get_type() == "BAD_DATA":
                self.rx.malformed += 1
                continue
            frame = bytes(msg.get_msgbuf())
            if not accept_frame(frame, msg, self.rx, self._verifier, s.secure):
                continue
            self.rx.packets += 1
            s.last_rx_s = now
            self._dispatch(msg, now, (s.serial, None))

    def _close_tcp(self, s: _Socket) -> None:
        if self._selector is not None:
            self._selector.unregister(s.sock)
        s.sock.close()
        self._sockets.remove(s)

    def _close_idle_tcp(self, now: float) -> None:
        """Close the TCP connections that sent no MAVLink message for ``tcp_idle_timeout_s``."""
        for c in [c for c in self._sockets if c.kind == "tcpconn"]:
            if now - c.last_rx_s > self.config.tcp_idle_timeout_s:
                log.info("TCP connection %d closed: silent for %.0f s", c.serial, now - c.last_rx_s)
                self.tcp_closed_idle += 1
                self._close_tcp(c)

    def _room_for_connection(self, now: float) -> bool:
        """Whether a new TCP connection may be taken: fewer than :data:`MAX_PEERS` are open, or the one
        silent longest has been silent for ``tcp_evict_idle_s`` and is closed to make room."""
        conns = [c for c in self._sockets if c.kind == "tcpconn"]
        if len(conns) < MAX_PEERS:
            return True
        idlest = min(conns, key=lambda c: c.last_rx_s)
        if now - idlest.last_rx_s < self.config.tcp_evict_idle_s:
            return False
        log.info(
            "TCP connection %d gives way to a new one: silent for %.1f s",
            idlest.serial,
            now - idlest.last_rx_s,
        )
        self.tcp_closed_idle += 1
        self._close_tcp(idlest)
        return True

    def _learn(self, s: _Socket, addr: Addr, now: float) -> None:
        """Remember ``addr`` as a peer (first come, kept while it speaks: a full table of live peers is
        never emptied for a newcomer, so a flood of new addresses cannot push a ground station out)."""
        if addr == s.fixed:
            return
        if addr not in s.peers:
            if len(s.peers) >= MAX_PEERS:
                self._forget_expired(s, now)
            if len(s.peers) >= MAX_PEERS:
                self.rx.peers_refused += 1
                return
            s.shares[addr] = self._peer_share()
            s.budgets[addr] = self._peer_budget()
        s.peers[addr] = now

    @staticmethod
    def _forget_expired(s: _Socket, now: float) -> None:
        for addr, last in list(s.peers.items()):
            if now - last > PEER_EXPIRY_S:
                del s.peers[addr]
                s.shares.pop(addr, None)
                s.budgets.pop(addr, None)

    # ---- send ----------------------------------------------------------------------------------
    def _spend(self, budget: TokenBucket | None, now: float) -> bool:
        """Take one message from a peer's output budget; False (counted) when it is spent."""
        if budget is None or budget.take(now):
            return True
        self.tx_shed += 1
        return False

    def _budget_of(self, link: Link) -> TokenBucket:
        """The output budget of ``link``: its peer's own, or the one the addresses that are no peer share."""
        serial, addr = link
        for s in self._sockets:
            if s.serial != serial:
                continue
            if s.kind == "tcpconn" or (addr is not None and addr == s.fixed):
                return s.budget or self._strangers_tx
            return s.budgets.get(addr, self._strangers_tx) if addr is not None else self._strangers_tx
        return self._strangers_tx

    def _send_raw(self, buf: bytes) -> None:
        if self._route is not None:
            self._send_one(buf, self._route)
            return
        now = self._clock()
        exclude = self._exclude
        for s in list(self._sockets):
            if s.server:
                continue
            if s.kind == "tcpconn":
                if (s.serial, None) not in exclude and self._spend(s.budget, now):
                    self._put(s, buf, None)
                continue
            self._forget_expired(s, now)
            for addr in s.peers:
                if (s.serial, addr) not in exclude and self._spend(s.budgets.get(addr), now):
                    self._put(s, buf, addr)
            if s.fixed is not None and (s.serial, s.fixed) not in exclude and self._spend(s.budget, now):
                self._put(s, buf, s.fixed)
        self.tx_packets += 1

    def _put(self, s: _Socket, buf: bytes, addr: Addr | None) -> None:
        """One packet to one destination (an error there is counted and costs no other peer its copy)."""
        try:
            if s.kind == "tcpconn":
                s.sock.send(buf)
            elif addr is not None:
                s.sock.sendto(buf, addr)
        except OSError:
            self.tx_errors += 1

    def _send_one(self, buf: bytes, link: Link) -> None:
        serial, addr = link
        for s in self._sockets:
            if s.serial != serial:
                continue
            self._put(s, buf, addr)
            self.tx_packets += 1
            return
        self.tx_errors += 1  # the link is gone (a closed TCP connection): nobody to answer

    def send(
        self, msg: mavlink.MAVLink_message, link: Link | None = None, exclude: Collection[Link] = ()
    ) -> None:
        """Send one message to every peer but those of ``exclude``, or with ``link`` to that one only (I/O
        thread only). Each destination spends one message of its output budget; a reply to one link
        beyond its budget is dropped before it is encoded."""
        if link is not None and not self._spend(self._budget_of(link), self._clock()):
            return
        self._route = link
        self._exclude = exclude
        try:
            self._mav.send(msg)
        finally:
            self._route = None
            self._exclude = ()

    def reply(self, msg: mavlink.MAVLink_message, to: Sender) -> None:
        """Send ``msg`` to the link ``to`` came over (to every peer when it is not known)."""
        link = to.link if isinstance(to, Sender) else None
        if link is None:
            self.send(msg)
        else:
            self.send(msg, link)

    def statustext(self, severity: Severity, text: str, to: Sender | None = None) -> None:
        """One STATUSTEXT (chunked when longer than 50 bytes) with the severity mapped by the one table; to
        every peer, or with ``to`` to that sender's link only."""
        sev = MAV_SEVERITY.get(severity, mavlink.MAV_SEVERITY_INFO)
        if len(text.encode("ascii", "replace")) > STATUSTEXT_LEN:
            self._text_id = self._text_id % 65535 + 1
        for raw, chunk_id, seq in statustext_chunks(text, self._text_id):
            msg = mavlink.MAVLink_statustext_message(sev, raw, chunk_id, seq)
            if to is None:
                self.send(msg)
            else:
                self.reply(msg, to)
