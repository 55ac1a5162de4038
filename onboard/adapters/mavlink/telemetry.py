"""HEARTBEAT, the telemetry streams, message intervals and the one table of mission states on MAVLink.

Heartbeat: MAV_TYPE_SUBMARINE, MAV_AUTOPILOT_GENERIC. ``custom_mode`` is ArduSub's mode number of the state
(:mod:`~onboard.adapters.mavlink.modes`, the one table: MANUAL, AUTO, POSHOLD, CIRCLE, SURFACE), which
MAVProxy shows by name. ``base_mode`` MAV_MODE_FLAG_SAFETY_ARMED is
``snapshot.armed`` and nothing else. ``system_status``: CRITICAL in ABORT or with a failsafe, ACTIVE when
armed, STANDBY when ready and disarmed, BOOT while not ready (before the first valid navigation).

MISSION_CURRENT carries ``snapshot.current_goal`` as a seq (home offset), ``total`` = the goals (the spec
excludes home), ``mission_state`` from :data:`STATE_TABLE`. MISSION_ITEM_REACHED is sent whenever
``goals_reached`` increases. ACTUATOR_OUTPUT_STATUS carries [rudder_rad, stern_port_rad,
stern_starboard_rad, propeller_rps]. GLOBAL_POSITION_INT is the local position projected about the
configured origin (alt = origin altitude - depth). EXTENDED_SYS_STATE (landed state undefined) is off unless
a ground station sets its interval (MAVSDK does). NAMED_VALUE_INT ``FIX_REJ`` (at SYS_STATUS's rate) counts
the position fixes the navigation's innovation gate refused since boot.

Stream rates are per link, as in ArduPilot: every stream starts at its configured rate on every link, and a
SET_MESSAGE_INTERVAL changes it for the link it came over only (another station, with the same ids or not,
keeps its rates), at most ``[mavlink] max_stream_rate_hz`` (a faster request is clamped; interval 0: back to
the configured rate, -1: off for that link). A link's own rates are forgotten when it goes (a UDP peer
silent for 30 s, a closed TCP connection). REQUEST_MESSAGE is answered to the asker's link. What changes for
everyone (a state or armed change's HEARTBEAT and MISSION_CURRENT, MISSION_ITEM_REACHED) goes to every link.
"""

from __future__ import annotations

import collections
import math
import threading
from collections.abc import Callable, Collection
from dataclasses import dataclass, field

from pymavlink.dialects.v20 import common as mavlink

from onboard.adapters.mavlink import modes
from onboard.adapters.mavlink.api import VehicleSnapshot
from onboard.adapters.mavlink.config import MavlinkConfig
from onboard.adapters.mavlink.mission_protocol import MissionLimits, local_to_global, seq_of_goal
from onboard.adapters.mavlink.peers import Link
from onboard.adapters.mavlink.transport import Transport
from onboard.core import commands as core
from onboard.core.commands import Verdict
from onboard.core.mission.model import Obstacle
from onboard.core.mission.state import MissionState
from onboard.core.safety.diagnosis import FaultFlag
from onboard.protocol.conventions import body_to_ned

VERSION = (0, 1, 0)
CAPABILITIES = (
    mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_FLOAT
    | mavlink.MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT
    | mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_INT
    | mavlink.MAV_PROTOCOL_CAPABILITY_COMMAND_INT
    | mavlink.MAV_PROTOCOL_CAPABILITY_MAVLINK2
    | mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_FENCE
)


@dataclass(frozen=True)
class StateRow:
    """How one mission state looks on MAVLink."""

    mission_state: int  # MISSION_CURRENT.mission_state
    in_mission: bool  # MISSION_CURRENT.mission_mode


S = MissionState
#: The ONE table mapping the mission state to MISSION_STATE (custom_mode: the table of
#: :mod:`~onboard.adapters.mavlink.modes`; MAV_STATE: :func:`system_status`).
STATE_TABLE: dict[MissionState, StateRow] = {
    S.IDLE: StateRow(mavlink.MISSION_STATE_NOT_STARTED, False),
    S.ARMED: StateRow(mavlink.MISSION_STATE_NOT_STARTED, False),
    S.RUNNING: StateRow(mavlink.MISSION_STATE_ACTIVE, True),
    S.HOLD: StateRow(mavlink.MISSION_STATE_PAUSED, True),
    S.ABORT: StateRow(mavlink.MISSION_STATE_PAUSED, False),
    S.COMPLETE: StateRow(mavlink.MISSION_STATE_COMPLETE, False),
}


def system_status(s: VehicleSnapshot) -> int:
    """MAV_STATE of a snapshot: CRITICAL (ABORT, failsafe) > ACTIVE (armed) > STANDBY (ready) > BOOT."""
    if s.state is MissionState.ABORT or s.failsafe:
        return mavlink.MAV_STATE_CRITICAL
    if s.armed:
        return mavlink.MAV_STATE_ACTIVE
    if s.ready:
        return mavlink.MAV_STATE_STANDBY
    return mavlink.MAV_STATE_BOOT


def _f(v: float) -> float:
    """NaN-safe float for MAVLink float fields (NaN stays NaN, which MAVLink uses for unknown)."""
    return float(v)


def _i(v: float, lo: int, hi: int) -> int:
    """Clamp a float to an integer field (NaN -> 0)."""
    if not math.isfinite(v):
        return 0
    return max(lo, min(hi, round(v)))


@dataclass
class _Rate:
    """One link's own rate of a stream (it set the interval)."""

    period_s: float
    next_s: float = 0.0


@dataclass
class _Stream:
    period_s: float  # for every link without a rate of its own
    default_s: float
    next_s: float = 0.0
    links: dict[Link, _Rate] = field(default_factory=dict)  # the links that set an interval of their own


#: The SYS_STATUS bit of each sensor (or actuator) a fault detector judges, and the fault that makes it
#: unhealthy: the compass 3D_MAG, the depth sensor ABSOLUTE_PRESSURE (it is one), the position fixes GPS (the
#: position-fix sensor's bit; LBL here), the DVL VISION_POSITION (ArduSub feeds its DVL to the EKF the same
#: way, as visual odometry; SYS_STATUS has no DVL bit), the propeller PROPULSION. A stuck fin is
#: MOTOR_OUTPUTS (with the bus).
FAULT_BITS: tuple[tuple[int, FaultFlag], ...] = (
    (mavlink.MAV_SYS_STATUS_SENSOR_3D_MAG, FaultFlag.COMPASS_BIAS),
    (mavlink.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE, FaultFlag.DEPTH_STUCK),
    (mavlink.MAV_SYS_STATUS_SENSOR_GPS, FaultFlag.FIX_OUTAGE),
    (mavlink.MAV_SYS_STATUS_SENSOR_VISION_POSITION, FaultFlag.DVL_DROPOUT),
    (mavlink.MAV_SYS_STATUS_SENSOR_PROPULSION, FaultFlag.THRUST_LOSS),
)


def fault_bits(fault_flags: int) -> tuple[int, int]:
    """(present = enabled, unhealthy) SYS_STATUS bits of the judged sensors for the faults named now."""
    present = unhealthy = 0
    for bit, flag in FAULT_BITS:
        present |= bit
        if fault_flags & flag:
            unhealthy |= bit
    return present, unhealthy


def _advance(next_s: float, period_s: float, now: float) -> float:
    """The next deadline of a stream due at ``now`` (never a catch-up burst after a late poll)."""
    return max(next_s + period_s, now) if next_s else now


class Telemetry:
    """Snapshot in (loop thread, :meth:`publish`), streams out (I/O thread, :meth:`poll`)."""

    def __init__(
        self,
        config: MavlinkConfig,
        transport: Transport,
        clock: Callable[[], float],
        shape: Callable[[], tuple[int, int]],
        error_count: Callable[[], int] = lambda: 0,
        progress: int | None = None,
        fence_circles: Callable[[], tuple[Obstacle, ...]] = tuple,
        origin: Callable[[], MissionLimits] | None = None,
        storage_problem: Callable[[], str] | None = None,
    ) -> None:
        self.config = config
        self._fence_circles = fence_circles
        self._storage_problem = storage_problem  # "" = the state directory can be written
        self.transport = transport
        self._clock = clock
        self._shape = shape
        self._error_count = error_count
        self._origin = origin or (
            lambda: MissionLimits(config.origin_lat_deg, config.origin_lon_deg, config.origin_alt_m)
        )
        self._lock = threading.Lock()
        # Until the loop's first snapshot: the persisted progress, so MISSION_CURRENT never says goal 0
        # of a mission that has progressed (the core restores the same value at boot).
        self._snapshot = VehicleSnapshot(current_goal=progress or 0)
        self.published = False
        self._reached: collections.deque[int] = collections.deque(maxlen=256)
        self._changed = False  # the state or the armed bit changed since the last poll
        self._streams: dict[int, _Stream] = {}
        for msg_id, rate in (
            (mavlink.MAVLINK_MSG_ID_HEARTBEAT, config.heartbeat_rate_hz),
            (mavlink.MAVLINK_MSG_ID_LOCAL_POSITION_NED, config.position_rate_hz),
            (mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, config.position_rate_hz),
            (mavlink.MAVLINK_MSG_ID_ATTITUDE, config.attitude_rate_hz),
            (mavlink.MAVLINK_MSG_ID_NAV_CONTROLLER_OUTPUT, config.nav_rate_hz),
            (mavlink.MAVLINK_MSG_ID_ACTUATOR_OUTPUT_STATUS, config.actuator_rate_hz),
            (mavlink.MAVLINK_MSG_ID_SYS_STATUS, config.sys_status_rate_hz),
            (mavlink.MAVLINK_MSG_ID_NAMED_VALUE_INT, config.sys_status_rate_hz),  # FIX_REJ
            (mavlink.MAVLINK_MSG_ID_MISSION_CURRENT, config.mission_current_rate_hz),
            (mavlink.MAVLINK_MSG_ID_HOME_POSITION, config.home_rate_hz),
            (mavlink.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN, config.home_rate_hz),
            (mavlink.MAVLINK_MSG_ID_EXTENDED_SYS_STATE, 0.0),  # off unless asked for (MAVSDK asks)
        ):
            period = 1.0 / rate if rate > 0 else math.inf
            self._streams[msg_id] = _Stream(period, period)

    # ---- loop thread ---------------------------------------------------------------------------
    def publish(self, snapshot: VehicleSnapshot) -> None:
        """Store the loop's latest state (O(1)); queue MISSION_ITEM_REACHED for newly reached goals, and a
        HEARTBEAT and MISSION_CURRENT when the state changed: a ground station hears a transition at once,
        not at the next 1 Hz beat (MAVSDK's ``is_mission_finished`` reads COMPLETE from MISSION_CURRENT)."""
        offset = self._shape()[0]
        with self._lock:
            prev = self._snapshot
            self._snapshot = snapshot
            self.published = True
            for k in range(max(0, snapshot.goals_reached - prev.goals_reached)):
                self._reached.append(seq_of_goal(prev.current_goal + k, offset))
            changed = snapshot.state is not prev.state or snapshot.armed != prev.armed
            self._changed = self._changed or changed
        if changed:
            self.transport.wake()  # the I/O thread sends it now, not at its next stream's deadline

    def snapshot(self) -> VehicleSnapshot:
        with self._lock:
            return self._snapshot

    # ---- I/O thread ----------------------------------------------------------------------------
    def _sensor_bits(self, s: VehicleSnapshot) -> tuple[int, int, int]:
        """SYS_STATUS (present, enabled, health): only what is really known. The geofence (the mission's
        fence circles) is present and enabled while there are circles, and healthy unless the vehicle's
        position is inside one (MAVLink's health bit for it means "not breached"). A bit not present is
        reported healthy, as ArduPilot does, so no station reads it as a breach (MAVProxy said "fence
        breach" on connect when every health bit was 0). The sensors the fault detectors judge are added
        where the message is built (:func:`fault_bits`)."""
        fence = mavlink.MAV_SYS_STATUS_GEOFENCE
        circles = self._fence_circles()
        if not circles:
            return 0, 0, fence
        inside = any(math.hypot(s.x_m - c.x_m, s.y_m - c.y_m) < c.radius_m for c in circles)
        return fence, fence, 0 if inside else fence

    def poll(self, now: float) -> None:
        while True:
            with self._lock:
                if not self._reached:
                    break
                seq = self._reached.popleft()
            self.transport.send(mavlink.MAVLink_mission_item_reached_message(seq))
        with self._lock:
            changed, self._changed = self._changed, False
        if changed:  # after the reached goals: a station sees the goal, then the state it led to
            self.send_message(mavlink.MAVLINK_MSG_ID_HEARTBEAT)
            self.send_mission_current()
        self._forget_gone_links()
        for msg_id, stream in self._streams.items():
            if now >= stream.next_s:
                stream.next_s = _advance(stream.next_s, stream.period_s, now)
                if stream.period_s < math.inf:
                    self.send_message(msg_id, exclude=stream.links.keys())
            for link, own in stream.links.items():
                if now >= own.next_s:
                    own.next_s = _advance(own.next_s, own.period_s, now)
                    if own.period_s < math.inf:
                        self.send_message(msg_id, link)

    def _forget_gone_links(self) -> None:
        """Drop the own rates of links that are no peer any more (the table stays as small as the peers')."""
        if not any(st.links for st in self._streams.values()):
            return
        live = self.transport.links()
        for st in self._streams.values():
            for link in [k for k in st.links if k not in live]:
                del st.links[link]

    def next_deadline(self) -> float:
        with self._lock:
            if self._reached or self._changed:
                return self._clock()
        return min(min([s.next_s, *(r.next_s for r in s.links.values())]) for s in self._streams.values())

    def requestable(self) -> set[int]:
        return set(self._streams) | {mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION}

    def set_interval(self, msg_id: int, interval_us: float, link: Link | None = None) -> Verdict:
        """SET_MESSAGE_INTERVAL for ``link`` (the asker's; None, a sender not known: every link's default):
        < 0 off, 0 the configured rate, else the interval, at most ``max_stream_rate_hz``."""
        stream = self._streams.get(msg_id)
        if stream is None or msg_id == mavlink.MAVLINK_MSG_ID_HEARTBEAT:
            return core.denied(f"the interval of message {msg_id} cannot be set")
        max_hz = self.config.max_stream_rate_hz
        if interval_us < 0:
            period = math.inf
        elif interval_us == 0:
            period = stream.default_s
        else:
            period = max(interval_us * 1e-6, 1.0 / max_hz)
        now = self._clock()
        if link is None:
            stream.period_s, stream.next_s = period, now
        elif interval_us == 0:
            stream.links.pop(link, None)
        else:
            stream.links[link] = _Rate(period, now)
        if 0 < interval_us * 1e-6 < 1.0 / max_hz:
            return core.accepted(f"interval set to {period * 1e6:.0f} us (at most {max_hz:g} Hz)")
        return core.accepted("interval set")

    def send_mission_current(
        self, goal_index: int | None = None, link: Link | None = None, exclude: Collection[Link] = ()
    ) -> None:
        """MISSION_CURRENT now (``goal_index`` given: the goal just selected, before the loop reports it), to
        every link but ``exclude``, or to ``link`` only."""
        s = self.snapshot()
        offset, n = self._shape()  # total excludes a home item (spec)
        index = s.current_goal if goal_index is None else goal_index
        row = STATE_TABLE[s.state]
        self._send(
            mavlink.MAVLink_mission_current_message(
                _i(seq_of_goal(index, offset), 0, 65535),
                n,
                row.mission_state if n else mavlink.MISSION_STATE_NO_MISSION,
                1 if row.in_mission else 0,
            ),
            link,
            exclude,
        )

    def _send(self, m: mavlink.MAVLink_message, link: Link | None, exclude: Collection[Link]) -> None:
        if link is not None:
            self.transport.send(m, link)
        elif exclude:
            self.transport.send(m, exclude=exclude)
        else:
            self.transport.send(m)

    def send_message(self, msg_id: int, link: Link | None = None, exclude: Collection[Link] = ()) -> None:
        """Message ``msg_id`` now, to every link but ``exclude``, or to ``link`` only."""
        s = self.snapshot()
        boot_ms = _i(s.t_s * 1000.0, 0, 2**32 - 1)
        usec = _i(s.t_s * 1e6, 0, 2**63 - 1)
        o = self._origin()
        m: mavlink.MAVLink_message
        if msg_id == mavlink.MAVLINK_MSG_ID_HEARTBEAT:
            base = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | mavlink.MAV_MODE_FLAG_AUTO_ENABLED
            if s.armed:
                base |= mavlink.MAV_MODE_FLAG_SAFETY_ARMED
            m = mavlink.MAVLink_heartbeat_message(
                mavlink.MAV_TYPE_SUBMARINE,
                mavlink.MAV_AUTOPILOT_GENERIC,
                base,
                modes.custom_mode(s.state, s.loitering),
                system_status(s),
                3,
            )
        elif msg_id == mavlink.MAVLINK_MSG_ID_LOCAL_POSITION_NED:
            vn, ve, vd = body_to_ned(s.roll_rad, s.pitch_rad, s.yaw_rad, s.u_mps, s.v_mps, s.w_mps)
            m = mavlink.MAVLink_local_position_ned_message(boot_ms, s.x_m, s.y_m, s.depth_m, vn, ve, vd)
        elif msg_id == mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT:
            vn, ve, vd = body_to_ned(s.roll_rad, s.pitch_rad, s.yaw_rad, s.u_mps, s.v_mps, s.w_mps)
            lat, lon = local_to_global(s.x_m, s.y_m, o)
            hdg = math.degrees(s.yaw_rad) % 360.0 if math.isfinite(s.yaw_rad) else math.nan
            m = mavlink.MAVLink_global_position_int_message(
                boot_ms,
                _i(lat * 1e7, -900_000_000, 900_000_000),
                _i(lon * 1e7, -1_800_000_000, 1_800_000_000),
                _i((o.origin_alt_m - s.depth_m) * 1000.0, -(2**31), 2**31 - 1),
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
            target = math.degrees(s.yaw_rad + s.e_yaw_rad)
            m = mavlink.MAVLink_nav_controller_output_message(
                0.0,
                0.0,
                _i(bearing, -32768, 32767),
                _i(target, -32768, 32767),
                _i(s.goal_distance_m, 0, 65535),
                _f(s.e_depth_m),
                0.0,
                _f(s.cross_track_m),
            )
        elif msg_id == mavlink.MAVLINK_MSG_ID_ACTUATOR_OUTPUT_STATUS:
            acts = [s.rudder_rad, s.stern_port_rad, s.stern_starboard_rad, s.propeller_rps]
            m = mavlink.MAVLink_actuator_output_status_message(usec, 4, [*acts, *([0.0] * 28)])
        elif msg_id == mavlink.MAVLINK_MSG_ID_SYS_STATUS:
            # the loop's busy share of its period (LoopStats.load), in MAVLink's per mille, at most 1000
            load = _i(s.loop_load * 1000.0, 0, 1000)
            errors = self._error_count()
            present, enabled, health = self._sensor_bits(s)
            if self._storage_problem is not None:  # LOGGING: the state directory (saving) works
                bit = mavlink.MAV_SYS_STATUS_LOGGING
                present, enabled = present | bit, enabled | bit
                health = health | bit if not self._storage_problem() else health & ~bit
            # MOTOR_OUTPUTS: the CAN bus to the actuator node and the fins following their commands (healthy
            # unless the bus is lost or a fin is stuck; the STATUSTEXT says why)
            motors = mavlink.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS
            present, enabled = present | motors, enabled | motors
            stuck = s.fault_flags & FaultFlag.FIN_STUCK
            health = health & ~motors if s.bus_lost or stuck else health | motors
            # the sensors and the propeller the fault detectors judge (onboard.core.safety.diagnosis)
            bits, unhealthy = fault_bits(s.fault_flags)
            present, enabled, health = present | bits, enabled | bits, (health | bits) & ~unhealthy
            m = mavlink.MAVLink_sys_status_message(
                present, enabled, health, load, 0xFFFF, -1, -1, 0, _i(errors, 0, 65535),
                _i(s.overruns, 0, 65535), 0, 0, 0,
            )  # fmt: skip
        elif msg_id == mavlink.MAVLINK_MSG_ID_NAMED_VALUE_INT:
            # the position fixes the navigation's innovation gate refused since boot (a 20 m jump counted,
            # not followed), at SYS_STATUS's rate: the operator sees refusals before they repeat
            m = mavlink.MAVLink_named_value_int_message(
                boot_ms, b"FIX_REJ", _i(s.fixes_rejected, 0, 2**31 - 1)
            )
        elif msg_id == mavlink.MAVLINK_MSG_ID_MISSION_CURRENT:
            self.send_mission_current(link=link, exclude=exclude)
            return
        elif msg_id == mavlink.MAVLINK_MSG_ID_HOME_POSITION:
            m = mavlink.MAVLink_home_position_message(
                round(o.origin_lat_deg * 1e7),
                round(o.origin_lon_deg * 1e7),
                round(o.origin_alt_m * 1000),
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
            m = mavlink.MAVLink_gps_global_origin_message(
                round(o.origin_lat_deg * 1e7),
                round(o.origin_lon_deg * 1e7),
                round(o.origin_alt_m * 1000),
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
        self._send(m, link, exclude)
