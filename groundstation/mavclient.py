"""A small MAVLink 2 client for the ground station: UDP/TCP, tlog recording, mission/command/param helpers.

It talks to the vehicle only over the wire (no onboard imports). Every packet sent and received is appended
to the session's ``.tlog`` (8-byte big-endian microseconds since the epoch, then the raw packet), the format
MAVProxy, QGroundControl and pymavlink read.

The vehicle's word: every STATUSTEXT from the vehicle is reassembled (MAVLink 2 chunks with a common ``id``
and ``chunk_seq`` 0, 1, ...; the text ends in the first chunk shorter than 50 characters) into
:class:`StatusText` records (:attr:`MavClient.texts`). A refused COMMAND_ACK or MISSION_ACK is followed by a
STATUSTEXT with the vehicle's reason; :meth:`MavClient.command_ack` and :meth:`MavClient.upload` collect the
texts arriving within ``reason_window_s`` (0.3 s) after the ACK and return the reason with the result.

URLs: ``udpin:HOST:PORT`` listens (the vehicle sends there; default ``udpin:0.0.0.0:14550``) and answers the
address the vehicle's packets came from; ``udpout:HOST:PORT`` sends to a vehicle listening there;
``tcp:HOST:PORT`` connects to a vehicle's ``tcpin`` endpoint.
"""

from __future__ import annotations

import collections
import math
import socket
import struct
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path

from pymavlink.dialects.v20 import common as mavlink

from auv_common import mavlink_ftp as ftp
from auv_common.mavlink_signing import SigningVerifier, signing_timestamp_now

Msg = mavlink.MAVLink_message
MISSION_RESULT_NAMES = {
    v: k
    for k, v in vars(mavlink).items()
    if k.startswith("MAV_MISSION_") and isinstance(v, int) and "TYPE" not in k
}
MAV_RESULT_NAMES = {
    v: k for k, v in vars(mavlink).items() if k.startswith("MAV_RESULT_") and isinstance(v, int)
}
MAV_STATE_NAMES = {
    v: k for k, v in vars(mavlink).items() if k.startswith("MAV_STATE_") and isinstance(v, int)
}
#: The vehicle's HEARTBEAT custom_mode: ArduSub's mode numbers (pymavlink's ``mode_mapping_sub``).
ARDUSUB_MANUAL, ARDUSUB_AUTO, ARDUSUB_POSHOLD, ARDUSUB_CIRCLE, ARDUSUB_SURFACE = 19, 3, 16, 7, 9
#: HEARTBEAT system_status values meaning "not ready yet" (the vehicle reports BOOT until it could start).
NOT_READY_STATES = (mavlink.MAV_STATE_UNINIT, mavlink.MAV_STATE_BOOT)
STATUSTEXT_LEN = 50
REASON_WINDOW_S = 0.3
#: Answers of the mission protocol: ones already waiting when a transfer begins are stale.
MISSION_REPLIES = (
    "MISSION_ACK",
    "MISSION_COUNT",
    "MISSION_ITEM_INT",
    "MISSION_REQUEST_INT",
    "MISSION_REQUEST",
)


class LinkError(RuntimeError):
    """No answer from the vehicle, or an unusable connection URL."""


class UnknownParameter(LinkError):
    """The vehicle has no parameter of that name (a refusal, not a link problem)."""


@dataclass(frozen=True)
class Item:
    """One mission item in MISSION_ITEM_INT encoding (local x/y = metres * 1e4; global = degrees * 1e7)."""

    frame: int
    command: int
    param1: float
    param2: float
    param3: float
    param4: float
    x: int
    y: int
    z: float
    autocontinue: int = 1


@dataclass(frozen=True)
class TransferResult:
    """Outcome of a mission transfer: MAV_MISSION result code, its name, time taken, resends, and on a
    refusal the vehicle's reason (its STATUSTEXT; "" if it sent none)."""

    ok: bool
    result: int
    result_name: str
    elapsed_s: float
    resends: int
    reason: str = ""


@dataclass(frozen=True)
class StatusText:
    """One (reassembled) STATUSTEXT of the vehicle: MAV_SEVERITY, the text, when it arrived (monotonic s).

    ``complete`` is False for a chunked text whose last chunk never came (the chunks that did, in order)."""

    severity: int
    text: str
    t_s: float
    complete: bool = True


@dataclass(frozen=True)
class CommandAck:
    """The vehicle's answer to one command: the MAV_RESULT, its name, and the vehicle's reason (the
    STATUSTEXT it sent with a refusal; "" if none came within the window)."""

    result: int
    result_name: str
    reason: str = ""
    texts: tuple[str, ...] = ()

    @property
    def ok(self) -> bool:
        return self.result == mavlink.MAV_RESULT_ACCEPTED


class StatusTextAssembler:
    """Reassembles STATUSTEXT chunks (MAVLink 2 ``id`` / ``chunk_seq``) into whole texts."""

    def __init__(self, max_age_s: float = 2.0) -> None:
        self.max_age_s = max_age_s
        self._parts: dict[tuple[int, int, int], tuple[int, float, dict[int, str]]] = {}

    def feed(self, msg: Msg, now_s: float) -> StatusText | None:
        """The completed text this message finishes (a single-message text at once), else None."""
        text = _text(msg.text)
        chunk_id = int(getattr(msg, "id", 0) or 0)
        if chunk_id == 0:
            return StatusText(int(msg.severity), text, now_s)
        key = (msg.get_srcSystem(), msg.get_srcComponent(), chunk_id)
        severity, _t, parts = self._parts.get(key, (int(msg.severity), now_s, {}))
        parts[int(getattr(msg, "chunk_seq", 0) or 0)] = text
        if len(text) < STATUSTEXT_LEN:  # the last chunk (it ends with a NUL)
            self._parts.pop(key, None)
            last = max(parts)
            complete = all(k in parts for k in range(last + 1))
            return StatusText(severity, "".join(parts[k] for k in sorted(parts)), now_s, complete)
        self._parts[key] = (severity, now_s, parts)
        return None

    def flush(self, now_s: float, older_than_s: float | None = None) -> list[StatusText]:
        """Texts whose last chunk did not come within ``older_than_s`` (default ``max_age_s``), incomplete."""
        age = self.max_age_s if older_than_s is None else older_than_s
        out = []
        for key, (severity, t, parts) in list(self._parts.items()):
            if now_s - t >= age:
                del self._parts[key]
                out.append(StatusText(severity, "".join(parts[k] for k in sorted(parts)), now_s, False))
        return out


def state_from_heartbeat(msg: Msg) -> str:
    """Mission state from the vehicle's HEARTBEAT: its ArduSub mode, SAFETY_ARMED and system_status (the
    vehicle's README, "Modes": MANUAL is IDLE or, armed, ARMED; AUTO RUNNING; POSHOLD HOLD; CIRCLE COMPLETE;
    SURFACE is ABORT when CRITICAL, else COMPLETE)."""
    mode = int(msg.custom_mode)
    if mode == ARDUSUB_MANUAL:
        return "ARMED" if msg.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED else "IDLE"
    if mode == ARDUSUB_SURFACE:
        return "ABORT" if msg.system_status >= mavlink.MAV_STATE_CRITICAL else "COMPLETE"
    named = {ARDUSUB_AUTO: "RUNNING", ARDUSUB_POSHOLD: "HOLD", ARDUSUB_CIRCLE: "COMPLETE"}
    return named.get(mode, f"?{mode}")


class MavClient:
    """A ground-station MAVLink 2 connection (system 255, component 190 by default).

    ``gcs_session``: this client is an operator's session (``monitor``, ``fly``, ``map``) and sends a
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
        self._tlog = tlog.open("ab", buffering=0) if tlog is not None else None
        self._hb_period_s = heartbeat_period_s
        self.gcs_session = gcs_session
        self._hb_next = 0.0
        self._confirmation = 0
        self._ftp_seq = 0
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

    def __enter__(self) -> MavClient:
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
                if msg.get_type() == "STATUSTEXT" and self._from_target(msg):
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
                self.send(
                    mavlink.MAVLink_command_long_message(
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
                )
            m = self.recv(min(left, max(0.01, ask_at - time.monotonic())))
            if m is not None and m.get_type() == "HEARTBEAT" and m.type != mavlink.MAV_TYPE_GCS:
                self.target = (m.get_srcSystem(), m.get_srcComponent())
                return m
        raise LinkError(f"no vehicle heartbeat within {timeout_s:.1f} s{self.signing_note()}")

    def _from_target(self, m: Msg) -> bool:
        return (m.get_srcSystem(), m.get_srcComponent()) == self.target

    def from_vehicle(self, m: Msg) -> bool:
        """True for a message of the vehicle this client talks to (its system id, as last heard)."""
        return self._from_target(m)

    def _to_us(self, m: Msg) -> bool:
        ts = getattr(m, "target_system", 0)
        return ts in (0, self.system_id)

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

    # ---- mission protocol ----------------------------------------------------------------------
    def upload(
        self,
        items: list[Item],
        mission_type: int = mavlink.MAV_MISSION_TYPE_MISSION,
        *,
        progress: Callable[[int, int], None] | None = None,
        resend_s: float = 0.4,
        timeout_s: float = 8.0,
    ) -> TransferResult:
        """Upload a plan; returns the vehicle's MISSION_ACK result (or a timeout, result -1).

        The vehicle re-requests a missing item every 250 ms; to recover faster from a lost packet the
        client also resends its last message when no answer came within a few measured round trips
        (at least 30 ms, at most ``resend_s``): a lost item is then delivered, and a lost request is
        answered by the vehicle with a fresh request for the item it needs.
        """
        self.drop_stale(MISSION_REPLIES)
        t0 = time.monotonic()
        n = len(items)
        ts, tc = self.target
        count_msg = mavlink.MAVLink_mission_count_message(ts, tc, n, mission_type)
        self.send(count_msg)
        resends = 0
        got_request = False
        last_sent: Msg = count_msg
        sent_last_item = n == 0
        last_tx = last_progress = time.monotonic()
        done = 0
        rtt_s = resend_s / 4.0
        wait_s = resend_s
        while True:
            now = time.monotonic()
            if now - last_progress > timeout_s:
                return TransferResult(
                    False, -1, "TIMEOUT", now - t0, resends, self.signing_note().strip(" ()")
                )
            m = self.recv(max(0.0, min(wait_s - (now - last_tx), 0.1)))
            now = time.monotonic()
            if m is None:
                if now - last_tx >= wait_s:
                    wait_s = min(resend_s, wait_s * 2.0)  # back off while nothing comes back
                    self.send(last_sent if got_request else count_msg)
                    resends += 1
                    last_tx = now
                continue
            if not (self._from_target(m) and self._to_us(m)):
                continue
            kind = m.get_type()
            if kind in ("MISSION_REQUEST_INT", "MISSION_REQUEST") and m.mission_type == mission_type:
                if not 0 <= m.seq < n:
                    continue
                got_request = True
                it = items[m.seq]
                last_sent = mavlink.MAVLink_mission_item_int_message(
                    ts, tc, m.seq, it.frame, it.command, 0, it.autocontinue,
                    it.param1, it.param2, it.param3, it.param4, it.x, it.y, it.z, mission_type,
                )  # fmt: skip
                if m.seq == done and done > 0:  # answer to our last item: a round-trip sample
                    rtt_s = 0.8 * rtt_s + 0.2 * (now - last_tx)
                self.send(last_sent)
                last_tx = now
                wait_s = min(resend_s, max(0.03, 4.0 * rtt_s))
                if m.seq >= done:
                    done = m.seq + 1
                    last_progress = now
                    if progress is not None:
                        progress(m.seq, n)
                if m.seq == n - 1:
                    sent_last_item = True
            elif kind == "MISSION_ACK" and m.mission_type == mission_type:
                if m.type == mavlink.MAV_MISSION_ACCEPTED and not sent_last_item:
                    continue  # a stale ACK of an earlier transfer
                if progress is not None and m.type == mavlink.MAV_MISSION_ACCEPTED:
                    progress(n, n)
                name = MISSION_RESULT_NAMES.get(m.type, str(m.type))
                elapsed = time.monotonic() - t0
                ok = m.type == mavlink.MAV_MISSION_ACCEPTED
                reason = "" if ok else self.reason_after(t0, time.monotonic())
                return TransferResult(ok, int(m.type), name, elapsed, resends, reason)

    def download(
        self,
        mission_type: int = mavlink.MAV_MISSION_TYPE_MISSION,
        *,
        resend_s: float = 0.5,
        retries: int = 10,
    ) -> list[Item]:
        """Download a plan (MISSION_REQUEST_LIST, then MISSION_REQUEST_INT per item, then MISSION_ACK)."""
        self.drop_stale(MISSION_REPLIES)
        ts, tc = self.target
        req = mavlink.MAVLink_mission_request_list_message(ts, tc, mission_type)
        count_msg = self._request_reply(
            req, "MISSION_COUNT", lambda m: m.mission_type == mission_type, resend_s, retries
        )
        if count_msg.get_type() == "MISSION_ACK":
            raise LinkError(f"download refused: {MISSION_RESULT_NAMES.get(count_msg.type, count_msg.type)}")
        items: list[Item] = []
        for seq in range(count_msg.count):
            r = mavlink.MAVLink_mission_request_int_message(ts, tc, seq, mission_type)
            m = self._request_reply(
                r,
                "MISSION_ITEM_INT",
                lambda m, s=seq: m.seq == s and m.mission_type == mission_type,
                resend_s,
                retries,
            )
            if m.get_type() == "MISSION_ACK":
                raise LinkError(f"download failed: {MISSION_RESULT_NAMES.get(m.type, m.type)}")
            items.append(
                Item(
                    m.frame, m.command, m.param1, m.param2, m.param3, m.param4, m.x, m.y, m.z, m.autocontinue
                )
            )
        self.send(mavlink.MAVLink_mission_ack_message(ts, tc, mavlink.MAV_MISSION_ACCEPTED, mission_type))
        return items

    def _request_reply(
        self, req: Msg, kind: str, match: Callable[[Msg], bool], resend_s: float, retries: int
    ) -> Msg:
        """Send ``req`` until a ``kind`` message matching ``match`` (or a MISSION_ACK error) arrives."""
        for _ in range(retries):
            self.send(req)
            deadline = time.monotonic() + resend_s
            while (left := deadline - time.monotonic()) > 0:
                m = self.recv(left)
                if m is None or not (self._from_target(m) and self._to_us(m)):
                    continue
                if m.get_type() == kind and match(m):
                    return m
                if m.get_type() == "MISSION_ACK" and kind != "MISSION_ACK" and m.type != 0:
                    return m
        raise LinkError(f"no {kind} from the vehicle after {retries} tries{self.signing_note()}")

    def clear(
        self, mission_type: int = mavlink.MAV_MISSION_TYPE_MISSION, *, resend_s: float = 0.5
    ) -> TransferResult:
        """MISSION_CLEAR_ALL with retries; returns the vehicle's ACK."""
        self.drop_stale(MISSION_REPLIES)
        t0 = time.monotonic()
        ts, tc = self.target
        req = mavlink.MAVLink_mission_clear_all_message(ts, tc, mission_type)
        m = self._request_reply(req, "MISSION_ACK", lambda m: m.mission_type == mission_type, resend_s, 10)
        name = MISSION_RESULT_NAMES.get(m.type, str(m.type))
        elapsed = time.monotonic() - t0
        ok = m.type == mavlink.MAV_MISSION_ACCEPTED
        return TransferResult(
            ok, int(m.type), name, elapsed, 0, "" if ok else self.reason_after(t0, time.monotonic())
        )

    # ---- the vehicle's reasons ------------------------------------------------------------------
    def reason_after(
        self, t_sent: float, t_ack: float, window_s: float = REASON_WINDOW_S, *, wait: bool = True
    ) -> str:
        """The vehicle's reason for a refusal answered at ``t_ack`` (request sent at ``t_sent``): the first
        warning-or-worse STATUSTEXT after the ACK (waiting up to ``window_s`` for it), else one that came
        between the request and the ACK, else any text after the ACK; "" if the vehicle said nothing."""
        deadline = t_ack + window_s
        while wait and not _pick(self.texts, t_ack, warning_only=True):
            left = deadline - time.monotonic()
            if left <= 0:
                break
            self.recv(min(left, 0.05))
        now = time.monotonic()
        self.texts.extend(self._assembler.flush(now, older_than_s=0.0 if now >= deadline else None))
        text = (
            _pick(self.texts, t_ack, warning_only=True)
            or _pick(self.texts, t_sent, warning_only=True)
            or _pick(self.texts, t_ack, warning_only=False)
        )
        return text.text if text is not None else ""

    def texts_since(self, t_s: float) -> list[StatusText]:
        """The vehicle's texts that arrived at or after ``t_s`` (monotonic), oldest first."""
        return [t for t in self.texts if t.t_s >= t_s]

    # ---- commands and parameters ---------------------------------------------------------------
    def command(self, command: int, *params: float, resend_s: float = 1.0, retries: int = 3) -> int:
        """COMMAND_LONG with retries (confirmation counts up); returns the MAV_RESULT."""
        return self.command_ack(command, *params, resend_s=resend_s, retries=retries, reason=False).result

    def command_ack(
        self,
        command: int,
        *params: float,
        resend_s: float = 1.0,
        retries: int = 3,
        reason: bool = True,
        window_s: float = REASON_WINDOW_S,
    ) -> CommandAck:
        """COMMAND_LONG with retries (confirmation counts up); the vehicle's MAV_RESULT and, for anything
        but ACCEPTED (and ``reason``), the vehicle's reason (see :meth:`reason_after`)."""
        p = [*params, *([0.0] * (7 - len(params)))]
        ts, tc = self.target
        self.drop_stale(("COMMAND_ACK",))  # an ACK already waiting answers an earlier command, not this one
        t_sent = time.monotonic()
        for attempt in range(retries):
            self.send(mavlink.MAVLink_command_long_message(ts, tc, command, attempt, *p))
            deadline = time.monotonic() + resend_s
            while (left := deadline - time.monotonic()) > 0:
                m = self.recv(left)
                if (
                    m is not None
                    and m.get_type() == "COMMAND_ACK"
                    and m.command == command
                    and self._from_target(m)
                    and self._to_us(m)
                ):
                    result = int(m.result)
                    t_ack = time.monotonic()
                    why = ""
                    if reason and result != mavlink.MAV_RESULT_ACCEPTED:
                        why = self.reason_after(t_sent, t_ack, window_s)
                    texts = tuple(t.text for t in self.texts_since(t_sent))
                    return CommandAck(result, MAV_RESULT_NAMES.get(result, str(result)), why, texts)
        raise LinkError(f"no COMMAND_ACK for command {command} after {retries} tries{self.signing_note()}")

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
            if m is None or not self._from_target(m):
                continue
            kind = m.get_type()
            if kind == "HEARTBEAT" and m.type != mavlink.MAV_TYPE_GCS:
                last_hb = m
                if int(m.system_status) not in NOT_READY_STATES:
                    return True, m, ""
            elif kind == "SYS_STATUS":
                sys_reason = _sensor_problems(m)
        texts = self.texts_since(t0) or list(self.texts)
        return False, last_hb, sys_reason or (texts[-1].text if texts else "")

    def param_list(self, *, quiet_s: float = 1.0, timeout_s: float = 10.0) -> dict[str, float]:
        """All parameters (PARAM_REQUEST_LIST, then PARAM_REQUEST_READ for any missing index)."""
        ts, tc = self.target
        self.send(mavlink.MAVLink_param_request_list_message(ts, tc))
        values: dict[int, tuple[str, float]] = {}
        total: int | None = None
        t_end = time.monotonic() + timeout_s
        last_rx = time.monotonic()
        while time.monotonic() < t_end:
            m = self.recv(0.1)
            if m is not None and m.get_type() == "PARAM_VALUE" and self._from_target(m):
                total = m.param_count
                values[m.param_index] = (_pname(m.param_id), float(m.param_value))
                last_rx = time.monotonic()
                if len(values) >= total:
                    break
            elif time.monotonic() - last_rx > quiet_s:
                if total is None:
                    self.send(mavlink.MAVLink_param_request_list_message(ts, tc))
                else:
                    for i in range(total):
                        if i not in values:
                            self.send(mavlink.MAVLink_param_request_read_message(ts, tc, b"", i))
                last_rx = time.monotonic()
        if total is None or len(values) < total:
            raise LinkError("parameter list incomplete")
        return dict(values[i] for i in sorted(values))

    def param_get(self, name: str, *, resend_s: float = 0.5, retries: int = 5) -> float:
        """PARAM_REQUEST_READ by name. No answer (MAVLink's way of saying "unknown"): the list is asked for
        and :class:`UnknownParameter` raised if the name is not in it, else :class:`LinkError`."""
        ts, tc = self.target
        for _ in range(retries):
            self.send(mavlink.MAVLink_param_request_read_message(ts, tc, name.encode("ascii"), -1))
            deadline = time.monotonic() + resend_s
            while (left := deadline - time.monotonic()) > 0:
                m = self.recv(left)
                if m is not None and m.get_type() == "PARAM_VALUE" and _pname(m.param_id) == name:
                    return float(m.param_value)
        try:
            names = self.param_list(quiet_s=0.5, timeout_s=3.0)
        except LinkError:
            names = {}
        if names and name not in names:
            raise UnknownParameter(f"no such parameter {name} (the vehicle has {len(names)})")
        raise LinkError(f"no value for parameter {name}{self.signing_note()}")

    # ---- MAVLink FTP (read only) ------------------------------------------------------------------
    def _ftp(
        self,
        opcode: int,
        *,
        session: int = 0,
        offset: int = 0,
        size: int = 0,
        data: bytes = b"",
        on_other: Callable[[Msg], None] | None = None,
        resend_s: float = 0.5,
        retries: int = 6,
    ) -> ftp.Packet:
        """One FTP request, re-sent with the same sequence number until its reply (ACK or NAK) comes."""
        self._ftp_seq = (self._ftp_seq + 1) & 0xFFFF
        req = ftp.Packet(self._ftp_seq, session, opcode, size or len(data), 0, 0, offset, data)
        ts, tc = self.target
        msg = mavlink.MAVLink_file_transfer_protocol_message(0, ts, tc, req.encode())
        for _ in range(retries):
            self.send(msg)
            deadline = time.monotonic() + resend_s
            while (left := deadline - time.monotonic()) > 0:
                m = self.recv(left)
                if m is None:
                    continue
                if m.get_type() != "FILE_TRANSFER_PROTOCOL" or not (self._from_target(m) and self._to_us(m)):
                    if on_other is not None:
                        on_other(m)
                    continue
                reply = ftp.Packet.decode(m.payload)
                if reply.seq == (req.seq + 1) & 0xFFFF and reply.req_opcode == opcode:
                    return reply
        raise LinkError(f"no FTP answer from the vehicle after {retries} tries{self.signing_note()}")

    def read_file(
        self,
        path: str,
        on_other: Callable[[Msg], None] | None = None,
        *,
        progress: Callable[[int, int], None] | None = None,
    ) -> bytes:
        """A file of the vehicle over MAVLink FTP (OpenFileRO, ReadFile, TerminateSession). Raises
        :class:`LinkError` for a missing file ("no such file on the vehicle: PATH") or no answer. Messages
        that are not FTP replies go to ``on_other``; ``progress(done, size)`` after each chunk."""
        opened = self._ftp(ftp.OPEN_RO, data=path.encode(), on_other=on_other)
        if opened.opcode == ftp.NAK:
            code = opened.data[0] if opened.data else 0
            if code == ftp.FILE_NOT_FOUND:
                raise LinkError(f"no such file on the vehicle: {path}")
            raise LinkError(f"the vehicle cannot open {path} (FTP error {code})")
        if len(opened.data) < 4:
            raise LinkError(f"the vehicle's answer to opening {path} has no size")
        size = struct.unpack("<I", opened.data[:4])[0]
        out = bytearray()
        try:
            while len(out) < size:
                r = self._ftp(
                    ftp.READ, session=opened.session, offset=len(out), size=ftp.DATA_MAX, on_other=on_other
                )
                if r.opcode == ftp.NAK or not r.data:
                    break  # EOF (the file is shorter than it was at the open) or an error: what we have
                out += r.data
                if progress is not None:
                    progress(len(out), size)
        finally:
            try:  # the vehicle closes an idle session itself: a lost TERMINATE costs no download
                self._ftp(ftp.TERMINATE, session=opened.session, on_other=on_other, retries=2)
            except LinkError:
                pass
        if len(out) < size:
            raise LinkError(f"{path}: read {len(out)} of {size} bytes")
        return bytes(out)

    def file_crc32(self, path: str, on_other: Callable[[Msg], None] | None = None) -> int | None:
        """CalcFileCRC32 of a vehicle file over MAVLink FTP (zlib's CRC-32 of its bytes); None when the
        vehicle cannot compute one. Raises LinkError for a missing file or no answer."""
        r = self._ftp(ftp.CRC32, data=path.encode(), on_other=on_other)
        if r.opcode == ftp.NAK:
            code = r.data[0] if r.data else 0
            if code == ftp.FILE_NOT_FOUND:
                raise LinkError(f"no such file on the vehicle: {path}")
            return None
        return int(struct.unpack("<I", r.data[:4])[0]) if len(r.data) >= 4 else None

    def list_dir(
        self, path: str, on_other: Callable[[Msg], None] | None = None
    ) -> list[tuple[str, str, int]]:
        """(kind "F" / "D", name, size) of each entry of a vehicle directory over MAVLink FTP."""
        entries: list[tuple[str, str, int]] = []
        while True:
            r = self._ftp(ftp.LIST, offset=len(entries), data=path.encode(), on_other=on_other)
            if r.opcode == ftp.NAK:
                code = r.data[0] if r.data else 0
                if code == ftp.EOF:
                    return entries
                if code == ftp.FILE_NOT_FOUND:
                    raise LinkError(f"no such directory on the vehicle: {path}")
                raise LinkError(f"the vehicle cannot list {path} (FTP error {code})")
            got = [e for e in r.data.split(b"\0") if e]
            if not got:
                return entries
            for e in got:
                text = e.decode("utf-8", "replace")
                name, _, size = text[1:].partition("\t")
                entries.append((text[0], name, int(size) if size.isdigit() else 0))

    def param_set(
        self, name: str, value: float, *, resend_s: float = 0.5, retries: int = 5
    ) -> tuple[bool, float]:
        """PARAM_SET; returns (accepted, value now in force). A refused set is answered with the old value."""
        ts, tc = self.target
        want = struct.unpack("<f", struct.pack("<f", value))[0] if math.isfinite(value) else value
        t_sent = time.monotonic()
        unknown = f"unknown parameter {name}"
        for _ in range(retries):
            self.send(
                mavlink.MAVLink_param_set_message(
                    ts, tc, name.encode("ascii"), value, mavlink.MAV_PARAM_TYPE_REAL32
                )
            )
            deadline = time.monotonic() + resend_s
            while (left := deadline - time.monotonic()) > 0:
                m = self.recv(left)
                if m is not None and m.get_type() == "PARAM_VALUE" and _pname(m.param_id) == name:
                    got = float(m.param_value)
                    return got == want, got
                if any(t.text == unknown for t in self.texts_since(t_sent)):  # the vehicle's answer
                    raise UnknownParameter(f"no such parameter {name} (the vehicle says: {unknown})")
        raise LinkError(f"no answer to setting {name}{self.signing_note()}")


@dataclass
class SigningStats:
    """Packets a signing client dropped: unsigned, signed with another key (or forged), old timestamps."""

    unsigned_rejected: int = 0
    bad_signature: int = 0
    old_timestamp: int = 0

    @property
    def dropped(self) -> int:
        return self.unsigned_rejected + self.bad_signature + self.old_timestamp


def _text(raw: object) -> str:
    if isinstance(raw, bytes):
        raw = raw.decode("ascii", "replace")
    return str(raw).split("\x00", 1)[0]


def _pick(texts: Iterable[StatusText], t_s: float, *, warning_only: bool) -> StatusText | None:
    """The first text at or after ``t_s`` (of severity WARNING or worse if ``warning_only``)."""
    for t in texts:
        if t.t_s >= t_s and (not warning_only or t.severity <= mavlink.MAV_SEVERITY_WARNING):
            return t
    return None


def _sensor_problems(msg: Msg) -> str:
    """SYS_STATUS: the sensors present and enabled but not healthy, as one phrase ("" if none)."""
    bad = int(msg.onboard_control_sensors_present) & int(msg.onboard_control_sensors_enabled)
    bad &= ~int(msg.onboard_control_sensors_health)
    if not bad:
        return ""
    names = [
        entry.name.removeprefix("MAV_SYS_STATUS_SENSOR_").removeprefix("MAV_SYS_STATUS_")
        for bit, entry in mavlink.enums["MAV_SYS_STATUS_SENSOR"].items()
        if bit & bad and bit & (bit - 1) == 0
    ]
    return "not healthy: " + ", ".join(names) if names else f"sensor health 0x{bad:x}"


def _pname(raw: object) -> str:
    if isinstance(raw, bytes):
        raw = raw.decode("ascii", "replace")
    return str(raw).split("\x00", 1)[0]
