"""The vehicle's MAVLink 2 endpoint: sockets and protocol in its own thread, never in the control loop.

The loop talks to it only through :class:`VehicleLink`: ``publish(snapshot)`` each tick (stores a reference)
and ``take_events()`` each tick (swaps a list). Everything else happens in the endpoint's I/O thread on the
monotonic wall clock, in both time modes: receiving and decoding (each UDP datagram on its own, see
:mod:`onboard.adapters.mavlink.wire`), the mission service
(:mod:`onboard.adapters.mavlink.mission_protocol`), commands with
COMMAND_ACK, parameters, HEARTBEAT at 1 Hz, telemetry, GCS-heartbeat watch and persistence (before the ACK).

Commands are judged against the latest snapshot (plus the state the endpoint has just commanded and the
loop has not yet reported), acknowledged, and handed to the loop as events.

Heartbeat: MAV_TYPE_SUBMARINE, MAV_AUTOPILOT_GENERIC. ``custom_mode`` uses the PX4 layout that MAVSDK decodes
for a generic autopilot (main mode in byte 2, sub mode in byte 3: AUTO with READY / MISSION / LOITER / RTL),
and byte 0 carries our mission state index (0 IDLE, 1 ARMED, 2 RUNNING, 3 HOLD, 4 ABORT, 5 COMPLETE).
ACTUATOR_OUTPUT_STATUS carries [rudder_rad, stern_port_rad, stern_starboard_rad, propeller_rps].

MAVSDK / QGroundControl / MAVProxy interoperability: MAV_CMD_DO_SET_MODE with a PX4 custom mode (what
MAVSDK sends to a generic autopilot: param1 base mode with MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, param2 main
mode AUTO, param3 sub mode) starts (MISSION), holds (LOITER), aborts (RTL), or is a no-op (READY while
not running); MissionRaw.start_mission / pause_mission and Action.hold use it. GLOBAL_POSITION_INT is the
local position projected about the configured origin (alt = origin altitude - depth), at the position rate,
for MAVSDK's Telemetry.position and QGC's map. MAV_CMD_GET_HOME_POSITION (deprecated, still sent by
MAVProxy) is ACCEPTED and answered with HOME_POSITION. MAV_CMD_REQUEST_PROTOCOL_VERSION stays UNSUPPORTED
(PROTOCOL_VERSION is not in pymavlink's ``common`` dialect; QGC then goes by the frames it sees, which are
MAVLink 2). EXTENDED_SYS_STATE (landed state undefined) is off unless a ground station sets its
interval (MAVSDK does).

Mission seq vs goal index: the loop counts goals 0..n-1. When the stored mission starts with an
ArduPilot-style home item (seq 0, see :mod:`onboard.adapters.mavlink.mission_protocol`), MAVLink seq = goal
index + 1 everywhere (MISSION_CURRENT.seq, MISSION_ITEM_REACHED.seq, MISSION_SET_CURRENT,
MAV_CMD_DO_SET_MISSION_CURRENT and MAV_CMD_MISSION_START first_item); a seq naming the home item selects
goal 0; MISSION_CURRENT.total counts the goals only (the spec excludes home). A plan with no goals (count 0,
MISSION_CLEAR_ALL, or only a home item) is refused with MAV_MISSION_ERROR while RUNNING, because the mission
state machine cannot take a mission without goals while running (the vehicle would keep flying a plan the
ground station believes cleared); hold or abort first. A resume with no goals is denied.
"""

from __future__ import annotations

import collections
import logging
import math
import selectors
import socket
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from pymavlink.dialects.v20 import common as mavlink

from onboard.adapters.mavlink import api
from onboard.adapters.mavlink.api import MISSION_STATES, VehicleEvent, VehicleSnapshot
from onboard.adapters.mavlink.config import MavlinkConfig, load_signing_key, parse_endpoint
from onboard.adapters.mavlink.mission_protocol import (
    TYPE_FENCE,
    TYPE_MISSION,
    MissionItem,
    MissionLimits,
    MissionServer,
    PlanRefused,
    goal_items,
    goal_of_seq,
    items_from_mission,
    local_to_global,
    seq_of_goal,
)
from onboard.adapters.mavlink.params import DEFAULT_PARAMS, ParamSpec, ParamTable
from onboard.adapters.mavlink.persistence import StateStore
from onboard.adapters.mavlink.wire import RxStats, SigningVerifier, decode_datagram, signing_timestamp_now
from onboard.core.mission.model import Mission

log = logging.getLogger(__name__)

PX4_MAIN_AUTO = 4
PX4_SUB_READY, PX4_SUB_LOITER, PX4_SUB_MISSION, PX4_SUB_RTL = 1, 3, 4, 5
FORCE_DISARM_MAGIC = 21196
VERSION = (0, 1, 0)
CAPABILITIES = (
    mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_FLOAT
    | mavlink.MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT
    | mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_INT
    | mavlink.MAV_PROTOCOL_CAPABILITY_COMMAND_INT
    | mavlink.MAV_PROTOCOL_CAPABILITY_MAVLINK2
    | mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_FENCE
)
PEER_EXPIRY_S = 30.0
MAX_PEERS = 16
ARMED_STATES = ("ARMED", "RUNNING", "HOLD")
_SUB_MODE = {"IDLE": 1, "ARMED": 1, "RUNNING": 4, "HOLD": 3, "ABORT": 5, "COMPLETE": 1}
_MISSION_STATE = {
    "IDLE": mavlink.MISSION_STATE_NOT_STARTED,
    "ARMED": mavlink.MISSION_STATE_NOT_STARTED,
    "RUNNING": mavlink.MISSION_STATE_ACTIVE,
    "HOLD": mavlink.MISSION_STATE_PAUSED,
    "ABORT": mavlink.MISSION_STATE_PAUSED,
    "COMPLETE": mavlink.MISSION_STATE_COMPLETE,
}
Addr = tuple[str, int]


def _f(v: float) -> float:
    """NaN-safe float for MAVLink float fields (NaN stays NaN, which MAVLink uses for unknown)."""
    return float(v)


def _i(v: float, lo: int, hi: int) -> int:
    """Clamp a float to an integer field (NaN -> 0)."""
    if not math.isfinite(v):
        return 0
    return max(lo, min(hi, round(v)))


def _body_to_ned(s: VehicleSnapshot) -> tuple[float, float, float]:
    """NED velocity (m/s) from body velocities u, v, w and the Euler angles (ZYX)."""
    cr, sr = math.cos(s.roll_rad), math.sin(s.roll_rad)
    cp, sp = math.cos(s.pitch_rad), math.sin(s.pitch_rad)
    cy, sy = math.cos(s.yaw_rad), math.sin(s.yaw_rad)
    u, v, w = s.u_mps, s.v_mps, s.w_mps
    vn = cy * cp * u + (cy * sp * sr - sy * cr) * v + (cy * sp * cr + sy * sr) * w
    ve = sy * cp * u + (sy * sp * sr + cy * cr) * v + (sy * sp * cr - cy * sr) * w
    vd = -sp * u + cp * sr * v + cp * cr * w
    return vn, ve, vd


@dataclass
class _Socket:
    kind: str
    sock: socket.socket
    fixed: Addr | None = None
    peers: dict[Addr, float] = field(default_factory=dict)  # learned address -> last rx (monotonic)
    stream_parser: Any = None  # for TCP connections
    server: bool = False


@dataclass
class _Stream:
    period_s: float
    default_s: float
    next_s: float = 0.0


class _Fanout:
    """File-like sink for pymavlink's ``MAVLink.send``: one packet to every peer of every socket."""

    def __init__(self, link: VehicleLink) -> None:
        self.link = link

    def write(self, buf: bytes) -> None:
        self.link._send_raw(bytes(buf))


class VehicleLink:
    """The MAVLink endpoint of the vehicle. Thread-safe API for the loop: publish() and take_events().

    Args:
        config: the ``[mavlink]`` configuration.
        params: the parameter table (default :data:`onboard.adapters.mavlink.params.DEFAULT_PARAMS`).
        initial_mission: a mission given at start (``--mission``); it wins over the persisted one and is
            persisted.
        clock: monotonic wall clock (s); tests may inject one.
    """

    def __init__(
        self,
        config: MavlinkConfig,
        *,
        params: tuple[ParamSpec, ...] = DEFAULT_PARAMS,
        initial_mission: Mission | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.config = config
        self._clock = clock
        self._store = StateStore(config.resolved_state_dir())
        self._lock = threading.Lock()
        self._events: list[VehicleEvent] = []
        self._snapshot = VehicleSnapshot()
        self._pending_state: str | None = None
        self._events_taken = False
        self._notes: collections.deque[tuple[int, str]] = collections.deque(maxlen=64)
        self._reached: collections.deque[int] = collections.deque(maxlen=256)
        self.rx = RxStats()
        self.tx_packets = 0
        self.tx_errors = 0
        self.limits = MissionLimits(
            area_half_m=config.area_half_m,
            max_depth_m=config.max_depth_m,
            max_goals=config.max_goals,
            max_fence_items=config.max_fence_items,
            origin_lat_deg=config.origin_lat_deg,
            origin_lon_deg=config.origin_lon_deg,
            origin_alt_m=config.origin_alt_m,
            item_timeout_s=config.item_timeout_s,
            upload_timeout_s=config.upload_timeout_s,
        )
        stored: dict[int, tuple[MissionItem, ...]] = {}
        for mt in (TYPE_MISSION, TYPE_FENCE):
            items = self._store.load_plan(mt)
            if items is not None:
                stored[mt] = items
        self.missions = MissionServer(
            self.limits, (config.system_id, config.component_id), stored, commit=self._commit_plan
        )
        if initial_mission is not None:
            goals, fences = items_from_mission(initial_mission)
            for mt, items in ((TYPE_MISSION, goals), (TYPE_FENCE, fences)):
                self._store.save_plan(mt, items)
                self.missions.replace(mt, items)
        self.missions.take_changed()
        self.params = ParamTable(params, self._store.load_params())
        self._mav = mavlink.MAVLink(_Fanout(self), config.system_id, config.component_id)
        self._verifier: SigningVerifier | None = None
        if config.signing_key_file:
            key = load_signing_key(config.signing_key_file)
            self._verifier = SigningVerifier(key)
            self._mav.signing.secret_key = key
            self._mav.signing.link_id = config.signing_link_id
            self._mav.signing.sign_outgoing = True
            self._mav.signing.timestamp = signing_timestamp_now()
        self._sockets: list[_Socket] = []
        self._selector: selectors.BaseSelector | None = None
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._boot_s = clock()
        self._streams: dict[int, _Stream] = {}
        for msg_id, rate in (
            (mavlink.MAVLINK_MSG_ID_HEARTBEAT, config.heartbeat_rate_hz),
            (mavlink.MAVLINK_MSG_ID_LOCAL_POSITION_NED, config.position_rate_hz),
            (mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, config.position_rate_hz),
            (mavlink.MAVLINK_MSG_ID_ATTITUDE, config.attitude_rate_hz),
            (mavlink.MAVLINK_MSG_ID_NAV_CONTROLLER_OUTPUT, config.nav_rate_hz),
            (mavlink.MAVLINK_MSG_ID_ACTUATOR_OUTPUT_STATUS, config.actuator_rate_hz),
            (mavlink.MAVLINK_MSG_ID_SYS_STATUS, config.sys_status_rate_hz),
            (mavlink.MAVLINK_MSG_ID_MISSION_CURRENT, config.mission_current_rate_hz),
            (mavlink.MAVLINK_MSG_ID_HOME_POSITION, config.home_rate_hz),
            (mavlink.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN, config.home_rate_hz),
            (mavlink.MAVLINK_MSG_ID_EXTENDED_SYS_STATE, 0.0),  # off unless asked for (MAVSDK asks)
        ):
            period = 1.0 / rate if rate > 0 else math.inf
            self._streams[msg_id] = _Stream(period, period)
        self._gcs_last_s: float | None = None
        self._gcs_lost = False
        self._budget = float(config.rx_budget_per_s)
        self._budget_t = clock()
        self._last_state: str | None = None
        # first events for the loop: the stored mission and the persisted parameter values
        mission = self.missions.mission()
        if mission.goals or mission.obstacles:
            self._events.append(api.MissionReplaced(mission))
        self._events.extend(api.ParamChanged(n, v) for n, v in self.params.changed().items())

    # ---- the loop's API (thread-safe, cheap) ----------------------------------------------------
    def publish(self, snapshot: VehicleSnapshot) -> None:
        """Store the loop's latest state (call once per tick; O(1), never blocks on I/O)."""
        with self._lock:
            prev = self._snapshot
            self._snapshot = snapshot
            if self._events_taken:
                self._pending_state = None
                self._events_taken = False
            if snapshot.state != prev.state:
                self._notes.append((mavlink.MAV_SEVERITY_INFO, f"state {prev.state} -> {snapshot.state}"))
            if snapshot.failsafe != prev.failsafe:
                if snapshot.failsafe:
                    self._notes.append((mavlink.MAV_SEVERITY_CRITICAL, f"failsafe: {snapshot.failsafe}"))
                else:
                    self._notes.append((mavlink.MAV_SEVERITY_NOTICE, "failsafe cleared"))
            offset = self.missions.home_offset()
            for k in range(max(0, snapshot.goals_reached - prev.goals_reached)):
                self._reached.append(seq_of_goal(prev.current_goal + k, offset))

    def take_events(self) -> list[VehicleEvent]:
        """All events since the last call, oldest first (call once per tick)."""
        with self._lock:
            events, self._events = self._events, []
            if events:
                self._events_taken = True
            return events

    def mission(self) -> Mission:
        """The accepted mission (goals and fence obstacles)."""
        with self._lock:
            return self.missions.mission()

    @property
    def ports(self) -> list[int]:
        """Local ports of the endpoint's sockets (after :meth:`start`), in config order."""
        return [s.sock.getsockname()[1] for s in self._sockets if s.kind != "tcpconn"]

    def stats(self) -> dict[str, int]:
        """Receive/transmit/mission counters."""
        d = dict(self.rx.__dict__)
        d.update({f"mission_{k}": v for k, v in self.missions.stats.__dict__.items()})
        d["tx_packets"] = self.tx_packets
        d["tx_errors"] = self.tx_errors
        return d

    # ---- lifecycle -----------------------------------------------------------------------------
    def start(self) -> None:
        """Open the sockets and start the I/O thread."""
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
                    s = _Socket(kind, sock, fixed=(host, port))
                sock.setblocking(False)
            self._sockets.append(s)
            sel.register(s.sock, selectors.EVENT_READ, s)
        self._selector = sel
        self._thread = threading.Thread(target=self._run, name="mavlink-endpoint", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        """Stop the I/O thread and close the sockets."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
        for s in self._sockets:
            s.sock.close()
        self._sockets.clear()
        if self._selector is not None:
            self._selector.close()

    def __enter__(self) -> VehicleLink:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    # ---- I/O thread ----------------------------------------------------------------------------
    def _run(self) -> None:
        assert self._selector is not None
        while not self._stop.is_set():
            now = self._clock()
            timeout = max(0.0, min(self._next_deadline(now) - now, 0.05))
            try:
                ready = self._selector.select(timeout)
            except OSError:
                break
            for key, _ in ready:
                self._read(key.data)
            try:
                self._timers(self._clock())
            except Exception:  # never let a bug kill the link silently
                log.exception("MAVLink timer failed")

    def _next_deadline(self, now: float) -> float:
        t = min(s.next_s for s in self._streams.values())
        d = self.missions.next_deadline()
        if d is not None:
            t = min(t, d)
        if self._notes or self._reached:
            t = now
        return t

    def _take_budget(self, now: float) -> bool:
        rate = float(self.config.rx_budget_per_s)
        self._budget = min(rate * 0.2, self._budget + (now - self._budget_t) * rate)
        self._budget_t = now
        if self._budget < 1.0:
            return False
        self._budget -= 1.0
        return True

    def _read(self, s: _Socket) -> None:
        if s.server:
            try:
                conn, _addr = s.sock.accept()
            except OSError:
                return
            conn.setblocking(False)
            parser = mavlink.MAVLink(None)
            parser.robust_parsing = True
            c = _Socket("tcpconn", conn, stream_parser=parser)
            self._sockets.append(c)
            assert self._selector is not None
            self._selector.register(conn, selectors.EVENT_READ, c)
            return
        if s.kind == "tcpconn":
            self._read_tcp(s)
            return
        for _ in range(256):  # bounded per wake-up so timers keep running under a flood
            try:
                data, addr = s.sock.recvfrom(65535)
            except (BlockingIOError, InterruptedError):
                return
            except OSError:
                return
            now = self._clock()
            if not self._take_budget(now):
                self.rx.shed += 1
                continue
            for msg, _frame in decode_datagram(data, self.rx, self._verifier):
                self._learn(s, addr, now)
                try:
                    self._dispatch(msg, now)
                except Exception:
                    log.exception("MAVLink message %s failed", msg.get_type())

    def _read_tcp(self, s: _Socket) -> None:
        try:
            data = s.sock.recv(65536)
        except (BlockingIOError, InterruptedError):
            return
        except OSError:
            data = b""
        if not data:
            assert self._selector is not None
            self._selector.unregister(s.sock)
            s.sock.close()
            self._sockets.remove(s)
            return
        now = self._clock()
        msgs = s.stream_parser.parse_buffer(data) or []
        for msg in msgs:
            if msg.get_type() == "BAD_DATA":
                self.rx.malformed += 1
                continue
            frame = bytes(msg.get_msgbuf())
            if self._verifier is not None and not self._verifier.verify(frame, self.rx):
                continue
            self.rx.packets += 1
            self._dispatch(msg, now)

    def _learn(self, s: _Socket, addr: Addr, now: float) -> None:
        if addr == s.fixed:
            return
        if addr not in s.peers and len(s.peers) >= MAX_PEERS:
            oldest = min(s.peers, key=lambda a: s.peers[a])
            del s.peers[oldest]
        s.peers[addr] = now

    def _send_raw(self, buf: bytes) -> None:
        now = self._clock()
        for s in list(self._sockets):
            if s.server:
                continue
            try:
                if s.kind == "tcpconn":
                    s.sock.send(buf)
                    continue
                for addr, last in list(s.peers.items()):
                    if now - last > PEER_EXPIRY_S:
                        del s.peers[addr]
                        continue
                    s.sock.sendto(buf, addr)
                if s.fixed is not None:
                    s.sock.sendto(buf, s.fixed)
            except OSError:
                self.tx_errors += 1
        self.tx_packets += 1

    def send(self, msg: mavlink.MAVLink_message) -> None:
        """Send one message to every peer (I/O thread only)."""
        self._mav.send(msg)

    def _statustext(self, severity: int, text: str) -> None:
        self.send(mavlink.MAVLink_statustext_message(severity, text.encode("ascii", "replace")[:50]))

    # ---- state ---------------------------------------------------------------------------------
    def _state(self) -> tuple[str, VehicleSnapshot]:
        with self._lock:
            snap = self._snapshot
            return (self._pending_state or snap.state), snap

    def _emit(self, event: VehicleEvent, pending: str | None = None) -> None:
        with self._lock:
            self._events.append(event)
            if pending is not None:
                self._pending_state = pending
                self._events_taken = False

    # ---- dispatch ------------------------------------------------------------------------------
    def _dispatch(self, msg: mavlink.MAVLink_message, now: float) -> None:
        kind = msg.get_type()
        sender = (msg.get_srcSystem(), msg.get_srcComponent())
        if kind == "HEARTBEAT":
            if msg.type == mavlink.MAV_TYPE_GCS:
                self._gcs_last_s = now
                if self._gcs_lost:
                    self._gcs_lost = False
                    self._emit(api.GcsLinkRegained())
                    self._statustext(mavlink.MAV_SEVERITY_NOTICE, "GCS link regained")
            return
        if kind.startswith("MISSION_") and kind != "MISSION_SET_CURRENT":
            with self._lock:  # mission() may be read from the loop thread
                out = self.missions.handle(msg, sender, now)
                changed = self.missions.take_changed()
                mission = self.missions.mission() if changed else None
            for m in out:
                self.send(m)
            if mission is not None:
                self._emit(api.MissionReplaced(mission))
            return
        if kind == "MISSION_SET_CURRENT":
            if self._for_us(msg):
                self._set_current(int(msg.seq))
            return
        if kind in ("COMMAND_LONG", "COMMAND_INT"):
            if not self._for_us(msg):
                return
            if kind == "COMMAND_LONG":
                p = [msg.param1, msg.param2, msg.param3, msg.param4, msg.param5, msg.param6, msg.param7]
            else:
                p = [msg.param1, msg.param2, msg.param3, msg.param4, float(msg.x), float(msg.y), msg.z]
            result = self._command(int(msg.command), [float(v) for v in p])
            self.send(
                mavlink.MAVLink_command_ack_message(int(msg.command), result, 0, 0, sender[0], sender[1])
            )
            self._after_command(int(msg.command), result, p)
            return
        if kind.startswith("PARAM_"):
            if self._for_us(msg):
                self._param(msg)

    def _for_us(self, msg: mavlink.MAVLink_message) -> bool:
        ts = int(getattr(msg, "target_system", 0))
        tc = int(getattr(msg, "target_component", 0))
        return ts in (0, self.config.system_id) and tc in (0, self.config.component_id)

    def _n_goals(self) -> int:
        with self._lock:
            return self.missions.goal_count()

    def _goal_shape(self) -> tuple[int, int]:
        """(home offset, number of goals) of the stored mission: MAVLink seq = goal index + offset."""
        with self._lock:
            return self.missions.home_offset(), self.missions.goal_count()

    def _commit_plan(self, mission_type: int, items: tuple[MissionItem, ...]) -> None:
        """MissionServer's commit callback (called with ``self._lock`` held): refuse, or persist."""
        if mission_type == TYPE_MISSION and not goal_items(items):
            state = self._pending_state or self._snapshot.state
            if state == "RUNNING":
                self._notes.append((mavlink.MAV_SEVERITY_WARNING, "mission without goals refused: RUNNING"))
                raise PlanRefused("a mission without goals cannot replace a running one")
        self._store.save_plan(mission_type, items)

    def _set_current(self, seq: int) -> bool:
        offset, n = self._goal_shape()
        index = goal_of_seq(seq, offset, n)
        if index is not None:
            self._emit(api.SetCurrent(index))
            state, _ = self._state()
            current = seq_of_goal(index, offset)
            self.send(mavlink.MAVLink_mission_current_message(current, n, _MISSION_STATE[state], 1))
            return True
        self._statustext(mavlink.MAV_SEVERITY_ERROR, f"set current: no item {seq} (have {n + offset})")
        return False

    def _start(self, state: str, first: float) -> int:
        if state == "RUNNING":
            return mavlink.MAV_RESULT_ACCEPTED
        offset, n = self._goal_shape()
        if state not in ("ARMED", "HOLD", "COMPLETE") or n < 1:
            return mavlink.MAV_RESULT_DENIED
        first_index: int | None = None
        if state != "HOLD":  # first_item is a MAVLink seq; out of range (or the home seq) -> goal 0
            index = goal_of_seq(int(first), offset, n) if math.isfinite(first) else None
            first_index = 0 if index is None else index
        self._emit(api.StartMission(first_index), pending="RUNNING")
        return mavlink.MAV_RESULT_ACCEPTED

    def _hold(self, state: str) -> int:
        if state == "HOLD":
            return mavlink.MAV_RESULT_ACCEPTED
        if state != "RUNNING":
            return mavlink.MAV_RESULT_DENIED
        self._emit(api.Hold(), pending="HOLD")
        return mavlink.MAV_RESULT_ACCEPTED

    def _abort(self, state: str, reason: str) -> int:
        if state != "ABORT":
            self._emit(api.Abort(reason), pending="ABORT")
        return mavlink.MAV_RESULT_ACCEPTED

    def _command(self, cmd: int, p: list[float]) -> int:
        """Judge one command against the current state; emit its event; return the MAV_RESULT."""
        state, _snap = self._state()
        if cmd == mavlink.MAV_CMD_COMPONENT_ARM_DISARM:
            if p[0] == 1.0:
                if state in ARMED_STATES:
                    return mavlink.MAV_RESULT_ACCEPTED
                if state in ("IDLE", "COMPLETE"):
                    self._emit(api.Arm(), pending="ARMED")
                    return mavlink.MAV_RESULT_ACCEPTED
                return mavlink.MAV_RESULT_DENIED
            if p[0] == 0.0:
                if state == "IDLE":
                    return mavlink.MAV_RESULT_ACCEPTED
                forced = p[1] == FORCE_DISARM_MAGIC
                if state in ("RUNNING", "HOLD") and not forced:
                    return mavlink.MAV_RESULT_DENIED
                self._emit(api.Disarm(forced), pending="IDLE")
                return mavlink.MAV_RESULT_ACCEPTED
            return mavlink.MAV_RESULT_DENIED
        if cmd == mavlink.MAV_CMD_MISSION_START:
            return self._start(state, p[0])
        if cmd == mavlink.MAV_CMD_DO_SET_MODE:
            if not (int(p[0]) & mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED) or int(p[1]) != PX4_MAIN_AUTO:
                return mavlink.MAV_RESULT_DENIED
            sub = int(p[2])
            if sub == PX4_SUB_MISSION:
                return self._start(state, 0.0) if state != "HOLD" else self._resume(state)
            if sub == PX4_SUB_LOITER:
                return self._hold(state)
            if sub == PX4_SUB_RTL:
                return self._abort(state, "mode RTL")
            if sub == PX4_SUB_READY and _SUB_MODE[state] == PX4_SUB_READY:
                return mavlink.MAV_RESULT_ACCEPTED  # already in AUTO / READY: nothing to change
            return mavlink.MAV_RESULT_DENIED
        if cmd == mavlink.MAV_CMD_DO_PAUSE_CONTINUE:
            if p[0] == 0.0:
                return self._hold(state)
            if p[0] == 1.0:
                return self._resume(state)
            return mavlink.MAV_RESULT_DENIED
        if cmd == mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH:
            return self._abort(state, "return to surface")
        if cmd == mavlink.MAV_CMD_DO_FLIGHTTERMINATION:
            if p[0] > 0.5:
                return self._abort(state, "termination")
            return mavlink.MAV_RESULT_DENIED
        if cmd == mavlink.MAV_CMD_DO_SET_MISSION_CURRENT:
            seq = int(p[0]) if math.isfinite(p[0]) else -1
            if seq == -1:
                return mavlink.MAV_RESULT_ACCEPTED  # -1: no change (spec)
            return mavlink.MAV_RESULT_ACCEPTED if self._set_current(seq) else mavlink.MAV_RESULT_DENIED
        if cmd == mavlink.MAV_CMD_REQUEST_MESSAGE:
            msg_id = int(p[0]) if math.isfinite(p[0]) else -1
            return mavlink.MAV_RESULT_ACCEPTED if msg_id in self._requestable() else mavlink.MAV_RESULT_DENIED
        if cmd in (
            mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES,
            mavlink.MAV_CMD_GET_HOME_POSITION,
        ):
            return mavlink.MAV_RESULT_ACCEPTED
        if cmd == mavlink.MAV_CMD_SET_MESSAGE_INTERVAL:
            msg_id = int(p[0]) if math.isfinite(p[0]) else -1
            stream = self._streams.get(msg_id)
            if stream is None or msg_id == mavlink.MAVLINK_MSG_ID_HEARTBEAT or not math.isfinite(p[1]):
                return mavlink.MAV_RESULT_DENIED
            if p[1] < 0:
                stream.period_s = math.inf
            elif p[1] == 0:
                stream.period_s = stream.default_s
            else:
                stream.period_s = max(p[1] * 1e-6, 0.01)
            stream.next_s = self._clock()
            return mavlink.MAV_RESULT_ACCEPTED
        return mavlink.MAV_RESULT_UNSUPPORTED

    def _resume(self, state: str) -> int:
        if state == "RUNNING":
            return mavlink.MAV_RESULT_ACCEPTED
        if state != "HOLD" or self._n_goals() < 1:  # the mission was cleared while holding
            return mavlink.MAV_RESULT_DENIED
        self._emit(api.Resume(), pending="RUNNING")
        return mavlink.MAV_RESULT_ACCEPTED

    def _after_command(self, cmd: int, result: int, p: list[float]) -> None:
        if result != mavlink.MAV_RESULT_ACCEPTED:
            return
        if cmd == mavlink.MAV_CMD_REQUEST_MESSAGE:
            self._send_message(int(p[0]))
        elif cmd == mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES:
            self._send_message(mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION)
        elif cmd == mavlink.MAV_CMD_GET_HOME_POSITION:  # deprecated, still sent by MAVProxy
            self._send_message(mavlink.MAVLINK_MSG_ID_HOME_POSITION)

    # ---- parameters ----------------------------------------------------------------------------
    def _param_value(self, name: str) -> mavlink.MAVLink_message:
        return mavlink.MAVLink_param_value_message(
            name.encode("ascii"),
            self.params.get(name),
            mavlink.MAV_PARAM_TYPE_REAL32,
            len(self.params.specs),
            self.params.index(name),
        )

    def _param(self, msg: mavlink.MAVLink_message) -> None:
        kind = msg.get_type()
        if kind == "PARAM_REQUEST_LIST":
            for spec in self.params.specs:
                self.send(self._param_value(spec.name))
        elif kind == "PARAM_REQUEST_READ":
            if msg.param_index >= 0:
                if msg.param_index < len(self.params.specs):
                    self.send(self._param_value(self.params.specs[msg.param_index].name))
                return
            name = _param_name(msg.param_id)
            if self.params.spec(name) is not None:
                self.send(self._param_value(name))
        elif kind == "PARAM_SET":
            name = _param_name(msg.param_id)
            if self.params.spec(name) is None:
                return  # unknown parameter: no answer (the GCS times out)
            value = float(msg.param_value)
            if not self.params.check(name, value):
                ps = self.params.spec(name)
                assert ps is not None
                self._statustext(
                    mavlink.MAV_SEVERITY_WARNING, f"{name}={value:g} refused ({ps.min:g}..{ps.max:g})"
                )
                self.send(self._param_value(name))  # the old value: the set was refused
                return
            old = self.params.get(name)
            self.params.set(name, value)
            try:
                # Only what differs from the defaults: the defaults are the configuration the vehicle
                # starts with, so a later edit of onboard.toml is not overridden by stale copies.
                self._store.save_params(self.params.changed())
            except OSError as exc:
                self.params.set(name, old)
                log.error("cannot persist parameters: %s", exc)
                self.send(self._param_value(name))
                return
            self._emit(api.ParamChanged(name, value))
            self.send(self._param_value(name))

    # ---- timers and telemetry ------------------------------------------------------------------
    def _timers(self, now: float) -> None:
        with self._lock:
            out = self.missions.poll(now)
        for m in out:
            self.send(m)
        while self._notes:
            severity, text = self._notes.popleft()
            self._statustext(severity, text)
        while self._reached:
            self.send(mavlink.MAVLink_mission_item_reached_message(self._reached.popleft()))
        if (
            self._gcs_last_s is not None
            and not self._gcs_lost
            and now - self._gcs_last_s > self.config.gcs_timeout_s
        ):
            self._gcs_lost = True
            action = self.config.gcs_loss_action
            self._emit(api.GcsLinkLost(action))
            self._statustext(mavlink.MAV_SEVERITY_WARNING, f"GCS heartbeat lost: action {action}")
        for msg_id, stream in self._streams.items():
            if now >= stream.next_s:
                stream.next_s = max(stream.next_s + stream.period_s, now) if stream.next_s else now
                if stream.period_s < math.inf:
                    self._send_message(msg_id)

    def _requestable(self) -> set[int]:
        return set(self._streams) | {mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION}

    def _send_message(self, msg_id: int) -> None:
        state, s = self._state()
        boot_ms = _i(s.t_s * 1000.0, 0, 2**32 - 1)
        usec = _i(s.t_s * 1e6, 0, 2**63 - 1)
        m: mavlink.MAVLink_message
        if msg_id == mavlink.MAVLINK_MSG_ID_HEARTBEAT:
            base = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | mavlink.MAV_MODE_FLAG_AUTO_ENABLED
            if state in ARMED_STATES:
                base |= mavlink.MAV_MODE_FLAG_SAFETY_ARMED
            custom = (PX4_MAIN_AUTO << 16) | (_SUB_MODE[state] << 24) | MISSION_STATES.index(state)
            if s.failsafe or state == "ABORT":
                status = mavlink.MAV_STATE_CRITICAL
            elif state in ARMED_STATES:
                status = mavlink.MAV_STATE_ACTIVE
            else:
                status = mavlink.MAV_STATE_STANDBY
            m = mavlink.MAVLink_heartbeat_message(
                mavlink.MAV_TYPE_SUBMARINE, mavlink.MAV_AUTOPILOT_GENERIC, base, custom, status, 3
            )
        elif msg_id == mavlink.MAVLINK_MSG_ID_LOCAL_POSITION_NED:
            vn, ve, vd = _body_to_ned(s)
            m = mavlink.MAVLink_local_position_ned_message(boot_ms, s.x_m, s.y_m, s.depth_m, vn, ve, vd)
        elif msg_id == mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT:
            c = self.config
            vn, ve, vd = _body_to_ned(s)
            lat, lon = local_to_global(s.x_m, s.y_m, self.limits)
            hdg = math.degrees(s.yaw_rad) % 360.0 if math.isfinite(s.yaw_rad) else math.nan
            m = mavlink.MAVLink_global_position_int_message(
                boot_ms,
                _i(lat * 1e7, -900_000_000, 900_000_000),
                _i(lon * 1e7, -1_800_000_000, 1_800_000_000),
                _i((c.origin_alt_m - s.depth_m) * 1000.0, -(2**31), 2**31 - 1),
                _i(-s.depth_m * 1000.0, -(2**31), 2**31 - 1),
                _i(vn * 100.0, -32768, 32767),
                _i(ve * 100.0, -32768, 32767),
                _i(vd * 100.0, -32768, 32767),
                _i(hdg * 100.0, 0, 35999) if math.isfinite(hdg) else 65535,
            )
        elif msg_id == mavlink.MAVLINK_MSG_ID_EXTENDED_SYS_STATE:
            m = mavlink.MAVLink_extended_sys_state_message(
                mavlink.MAV_VTOL_STATE_UNDEFINED, mavlink.MAV_LANDED_STATE_UNDEFINED
            )
        elif msg_id == mavlink.MAVLINK_MSG_ID_ATTITUDE:
            m = mavlink.MAVLink_attitude_message(
                boot_ms, s.roll_rad, s.pitch_rad, s.yaw_rad, s.p_radps, s.q_radps, s.r_radps
            )
        elif msg_id == mavlink.MAVLINK_MSG_ID_NAV_CONTROLLER_OUTPUT:
            bearing = math.degrees(s.yaw_rad)
            target = math.degrees(s.yaw_rad + s.yaw_error_rad)
            m = mavlink.MAVLink_nav_controller_output_message(
                0.0,
                0.0,
                _i(bearing, -32768, 32767),
                _i(target, -32768, 32767),
                _i(s.goal_distance_m, 0, 65535),
                _f(s.depth_error_m),
                0.0,
                _f(s.cross_track_m),
            )
        elif msg_id == mavlink.MAVLINK_MSG_ID_ACTUATOR_OUTPUT_STATUS:
            acts = [s.rudder_rad, s.stern_port_rad, s.stern_starboard_rad, s.propeller_rps]
            m = mavlink.MAVLink_actuator_output_status_message(usec, 4, [*acts, *([0.0] * 28)])
        elif msg_id == mavlink.MAVLINK_MSG_ID_SYS_STATUS:
            load = _i(s.loop_load * 1000.0, 0, 65535)
            errors = self.rx.malformed + self.rx.bad_signature + self.rx.unsigned_rejected
            m = mavlink.MAVLink_sys_status_message(
                0, 0, 0, load, 0xFFFF, -1, -1, 0, _i(errors, 0, 65535), _i(s.overruns, 0, 65535), 0, 0, 0
            )
        elif msg_id == mavlink.MAVLINK_MSG_ID_MISSION_CURRENT:
            offset, n = self._goal_shape()  # total excludes a home item (spec)
            mstate = _MISSION_STATE[state] if n else mavlink.MISSION_STATE_NO_MISSION
            m = mavlink.MAVLink_mission_current_message(
                _i(seq_of_goal(s.current_goal, offset), 0, 65535),
                n,
                mstate,
                1 if state in ("RUNNING", "HOLD") else 0,
            )
        elif msg_id == mavlink.MAVLINK_MSG_ID_HOME_POSITION:
            c = self.config
            m = mavlink.MAVLink_home_position_message(
                round(c.origin_lat_deg * 1e7),
                round(c.origin_lon_deg * 1e7),
                round(c.origin_alt_m * 1000),
                0.0,
                0.0,
                0.0,
                [1.0, 0.0, 0.0, 0.0],
                0.0,
                0.0,
                0.0,
                usec,
            )
        elif msg_id == mavlink.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN:
            c = self.config
            m = mavlink.MAVLink_gps_global_origin_message(
                round(c.origin_lat_deg * 1e7),
                round(c.origin_lon_deg * 1e7),
                round(c.origin_alt_m * 1000),
                usec,
            )
        elif msg_id == mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION:
            sw = (
                (VERSION[0] << 24)
                | (VERSION[1] << 16)
                | (VERSION[2] << 8)
                | mavlink.FIRMWARE_VERSION_TYPE_DEV
            )
            m = mavlink.MAVLink_autopilot_version_message(
                CAPABILITIES, sw, 0, 0, 0, [0] * 8, [0] * 8, [0] * 8, 0, 0, 0, [0] * 18
            )
        else:
            return
        self.send(m)


def _param_name(raw: object) -> str:
    if isinstance(raw, bytes):
        raw = raw.decode("ascii", "replace")
    return str(raw).split("\x00", 1)[0]
