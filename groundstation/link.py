"""The ground station's MAVLink 2 link to the vehicle: the socket, signing, the tlog, our heartbeat, and the
receive and wait primitives every client (:mod:`groundstation.mission_client`, ``command_client``,
``param_client``, ``ftp_client``) builds its transactions on.

It talks to the vehicle only over the wire (no onboard imports). Every packet sent and received is appended
to the session's ``.tlog`` (8-byte big-endian microseconds since the epoch, then the raw packet), the format
MAVProxy, QGroundControl and pymavlink read.

The vehicle's word: every STATUSTEXT from the vehicle is reassembled (MAVLink 2 chunks with a common ``id``
and ``chunk_seq`` 0, 1, ...; the text ends in the first chunk shorter than 50 characters) into
:class:`~groundstation.messages.StatusText` records (:attr:`Link.texts`). A refused COMMAND_ACK or
MISSION_ACK is followed by a STATUSTEXT with the vehicle's reason; :meth:`Link.reason_after` collects the
texts arriving within ``reason_window_s`` (0.3 s) after the ACK, for the clients to return with the result.

URLs: ``udpin:HOST:PORT`` listens (the vehicle sends there; default ``udpin:0.0.0.0:14550``) and answers the
address the vehicle's packets came from; ``udpout:HOST:PORT`` sends to a vehicle listening there;
``tcp:HOST:PORT`` connects to a vehicle's ``tcpin`` endpoint.
"""

from __future__ import annotations

import collections
import socket
import struct
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO, Self

from pymavlink.dialects.v20 import common as mavlink

from auv_common.mavlink_signing import SigningVerifier, signing_timestamp_now
from groundstation.messages import (
    NOT_READY_STATES,
    Msg,
    StatusText,
    StatusTextAssembler,
    pick_text,
    sensor_problems,
)

REASON_WINDOW_S = 0.3


class LinkError(RuntimeError):
    """No answer from the vehicle, or an unusable connection URL."""


@dataclass
class SigningStats:
    """Packets a signing client dropped: unsigned, signed with another key (or forged), old timestamps."""

    unsigned_rejected: int = 0
    bad_signature: int = 0
    old_timestamp: int = 0

    @property
    def dropped(self) -> int:
        return self.unsigned_rejected + self.bad_signature + self.old_timestamp


class Link:
    """A ground-station MAVLink 2 connection (system 255, component 190 by default).

    ``gcs_session``: this link is an operator's session (``monitor``, ``fly``, ``map``) and sends a
    MAV_TYPE_GCS HEARTBEAT every ``heartbeat_period_s``, which the vehicle's link watch counts (and reports
    lost when they stop). False: a one-shot tool (``arm``, ``upload``, ...) that sends no GCS heartbeat,
    so its exit is no "ground-station link lost" on the vehicle; the vehicle learns its address from its
    first message.
    """

    def __init__(
        self,
        url: str = "udpin:0.0.0.0:14550",
        *,
        system_id: int = 255,
        component_id: int = 190,
        tlog: Path | None = None,
        signing_key: bytes | None = None,
        heartbeat_period_s: float = 1.0,
        gcs_session: bool = True,
    ) -> None:
        parts = url.split(":")
        if len(parts) != 3 or parts[0] not in ("udpin", "udpout", "tcp"):
            raise LinkError(
                f"connection URL {url!r}: expected udpin:HOST:PORT, udpout:HOST:PORT or tcp:HOST:PORT"
            )
        kind, host, port_s = parts
        try:
            port = int(port_s)
        except ValueError:
            raise LinkError(f"connection URL {url!r}: bad port") from None
        self.kind = kind
        self._peer: tuple[str, int] | None = None
        if kind == "tcp":
            self.sock = socket.create_connection((host, port), timeout=5.0)
            self._stream = mavlink.MAVLink(None)
            self._stream.robust_parsing = True
        else:
            self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            if kind == "udpin":
                self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
                self.sock.bind((host, port))
            else:
                self.sock.bind(("0.0.0.0", 0))
                self._peer = (host, port)
        self.sock.setblocking(True)
        self.mav = mavlink.MAVLink(self, system_id, component_id)
        self.signing = SigningStats()
        self._verifier: SigningVerifier | None = None
        if signing_key is not None:
            self.mav.signing.secret_key = signing_key
            self.mav.signing.sign_outgoing = True
            self.mav.signing.timestamp = signing_timestamp_now()
            self._verifier = SigningVerifier(signing_key)  # the vehicle's replies are checked too
        self.system_id = system_id
        self.component_id = component_id
        self.target: tuple[int, int] = (1, 1)
        self._queue: collections.deque[Msg] = collections.deque()
        # unbuffered: each record is one append (O_APPEND), whole, also when another process appends too
        self._tlog: BinaryIO | None = tlog.open("ab", buffering=0) if tlog is not None else None
        self._hb_period_s = heartbeat_period_s
        self.gcs_session = gcs_session
        self._hb_next = 0.0
        self.rx_errors = 0
        self.on_message: Callable[[Msg], None] | None = None
        self.texts: collections.deque[StatusText] = collections.deque(maxlen=256)
        self._assembler = StatusTextAssembler()

    # ---- raw I/O -------------------------------------------------------------------------------
    def write(self, buf: bytes) -> None:
        """pymavlink's sink: send one packet (and record it)."""
        self._record(bytes(buf))
        try:
            if self.kind == "tcp":
                self.sock.sendall(buf)
            elif self._peer is not None:
                self.sock.sendto(buf, self._peer)
        except OSError:
            pass

    def _record(self, buf: bytes) -> None:
        if self._tlog is not None:
            self._tlog.write(struct.pack(">Q", int(time.time() * 1e6)) + buf)

    def signing_note(self) -> str:
        """ "" or, when packets were dropped by the signature check, a clause saying how many and why."""
        st = self.signing
        if not st.dropped:
            return ""
        return (
            f" (ignored {st.dropped} packets not signed with our key: {st.unsigned_rejected} unsigned, "
            f"{st.bad_signature} with another or a forged signature, {st.old_timestamp} replayed)"
        )

    def close(self) -> None:
        self.sock.close()
        if self._tlog is not None:
            self._tlog.close()
            self._tlog = None

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def send(self, msg: Msg) -> None:
        self.mav.send(msg)

    def heartbeat(self) -> None:
        """Our GCS HEARTBEAT (a session's; a one-shot client sends none, see the class docstring)."""
        if not self.gcs_session:
            return
        self.send(
            mavlink.MAVLink_heartbeat_message(
                mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, mavlink.MAV_STATE_ACTIVE, 3
            )
        )

    def _decode(self, data: bytes) -> list[Msg]:
        if self.kind == "tcp":
            msgs = self._stream.parse_buffer(data) or []
        else:
            parser = mavlink.MAVLink(None)  # fresh per datagram: a cut datagram cannot eat the next
            parser.robust_parsing = True
            try:
                msgs = parser.parse_buffer(data) or []
            except Exception:
                msgs = []
                self.rx_errors += 1
        out = []
        for m in msgs:
            if m.get_type() == "BAD_DATA":
                self.rx_errors += 1
                continue
            frame = bytes(m.get_msgbuf())
            if self._verifier is not None and not self._verifier.verify(frame, self.signing):
                continue  # unsigned, or not signed with our key, or replayed: not the vehicle we trust
            self._record(frame)
            out.append(m)
        return out

    def recv(self, timeout_s: float) -> Msg | None:
        """The next message, waiting at most ``timeout_s``; sends our heartbeat when due."""
        deadline = time.monotonic() + timeout_s
        while True:
            now = time.monotonic()
            if now >= self._hb_next and (self._peer is not None or self.kind == "tcp"):
                self._hb_next = now + self._hb_period_s
                self.heartbeat()
            if self._queue:
                msg = self._queue.popleft()
                if msg.get_type() == "STATUSTEXT" and self.from_vehicle(msg):
                    done = self._assembler.feed(msg, now)
                    if done is not None:
                        self.texts.append(done)
                self.texts.extend(self._assembler.flush(now))
                if self.on_message is not None:
                    self.on_message(msg)
                return msg
            remaining = deadline - now
            if remaining <= 0:
                return None
            self.sock.settimeout(min(remaining, max(0.01, self._hb_next - now)))
            try:
                if self.kind == "tcp":
                    data = self.sock.recv(65536)
                    addr = None
                else:
                    data, addr = self.sock.recvfrom(65535)
            except (TimeoutError, BlockingIOError):
                continue
            except OSError:
                continue
            msgs = self._decode(data)
            if msgs and addr is not None and self.kind == "udpin" and self._peer is None:
                self._peer = addr
            self._queue.extend(msgs)

    def drop_stale(self, kinds: tuple[str, ...]) -> int:
        """Read what is already waiting (without blocking) and drop the ``kinds`` messages among it, so a
        transaction does not take an answer to an earlier one (e.g. another ground station's MISSION_ACK,
        fanned out by the vehicle to every peer); other messages stay queued. Returns how many were dropped.
        """
        self.sock.settimeout(0.0)
        try:
            while True:
                try:
                    data = self.sock.recv(65536)
                except (BlockingIOError, TimeoutError):
                    break
                except OSError:
                    continue
                self._queue.extend(self._decode(data))
        finally:
            self.sock.settimeout(None)
        kept = collections.deque(m for m in self._queue if m.get_type() not in kinds)
        dropped = len(self._queue) - len(kept)
        self._queue = kept
        return dropped

    # ---- who is who ----------------------------------------------------------------------------
    def from_vehicle(self, m: Msg) -> bool:
        """True for a message of the vehicle this link talks to (its system and component id, as last
        heard)."""
        return bool((m.get_srcSystem(), m.get_srcComponent()) == self.target)

    def to_us(self, m: Msg) -> bool:
        """True for a message addressed to us or to everyone (target_system 0, or none)."""
        return getattr(m, "target_system", 0) in (0, self.system_id)

    # ---- waiting for the vehicle ---------------------------------------------------------------
    def wait_heartbeat(self, timeout_s: float = 5.0) -> Msg:
        """Wait for the vehicle's HEARTBEAT; remember its ids as the target.

        The vehicle sends one a second; to not wait that long, it is also asked for one
        (MAV_CMD_REQUEST_MESSAGE, broadcast) every 0.5 s while none came."""
        t0 = time.monotonic()
        deadline = t0 + timeout_s
        ask_at = t0 + 0.05
        while (left := deadline - time.monotonic()) > 0:
            if time.monotonic() >= ask_at:
                ask_at = time.monotonic() + 0.5
                request = mavlink.MAVLink_command_long_message(
                    0,
                    0,
                    mavlink.MAV_CMD_REQUEST_MESSAGE,
                    0,
                    mavlink.MAVLINK_MSG_ID_HEARTBEAT,
                    0,
                    0,
                    0,
                    0,
                    0,
                    0,
                )
                self.send(request)
            m = self.recv(min(left, max(0.01, ask_at - time.monotonic())))
            if m is not None and m.get_type() == "HEARTBEAT" and m.type != mavlink.MAV_TYPE_GCS:
                self.target = (m.get_srcSystem(), m.get_srcComponent())
                return m
        raise LinkError(f"no vehicle heartbeat within {timeout_s:.1f} s{self.signing_note()}")

    def wait_ready(self, timeout_s: float) -> tuple[bool, Msg | None, str]:
        """Wait until the vehicle's HEARTBEAT ``system_status`` is neither UNINIT nor BOOT (it reports BOOT
        until it is ready to start, e.g. until its navigation is valid).

        Returns (ready, the last vehicle HEARTBEAT or None, why not: the last SYS_STATUS sensor problem or
        STATUSTEXT of the vehicle, "" if none).
        """
        t0 = time.monotonic()
        deadline = t0 + timeout_s
        last_hb: Msg | None = None
        sys_reason = ""
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                break
            m = self.recv(min(left, 0.25))
            if m is None or not self.from_vehicle(m):
                continue
            kind = m.get_type()
            if kind == "HEARTBEAT" and m.type != mavlink.MAV_TYPE_GCS:
                last_hb = m
                if int(m.system_status) not in NOT_READY_STATES:
                    return True, m, ""
            elif kind == "SYS_STATUS":
                sys_reason = sensor_problems(m)
        texts = self.texts_since(t0) or list(self.texts)
        return False, last_hb, sys_reason or (texts[-1].text if texts else "")

    # ---- the vehicle's reasons ------------------------------------------------------------------
    def reason_after(
        self, t_sent: float, t_ack: float, window_s: float = REASON_WINDOW_S, *, wait: bool = True
    ) -> str:
        """The vehicle's reason for a refusal answered at ``t_ack`` (request sent at ``t_sent``): the first
        warning-or-worse STATUSTEXT after the ACK (waiting up to ``window_s`` for it), else one that came
        between the request and the ACK, else any text after the ACK; "" if the vehicle said nothing."""
        deadline = t_ack + window_s
        while wait and not pick_text(self.texts, t_ack, warning_only=True):
            left = deadline - time.monotonic()
            if left <= 0:
                break
            self.recv(min(left, 0.05))
        now = time.monotonic()
        self.texts.extend(self._assembler.flush(now, older_than_s=0.0 if now >= deadline else None))
        text = (
            pick_text(self.texts, t_ack, warning_only=True)
            or pick_text(self.texts, t_sent, warning_only=True)
            or pick_text(self.texts, t_ack, warning_only=False)
        )
        return text.text if text is not None else ""

    def texts_since(self, t_s: float) -> list[StatusText]:
        """The vehicle's texts that arrived at or after ``t_s`` (monotonic), oldest first."""
        return [t for t in self.texts if t.t_s >= t_s]
