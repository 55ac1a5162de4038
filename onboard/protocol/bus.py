"""Open a python-can bus from a program's configuration, with explicit arguments only.

Interfaces, chosen by configuration and nothing else:

- ``remote`` (bench default between processes): a python-can-remote hub on 127.0.0.1, hosted by the bench
  (``auv-hil run``); channel ``ws://127.0.0.1:PORT/``. No root, no kernel module, nothing leaves the machine.
- ``virtual``: inside one process (tests); channel is any name.
- ``local``: inside one process, every receiver gets the sent frame itself, not a copy
  (:class:`onboard.protocol.local_bus.LocalBus`): the one-process lock-step of a campaign run.
- ``socketcan``: a vehicle's ``can0`` (or ``vcan0`` where the kernel has it).
- ``udp_multicast``: only with ``hop_limit = 0`` and only when the group routes via ``lo``; by default
  multicast frames would go out on the LAN, so anything else is refused.

The bus classes are instantiated directly (never ``can.Bus(...)``), so python-can's configuration-file and
environment fallbacks are never consulted.
"""

from __future__ import annotations

import contextlib
import ipaddress
import json
import logging
import math
import re
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any, Literal
from urllib.parse import urlparse

import can
from can.typechecking import CanFilter

from auv_common.config import Bound, ConfigError, check_declared, param, require

log = logging.getLogger(__name__)

#: The frame logs python-can writes and reads: BLF, Vector ASCII, and candump -l (which cantools reads).
FRAME_LOG_SUFFIXES = (".blf", ".asc", ".log")
DEFAULT_HUB_PORT = 54701
DEFAULT_REMOTE_CHANNEL = f"ws://127.0.0.1:{DEFAULT_HUB_PORT}/"
DEFAULT_HUB_CHANNEL = "isimi100-bench"
LOOPBACK_HOSTS = ("127.0.0.1", "localhost", "::1")
_SOCKETCAN_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_-]{0,14}$")
_HOP_LIMIT_WHY = "udp_multicast needs hop_limit = 0: otherwise frames leave the machine"


def _udp_multicast_only(value: float, why: str, *, upper: bool) -> Bound:
    """A bound that holds with ``interface = "udp_multicast"`` only (the key means nothing elsewhere)."""
    unbounded = math.inf if upper else -math.inf
    return Bound(lambda c: value if c.interface == "udp_multicast" else unbounded, why)


@dataclass(frozen=True)
class BusConfig:
    """The ``[bus]`` table of a program's TOML configuration, opened by :func:`open_bus`."""

    interface: Literal["remote", "virtual", "local", "socketcan", "udp_multicast"] = param(
        "remote",
        desc="remote (a python-can-remote hub on 127.0.0.1), virtual or local (in one process), socketcan "
        "or udp_multicast (hop_limit 0, routed via lo)",
    )
    channel: str = param(
        DEFAULT_REMOTE_CHANNEL,
        desc="remote: the hub URL ws://host:port/; virtual, local: a name; socketcan: can0 or vcan0; "
        "udp_multicast: the multicast group address",
    )
    hub_channel: str = param(
        DEFAULT_HUB_CHANNEL,
        desc="the in-hub virtual channel (used by the program that hosts the hub; not empty)",
    )
    udp_port: int = param(
        43113,
        min=_udp_multicast_only(1, "1 with udp_multicast", upper=False),
        max=_udp_multicast_only(65535, "65535 with udp_multicast", upper=True),
        desc="udp_multicast: the UDP port of the group",
    )
    hop_limit: int = param(
        0,
        min=_udp_multicast_only(0, _HOP_LIMIT_WHY, upper=False),
        max=_udp_multicast_only(0, _HOP_LIMIT_WHY, upper=True),
        desc="udp_multicast: the multicast TTL",
    )
    record: str = param(
        "", desc='a .blf, .asc or .log (candump -l, which cantools reads) frame log of every frame ("" = off)'
    )
    retry_log_interval_s: float = param(
        3.0, unit="s", min=0.0, min_open=True,
        desc="while waiting for a bus that is not there yet, one log line this often",
    )  # fmt: skip
    reconnect_max_s: float = param(
        5.0, unit="s", min=0.2, max=60.0,
        desc="a bus lost while running is reopened after 0.2 s, the wait doubling after each failed attempt "
        "up to this (onboard.protocol.port.BusPort)",
    )  # fmt: skip

    def __post_init__(self) -> None:
        check_declared(self)
        require(bool(self.hub_channel), "hub_channel must not be empty")
        if self.record:
            require(
                self.record.endswith(FRAME_LOG_SUFFIXES),
                f"record must end in .blf, .asc or .log, got {self.record!r}",
            )
        if self.interface == "remote":
            remote_endpoint(self.channel)
        elif self.interface in ("virtual", "local"):
            require(bool(self.channel), f"{self.interface} channel must not be empty")
        elif self.interface == "socketcan":
            require(
                bool(_SOCKETCAN_NAME.match(self.channel)),
                f"malformed socketcan channel {self.channel!r} (expected e.g. can0 or vcan0)",
            )
        elif self.interface == "udp_multicast":
            try:
                group = ipaddress.ip_address(self.channel)
            except ValueError:
                raise ConfigError(f"udp_multicast channel {self.channel!r} is not an IP address") from None
            require(group.is_multicast, f"udp_multicast channel {self.channel} is not a multicast group")


def remote_endpoint(channel: str) -> tuple[str, int]:
    """(host, port) of a ``ws://host:port/`` hub URL; a :class:`ConfigError` if malformed or not loopback."""
    url = urlparse(channel)
    try:
        port = url.port
    except ValueError:
        port = None
    if url.scheme != "ws" or not url.hostname or port is None:
        raise ConfigError(f"malformed remote channel {channel!r} (expected ws://127.0.0.1:PORT/)")
    if url.hostname not in LOOPBACK_HOSTS:
        raise ConfigError(
            f"remote hub {url.hostname} is not loopback: the bench bus must not leave the machine"
        )
    return url.hostname, port


def check_multicast_route_via_lo(group: str) -> None:
    """Refuse a multicast group that does not route via ``lo`` (it would go out on the LAN)."""
    try:
        out = subprocess.run(
            ["ip", "-o", "route", "get", group], capture_output=True, text=True, timeout=5, check=False
        ).stdout
    except (OSError, subprocess.TimeoutExpired):
        out = ""
    if " dev lo " not in f" {out} ":
        raise ConfigError(
            f"multicast group {group} does not route via lo (ip route get: {out.strip() or 'no answer'}); "
            f"add one, e.g. 'ip route add {group}/32 dev lo', or use interface = \"remote\""
        )


class BusUnavailable(Exception):
    """The bus could not be opened before the caller gave up."""


def hub_went_away(exc: BaseException) -> bool:
    """Whether ``exc`` is python-can-remote's "the hub closed the connection" (a plain Exception there)."""
    return type(exc).__name__ == "WebsocketClosed"


def bus_lost(exc: BaseException) -> bool:
    """Whether ``exc`` from a bus's send or recv means the transport is gone (the one rule): the remote hub
    closed or reset the connection, a socketcan interface went down, any python-can error of the interface.
    Not an encoding error (a ``ValueError``: the frame is at fault, not the bus)."""
    return isinstance(exc, OSError | can.CanError) or hub_went_away(exc)


def loss_reason(exc: BaseException) -> str:
    """The operator's words for a lost bus (``CAN bus lost (...)``)."""
    if hub_went_away(exc):
        return "the hub closed the connection"
    text = str(exc).strip()
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def acceptance_filters(listen_ids: Iterable[int] | None) -> list[CanFilter] | None:
    """python-can ``can_filters`` that pass exactly the standard ids ``listen_ids`` (None: every frame).

    No ids (a node that only sends) gets a filter only extended id 0 passes: nothing on this bus, which uses
    standard ids only (python-can reads an empty filter list as "everything", and the hub would then queue
    every frame for a client that never reads).
    """
    if listen_ids is None:
        return None
    ids = sorted(set(listen_ids))
    if not ids:
        return [{"can_id": 0, "can_mask": 0x1FFFFFFF, "extended": True}]
    return [{"can_id": i, "can_mask": 0x7FF, "extended": False} for i in ids]


def _open_once(cfg: BusConfig, filters: list[CanFilter] | None) -> can.BusABC:
    if cfg.interface == "virtual":
        from can.interfaces.virtual import VirtualBus

        return VirtualBus(channel=cfg.channel, receive_own_messages=False)
    if cfg.interface == "local":
        from onboard.protocol.local_bus import LocalBus

        return LocalBus(channel=cfg.channel, can_filters=filters)  # filtered as frames are sent
    if cfg.interface == "remote":
        from can_remote import RemoteBus

        # The filters travel in the bus request: the hub applies them, other ids never reach this process.
        bus: Any = RemoteBus(cfg.channel, can_filters=filters)
        # python-can-remote leaves Nagle on for the client socket: small frames would wait for ACKs.
        bus.socket.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        remote: can.BusABC = bus
        return remote
    if cfg.interface == "socketcan":
        from can.interfaces.socketcan import SocketcanBus

        return SocketcanBus(channel=cfg.channel, can_filters=filters)  # filtered in the kernel
    check_multicast_route_via_lo(cfg.channel)
    from can.interfaces.udp_multicast import UdpMulticastBus

    return UdpMulticastBus(channel=cfg.channel, port=cfg.udp_port, hop_limit=cfg.hop_limit)


def open_bus(
    cfg: BusConfig,
    stop: threading.Event | None = None,
    timeout_s: float | None = None,
    listen_ids: Iterable[int] | None = None,
) -> can.BusABC:
    """Open the configured bus, waiting for it if it is not there yet.

    ``listen_ids``: the standard ids this node receives, as acceptance filters where they are applied
    outside this process: in the hub (``remote``) and in the kernel (``socketcan``), so a flood of other
    ids costs this process nothing; ``local`` applies them as a frame is sent. The other in-process buses
    (``virtual``, ``udp_multicast``) leave them to the port's receiver: python-can's software filter ends a
    non-blocking ``recv`` at the first frame it drops, which would cut every drain short. None: every frame.

    Retries every 0.2 s, logging one line every ``cfg.retry_log_interval_s``, until the bus opens, ``stop``
    is set or ``timeout_s`` passes (then :class:`BusUnavailable`). A configuration error (e.g. a multicast
    group not routed via ``lo``) raises :class:`ConfigError` at once.
    """
    filters = acceptance_filters(listen_ids)
    t0 = time.monotonic()
    next_log = t0
    while True:
        try:
            return _open_once(cfg, filters)
        except ConfigError:
            raise
        except (OSError, can.CanError, ConnectionError, ValueError) as exc:
            now = time.monotonic()
            if timeout_s is not None and now - t0 >= timeout_s:
                raise BusUnavailable(f"{cfg.interface} bus {cfg.channel} not available: {exc}") from None
            if now >= next_log:
                log.info("waiting for %s bus %s (%s)", cfg.interface, cfg.channel, exc)
                next_log = now + cfg.retry_log_interval_s
        if stop is not None and stop.wait(0.2):
            raise BusUnavailable("stopped while waiting for the bus")
        if stop is None:
            time.sleep(0.2)


class BenchHub:
    """The bench's python-can-remote hub, run as a process of its own (:mod:`onboard.protocol.hub`).

    A websocket server on loopback whose clients all hear each other. The hosting program's own bus,
    :attr:`bus` (acceptance filters ``listen_ids``, None: every frame; ``()``: it only sends), joins before
    the public port opens, so it hears every frame of the run. Apart from the simulation, a flood keeps the
    hub busy, not the bench.
    """

    def __init__(
        self,
        channel_url: str,
        hub_channel: str,
        listen_ids: Iterable[int] | None = None,
        start_timeout_s: float = 20.0,
    ) -> None:
        host, port = remote_endpoint(channel_url)
        self.host = host
        self.hub_channel = hub_channel
        cmd = [sys.executable, "-m", "onboard.protocol.hub", "--host", host, "--port", str(port)]
        self._proc = subprocess.Popen(
            [*cmd, "--channel", hub_channel],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
        )
        bus: can.BusABC | None = None
        try:
            private = self._answer("host_port", start_timeout_s, f"{host}:{port}")
            cfg = BusConfig(interface="remote", channel=f"ws://{host}:{private}/")
            bus = open_bus(cfg, timeout_s=start_timeout_s, listen_ids=listen_ids)
            assert self._proc.stdin is not None
            self._proc.stdin.write("open\n")
            self._proc.stdin.flush()
            self.port: int = self._answer("port", start_timeout_s, f"{host}:{port}")
        except BaseException:
            if bus is not None:
                bus.shutdown()
            self.close()
            raise
        self.bus: can.BusABC = bus
        self.url = f"ws://{host}:{self.port}/"
        log.info("bench CAN hub listening on %s (channel %s, pid %d)", self.url, hub_channel, self._proc.pid)

    def _answer(self, key: str, timeout_s: float, where: str) -> int:
        line = _read_line(self._proc, timeout_s)
        try:
            answer = json.loads(line) if line else {}
        except json.JSONDecodeError:
            answer = {}
        if key not in answer:
            reason = answer.get("error") or f"no answer within {timeout_s:.0f} s ({line!r})"
            raise OSError(f"CAN hub on {where} did not start: {reason}")
        return int(answer[key])

    def close(self) -> None:
        """Stop the hub (the host's :attr:`bus` is its user's to shut down, e.g. by its port)."""
        proc = self._proc
        if proc.stdin is not None and not proc.stdin.closed:
            with contextlib.suppress(OSError):  # the hub may have ended already: a broken pipe
                proc.stdin.close()  # the hub's signal to stop
        if proc.poll() is None:
            try:
                proc.wait(timeout=3.0)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait(timeout=3.0)
        if proc.stdout is not None:
            proc.stdout.close()


def _read_line(proc: subprocess.Popen[str], timeout_s: float) -> str:
    """The first stdout line of ``proc`` within ``timeout_s`` ("" if none)."""
    lines: list[str] = []
    reader = threading.Thread(target=lambda: lines.append(proc.stdout.readline() if proc.stdout else ""))
    reader.daemon = True
    reader.start()
    reader.join(timeout_s)
    return lines[0].strip() if lines else ""
