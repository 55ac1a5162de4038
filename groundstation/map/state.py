"""The map's picture of the vehicle: MAVLink messages in, small JSON-able records out (no I/O, no clock).

Frame: local NED metres (x north, y east, depth down), as the vehicle streams them; the page draws north up,
east right. Items of the plans in a global frame are drawn once the vehicle's GPS_GLOBAL_ORIGIN came,
projected as the vehicle does (:func:`groundstation.mission_files.local_ned`). Angles: yaw in degrees
clockwise from north (the page's unit), converted once here from the radians of ATTITUDE. A number that is
not finite is None (JSON has no NaN): the page does not draw a goal or obstacle without its position,
depth or radius, and says so.

Goals: MISSION_CURRENT.seq is a MAVLink seq, the goal index + 1 when the mission starts with a home
placeholder (:func:`groundstation.mission_files.is_home_placeholder`, the vehicle's rule); the telemetry and
each goal carry the goal ``index`` (0-based) the page shows, taken with the downloaded mission's offset.

Inputs, the same live and in a tlog replay: ``(t_s, message)`` pairs (``t_s`` unix seconds: the arrival time
live, the record's time in a tlog) for HEARTBEAT, LOCAL_POSITION_NED, ATTITUDE, NAV_CONTROLLER_OUTPUT,
MISSION_CURRENT, SYS_STATUS, STATUSTEXT and GPS_GLOBAL_ORIGIN of the vehicle; the plans (mission type 0
goals, type 1 fence circles) as :class:`~groundstation.mavclient.Item` lists (a download live; in a tlog
the transfers recorded in it, see :class:`PlanRecorder`); the vehicle's planned path file
(:func:`parse_planned`; in a tlog the MAVLink FTP reads recorded in it, see :class:`FileReadRecorder`).

Output: :meth:`MapModel.picture` — the telemetry record, the plans and the path with version numbers, and the
track — and :func:`update_for`, the message one page needs given what it was sent before.
"""

from __future__ import annotations

import json
import math
import struct
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any

from pymavlink.dialects.v20 import common as mavlink

from auv_common import mavlink_ftp as ftp
from auv_common.mission_items import radius_of_item
from groundstation import mission_files
from groundstation.messages import Msg, StatusText, StatusTextAssembler, state_from_heartbeat
from groundstation.mission_client import Item
from groundstation.text import wire_text

#: The vehicle's file with the path it flies now (read over MAVLink FTP).
PLANNED_PATH_FILE = "@PATH/planned.json"
#: No message of the vehicle for this long: the page says the link is lost.
STALE_AFTER_S = 3.0
#: A track point is kept when the vehicle moved at least this far from the last one kept.
TRACK_STEP_M = 0.05
#: At most this many track points (live); beyond, the older half is dropped (a new track epoch).
TRACK_MAX_POINTS = 20_000
#: The vehicle's texts the page lists (the newest last).
TEXTS_SHOWN = 5
#: A STATUSTEXT with one of these words may mean a new mission or fence: the plans are downloaded again.
PLAN_CHANGE_WORDS = ("accepted", "cleared", "replaced")
GEOFENCE_BIT = mavlink.MAV_SYS_STATUS_GEOFENCE
MISSION_STATE_NAMES = {k: v.name for k, v in mavlink.enums["MISSION_STATE"].items()}


def mission_state(heartbeat: Msg, mission_current: Msg | None = None) -> str:
    """The vehicle's mission state (IDLE, ARMED, RUNNING, HOLD, ABORT, COMPLETE): the one call of the ground
    station's owner of that decoding, :func:`~groundstation.mavclient.state_from_heartbeat`."""
    del mission_current  # (the owner may take it too one day: then it is passed here, in this one line)
    return state_from_heartbeat(heartbeat)


def finite(value: float) -> float | None:
    """``value`` as a float, None for NaN / inf (JSON has no NaN; the page shows "-")."""
    v = float(value)
    return v if math.isfinite(v) else None


def wrap_deg(angle_deg: float) -> float:
    """An angle in degrees wrapped into [-180, 180)."""
    return ((angle_deg + 180.0) % 360.0) - 180.0


def yaw_error_deg(nav: Msg) -> float:
    """NAV_CONTROLLER_OUTPUT's yaw error, target bearing - nav bearing (degrees, wrapped to [-180, 180))."""
    return wrap_deg(float(nav.target_bearing) - float(nav.nav_bearing))


def item_of(msg: Msg) -> Item:
    """A MISSION_ITEM_INT message as the client's :class:`Item` (the encoding :meth:`MavClient.download`
    returns)."""
    return Item(
        msg.frame, msg.command, msg.param1, msg.param2, msg.param3, msg.param4, msg.x, msg.y, msg.z,
        msg.autocontinue,
    )  # fmt: skip


def home_offset(items: Sequence[Item]) -> int:
    """1 if the MISSION plan ``items`` starts with the vehicle's home placeholder (MAVLink seq = goal index
    + 1), else 0 (:func:`groundstation.mission_files.is_home_placeholder`)."""
    return 1 if mission_files.is_home_placeholder(items) else 0


def _metres(value: float, digits: int) -> float | None:
    v = finite(value)
    return None if v is None else round(v, digits)


def goals_of(items: Sequence[Item], origin: mission_files.Origin | None = None) -> list[dict[str, Any]]:
    """The goals of a mission plan: the waypoints with a place in local NED (local ones; global ones about
    ``origin``, :func:`groundstation.mission_files.local_ned`) as ``{seq, index, x_m, y_m, depth_m,
    yaw_deg, radius_m}``: ``seq`` the MAVLink seq, ``index`` the goal index (seq less :func:`home_offset`),
    yaw None when the planner chooses it, ``radius_m`` the goal's acceptance radius (param2; 0 = the
    vehicle's default), a number that is not finite None. A home placeholder, items of other
    commands and global items without an origin are not drawn."""
    offset = home_offset(items)
    out = []
    for seq, it in enumerate(items):
        if seq < offset or it.command != mavlink.MAV_CMD_NAV_WAYPOINT:
            continue
        where = mission_files.local_ned(it, origin)
        if where is None:
            continue
        x_m, y_m, depth_m = where
        out.append(
            {
                "seq": seq,
                "index": seq - offset,
                "x_m": _metres(x_m, 4),
                "y_m": _metres(y_m, 4),
                "depth_m": _metres(depth_m, 6),
                "yaw_deg": _metres(it.param4, 6),
                "radius_m": _metres(radius_of_item(it), 6),
            }
        )
    return out


def obstacles_of(items: Iterable[Item], origin: mission_files.Origin | None = None) -> list[dict[str, Any]]:
    """The fence plan's exclusion circles with a place in local NED (as :func:`goals_of`) as ``{x_m, y_m,
    radius_m}``, a number that is not finite None; other fence items are not drawn."""
    out = []
    for it in items:
        where = mission_files.local_ned(it, origin)
        if it.command != mavlink.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION or where is None:
            continue
        out.append({"x_m": _metres(where[0], 4), "y_m": _metres(where[1], 4), "radius_m": finite(it.param1)})
    return out


def parse_planned(raw: bytes) -> dict[str, Any]:
    """The vehicle's planned-path file (JSON ``{version, kind, goal_index, frame: "local_ned", length_m,
    points_m}``, onboard ``ftp.path_document``) as ``{version, kind, goal_index, length_m (None if absent),
    points_m: [[x_m, y_m, depth_m], ...]}``; ValueError says what is wrong."""
    try:
        data = json.loads(raw.decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ValueError(f"{PLANNED_PATH_FILE}: not JSON ({exc})") from None
    if not isinstance(data, dict):
        raise ValueError(f"{PLANNED_PATH_FILE}: expected an object")
    if data.get("frame", "local_ned") != "local_ned":
        raise ValueError(f"{PLANNED_PATH_FILE}: frame {data.get('frame')!r}, expected 'local_ned'")
    points = data.get("points_m") or []
    if not isinstance(points, list):
        raise ValueError(f"{PLANNED_PATH_FILE}: points_m must be a list")
    out = []
    for i, p in enumerate(points):
        ok = isinstance(p, list | tuple) and len(p) in (2, 3)
        ok = ok and all(isinstance(v, int | float) and not isinstance(v, bool) for v in p)
        if not ok or not all(math.isfinite(v) for v in p):
            raise ValueError(f"{PLANNED_PATH_FILE}: points_m[{i}] is not [x_m, y_m, depth_m]: {p!r}")
        out.append([round(float(v), 3) for v in (*p, 0.0)[:3]])
    length = data.get("length_m")
    return {
        "version": int(data.get("version") or 0),
        "kind": str(data.get("kind") or ""),
        "goal_index": int(data.get("goal_index", -1)),
        "length_m": round(float(length), 3)
        if isinstance(length, int | float) and math.isfinite(length)
        else None,
        "points_m": out,
    }


class PlanRecorder:
    """The plans as a tlog recorded their transfers: a MISSION_COUNT opens a plan of its mission type, its
    MISSION_ITEM_INTs fill it, an accepted MISSION_ACK of the same type commits it (an upload is acked by the
    vehicle, a download by the ground station; a refused or broken transfer commits nothing). An accepted
    MISSION_CLEAR_ALL commits empty plans; an accepted whole-plan upload (type ALL: goals and fence in one
    transfer) commits both, its fence circles the fence and the rest the goals."""

    def __init__(self) -> None:
        self._open: dict[int, tuple[int, dict[int, Item]]] = {}
        self._clearing: set[int] = set()

    def feed(self, msg: Msg) -> list[tuple[int, list[Item]]]:
        """The plans (mission type, items) this message commits (usually none)."""
        kind = msg.get_type()
        mt = int(getattr(msg, "mission_type", 0))
        if kind == "MISSION_COUNT":
            self._open[mt] = (int(msg.count), {})
        elif kind == "MISSION_ITEM_INT" and mt in self._open:
            count, items = self._open[mt]
            if 0 <= msg.seq < count:
                items[int(msg.seq)] = item_of(msg)
        elif kind == "MISSION_CLEAR_ALL":
            self._clearing.add(mt)
        elif kind == "MISSION_ACK":
            if int(msg.type) != mavlink.MAV_MISSION_ACCEPTED:
                self._open.pop(mt, None)
                self._clearing.discard(mt)
                return []
            if mt in self._clearing:
                self._clearing.discard(mt)
                types = (
                    [mavlink.MAV_MISSION_TYPE_MISSION, mavlink.MAV_MISSION_TYPE_FENCE]
                    if mt == mavlink.MAV_MISSION_TYPE_ALL
                    else [mt]
                )
                return [(t, []) for t in types]
            opened = self._open.pop(mt, None)
            if opened is not None and len(opened[1]) == opened[0]:
                plan = [opened[1][i] for i in range(opened[0])]
                if mt == mavlink.MAV_MISSION_TYPE_ALL:
                    fence = mavlink.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION
                    return [
                        (mavlink.MAV_MISSION_TYPE_MISSION, [i for i in plan if i.command != fence]),
                        (mavlink.MAV_MISSION_TYPE_FENCE, [i for i in plan if i.command == fence]),
                    ]
                return [(mt, plan)]
        return []


class FileReadRecorder:
    """The files a recording read over MAVLink FTP: an OpenFileRO request names the file, its ACK opens a
    session of that size, the ReadFile ACKs carry its bytes in order; when all came, the read is done. A NAK
    to the open: the file is not there."""

    def __init__(self) -> None:
        self._opening: dict[int, str] = {}  # the seq of the expected reply -> the file's name
        self._reading: dict[int, tuple[str, int, bytearray]] = {}  # session -> (name, size, bytes so far)

    def feed(self, msg: Msg) -> tuple[str, bytes | None] | None:
        """(name, the file's bytes, None if it is not there) when this message completes a read, else None."""
        if msg.get_type() != "FILE_TRANSFER_PROTOCOL":
            return None
        try:
            p = ftp.Packet.decode(msg.payload)
        except struct.error:
            return None
        if p.opcode == ftp.OPEN_RO:
            self._opening[(p.seq + 1) & 0xFFFF] = p.data.decode("utf-8", "replace")
        elif p.opcode == ftp.NAK and p.req_opcode == ftp.OPEN_RO:
            name = self._opening.pop(p.seq, None)
            if name is not None and p.data[:1] == bytes([ftp.FILE_NOT_FOUND]):
                return name, None
        elif p.opcode == ftp.ACK and p.req_opcode == ftp.OPEN_RO and len(p.data) >= 4:
            name = self._opening.pop(p.seq, None)
            if name is not None:
                size = struct.unpack("<I", p.data[:4])[0]
                if size == 0:
                    return name, b""
                self._reading[p.session] = (name, size, bytearray())
        elif p.opcode == ftp.ACK and p.req_opcode == ftp.READ and p.session in self._reading:
            name, size, got = self._reading[p.session]
            if p.offset == len(got):
                got += p.data
            if len(got) >= size:
                del self._reading[p.session]
                return name, bytes(got[:size])
        elif p.req_opcode == ftp.TERMINATE:
            self._reading.pop(p.session, None)
        return None


@dataclass(frozen=True)
class Picture:
    """What the map shows at one time: the telemetry record (a new dict each time), the plans and the path
    with the version they have in the model, and the track (a list only ever appended to within one epoch:
    its first ``track_len`` points are this picture's track)."""

    t_s: float
    seq: int
    telemetry: dict[str, Any]
    plan_version: int
    plan: dict[str, Any]
    path_version: int
    path: dict[str, Any] | None
    track_epoch: int
    track: list[list[float]]
    track_len: int


@dataclass(frozen=True)
class Sent:
    """What one page was sent last: plan and path versions, track epoch and length."""

    plan_version: int = -1
    path_version: int = -1
    track_epoch: int = -1
    track_len: int = 0


def update_for(pic: Picture, sent: Sent | None) -> tuple[dict[str, Any], Sent]:
    """The update message for a page that was sent ``sent`` before (None: nothing yet), and what it then has.

    The telemetry always; the plan and the path only when their version changed; the track as the points
    from ``track_from`` on (the page cuts its track to ``track_from`` points, then appends ``track``): the
    new points, all of them after a new epoch, none and a shorter length when a replay seeks backwards."""
    sent = sent or Sent()
    msg: dict[str, Any] = {"type": "update", "t_s": pic.t_s, "telemetry": pic.telemetry}
    if pic.plan_version != sent.plan_version:
        msg["plan"] = pic.plan
    if pic.path_version != sent.path_version:
        msg["path"] = pic.path
    start = sent.track_len if pic.track_epoch == sent.track_epoch else 0
    start = min(start, pic.track_len)
    msg["track_from"] = start
    msg["track"] = pic.track[start : pic.track_len]
    return msg, Sent(pic.plan_version, pic.path_version, pic.track_epoch, pic.track_len)


@dataclass
class _Vehicle:
    x_m: float = math.nan
    y_m: float = math.nan
    depth_m: float = math.nan
    speed_mps: float = math.nan
    time_boot_ms: int = 0
    yaw_deg: float | None = None
    t_pose_s: float | None = None


class MapModel:
    """The map's state, changed by :meth:`apply` (telemetry), :meth:`set_plan` and :meth:`set_path`, read by
    :meth:`picture`.

    ``vehicle`` (system, component) is the vehicle whose messages count; None: the first one that sends a
    HEARTBEAT that is not a ground station's. ``from_recording``: take the plans and the planned path from
    the transfers in the messages (a tlog replay: :class:`PlanRecorder`, :class:`FileReadRecorder`) instead
    of :meth:`set_plan` and :meth:`set_path` (live). ``track_max_points``: None keeps
    every point (a replay: its pictures share one track)."""

    def __init__(
        self,
        vehicle: tuple[int, int] | None = None,
        *,
        from_recording: bool = False,
        track_max_points: int | None = TRACK_MAX_POINTS,
    ) -> None:
        self.vehicle = vehicle
        self.from_recording = from_recording
        self.track_max_points = track_max_points
        self.seq = 0  # counts every change: a page needs an update when it moved
        self.plan_version = 0
        self.path_version = 0
        self.track_epoch = 0
        self.track: list[list[float]] = []
        self.note = ""
        self._v = _Vehicle()
        self._heartbeat: Msg | None = None
        self._mission_current: Msg | None = None
        self._nav: Msg | None = None
        self._load: float | None = None
        self._fence_present: bool | None = None
        self._t_last_s: float | None = None
        self._texts: list[StatusText] = []
        self._assembler = StatusTextAssembler()
        self._recorder = PlanRecorder()
        self._files = FileReadRecorder()
        self._items: dict[int, list[Item]] = {
            mavlink.MAV_MISSION_TYPE_MISSION: [],
            mavlink.MAV_MISSION_TYPE_FENCE: [],
        }
        self._origin: mission_files.Origin | None = None
        self._plan: dict[str, Any] = _plan_of(self._items, None)
        self._path: dict[str, Any] | None = None
        self._refresh = False

    # ---- inputs ----------------------------------------------------------------------------------
    def apply(self, t_s: float, msg: Msg) -> None:
        """One message of the link (or the tlog) received at ``t_s`` (unix s)."""
        if self.from_recording:
            for mission_type, items in self._recorder.feed(msg):
                self.set_plan(mission_type, items)
            read = self._files.feed(msg)
            if read is not None and read[0] == PLANNED_PATH_FILE:
                self._set_path_file(read[1])
        kind = msg.get_type()
        src = (msg.get_srcSystem(), msg.get_srcComponent())
        if self.vehicle is None:
            if kind != "HEARTBEAT" or msg.type == mavlink.MAV_TYPE_GCS:
                return
            self.vehicle = src
        if src != self.vehicle:
            return
        self.seq += 1
        self._t_last_s = t_s
        v = self._v
        if kind == "HEARTBEAT":
            self._heartbeat = msg
        elif kind == "LOCAL_POSITION_NED":
            v.x_m, v.y_m, v.depth_m = float(msg.x), float(msg.y), float(msg.z)
            v.speed_mps = math.hypot(float(msg.vx), float(msg.vy))
            v.time_boot_ms, v.t_pose_s = int(msg.time_boot_ms), t_s
            self._add_track_point(v.x_m, v.y_m, v.depth_m)
        elif kind == "ATTITUDE":
            yaw = finite(msg.yaw)
            v.yaw_deg = None if yaw is None else math.degrees(yaw) % 360.0
        elif kind == "NAV_CONTROLLER_OUTPUT":
            self._nav = msg
        elif kind == "MISSION_CURRENT":
            old = self._mission_current
            if old is not None and old.total != msg.total:
                self._refresh = True
            self._mission_current = msg
        elif kind == "SYS_STATUS":
            present = bool(int(msg.onboard_control_sensors_present) & GEOFENCE_BIT)
            if self._fence_present is not None and present != self._fence_present:
                self._refresh = True
            self._fence_present = present
            self._load = int(msg.load) / 1000.0
        elif kind == "GPS_GLOBAL_ORIGIN":
            origin = mission_files.Origin(msg.latitude / 1e7, msg.longitude / 1e7, msg.altitude / 1000.0)
            if origin != self._origin:
                self._origin = origin
                self._draw_plans()
        elif kind == "STATUSTEXT":
            done = self._assembler.feed(msg, t_s)
            for text in [*([done] if done is not None else []), *self._assembler.flush(t_s)]:
                self._texts = [*self._texts[-(TEXTS_SHOWN - 1) :], text]
                if any(w in text.text.lower() for w in PLAN_CHANGE_WORDS):
                    self._refresh = True

    def _add_track_point(self, x_m: float, y_m: float, depth_m: float) -> None:
        if not (math.isfinite(x_m) and math.isfinite(y_m)):
            return
        if self.track:
            lx, ly, _ = self.track[-1]
            if math.hypot(x_m - lx, y_m - ly) < TRACK_STEP_M:
                return
        if self.track_max_points is not None and len(self.track) >= self.track_max_points:
            # a new list: pictures taken before keep theirs whole
            self.track = self.track[len(self.track) // 2 :]
            self.track_epoch += 1
        self.track.append(
            [round(x_m, 3), round(y_m, 3), round(depth_m, 3) if math.isfinite(depth_m) else 0.0]
        )

    def set_plan(self, mission_type: int, items: list[Item]) -> None:
        """The vehicle's plan of ``mission_type`` (0 mission: goals, 1 fence: obstacles) is ``items``."""
        if mission_type not in self._items:
            return
        self._items[mission_type] = list(items)
        self._draw_plans()

    def _draw_plans(self) -> None:
        plan = _plan_of(self._items, self._origin)
        if plan != self._plan:
            self._plan = plan
            self.plan_version += 1
            self.seq += 1

    def set_path(self, path: dict[str, Any] | None, note: str = "") -> None:
        """The path the vehicle flies (:func:`parse_planned`), None for none or unknown (``note``: why)."""
        self.note = note
        if path != self._path:
            self._path = path
            self.path_version += 1
            self.seq += 1

    def _set_path_file(self, raw: bytes | None) -> None:
        if raw is None:
            self.set_path(None, f"no planned path: no such file on the vehicle: {PLANNED_PATH_FILE}")
            return
        try:
            self.set_path(parse_planned(raw))
        except ValueError as exc:
            self.set_path(None, str(exc))

    def take_refresh(self) -> bool:
        """Whether the plans may have changed since the last call (MISSION_CURRENT.total changed, the fence
        bit of SYS_STATUS came or went, or a text of the vehicle has one of :data:`PLAN_CHANGE_WORDS`)."""
        refresh, self._refresh = self._refresh, False
        return refresh

    # ---- output ----------------------------------------------------------------------------------
    def picture(self, now_s: float) -> Picture:
        """What the map shows at ``now_s`` (unix s; the same clock as :meth:`apply`'s ``t_s``)."""
        return Picture(
            now_s,
            self.seq,
            self.telemetry(now_s),
            self.plan_version,
            self._plan,
            self.path_version,
            self._path,
            self.track_epoch,
            self.track,
            len(self.track),
        )

    def telemetry(self, now_s: float) -> dict[str, Any]:
        """The telemetry record: link, vehicle pose, state, goal, navigation errors, texts (JSON-able)."""
        v = self._v
        age = None if self._t_last_s is None else max(0.0, now_s - self._t_last_s)
        if self.vehicle is None or age is None:
            link = "waiting for the vehicle's heartbeat"
        elif age > STALE_AFTER_S:
            link = f"no message for {age:.0f} s"
        else:
            link = "ok"
        hb, mc, nav = self._heartbeat, self._mission_current, self._nav
        vehicle = None
        if v.t_pose_s is not None and math.isfinite(v.x_m) and math.isfinite(v.y_m):
            vehicle = {
                "x_m": round(v.x_m, 3),
                "y_m": round(v.y_m, 3),
                "depth_m": finite(round(v.depth_m, 3)),
                "yaw_deg": None if v.yaw_deg is None else round(v.yaw_deg, 2),
                "speed_mps": finite(round(v.speed_mps, 3)),
                "time_boot_ms": v.time_boot_ms,
                "age_s": round(max(0.0, now_s - v.t_pose_s), 3),
            }
        goal = None
        if mc is not None:
            offset = home_offset(self._items[mavlink.MAV_MISSION_TYPE_MISSION])
            goal = {
                "seq": int(mc.seq),
                "index": max(int(mc.seq) - offset, 0),  # the home's seq 0: the vehicle flies goal 0
                "total": int(mc.total),
                "mission_state": MISSION_STATE_NAMES.get(int(mc.mission_state), str(mc.mission_state)),
            }
        errors = None
        if nav is not None:
            errors = {
                "goal_distance_m": float(nav.wp_dist),
                "cross_track_m": _rounded(nav.xtrack_error),
                "depth_error_m": _rounded(nav.alt_error),
                "yaw_error_deg": _rounded(yaw_error_deg(nav)),
            }
        return {
            "link": link,
            "age_s": None if age is None else round(age, 3),
            "vehicle": vehicle,
            "state": None if hb is None else mission_state(hb, mc),
            "armed": None if hb is None else bool(hb.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED),
            "goal": goal,
            "errors": errors,
            "load": self._load,
            # the page writes them with textContent (never HTML); their control characters removed here
            "texts": [{"severity": t.severity, "text": wire_text(t.text), "t_s": t.t_s} for t in self._texts],
            "note": self.note,
        }


def _plan_of(items: dict[int, list[Item]], origin: mission_files.Origin | None) -> dict[str, Any]:
    """The plans as the page gets them: goals and obstacles drawn (:func:`goals_of`, :func:`obstacles_of`),
    how many items of each plan are not (a home placeholder is no goal), the origin (None: not known yet,
    global items are not drawn)."""
    mission, fence = items[mavlink.MAV_MISSION_TYPE_MISSION], items[mavlink.MAV_MISSION_TYPE_FENCE]
    goals, obstacles = goals_of(mission, origin), obstacles_of(fence, origin)
    return {
        "goals": goals,
        "obstacles": obstacles,
        "goals_not_drawn": len(mission) - home_offset(mission) - len(goals),
        "fence_not_drawn": len(fence) - len(obstacles),
        "origin": None
        if origin is None
        else {"lat_deg": origin.lat_deg, "lon_deg": origin.lon_deg, "alt_m": origin.alt_m},
    }


def _rounded(value: float, digits: int = 3) -> float | None:
    v = finite(value)
    return None if v is None else round(v, digits)


def replay_pictures(
    messages: Iterable[tuple[float, Msg]], step_s: float = 0.1, gap_s: float = 5.0
) -> list[Picture]:
    """The pictures of a recording, one every ``step_s`` of its time (tlog unix s) while messages come; over
    a silence longer than ``gap_s`` (a day's tlog holds several sessions) only one before and one after.
    The plans come from the transfers the recording holds (:class:`PlanRecorder`)."""
    model = MapModel(from_recording=True, track_max_points=None)
    pictures: list[Picture] = []
    next_t: float | None = None
    for t_s, msg in messages:
        if next_t is None:
            next_t = t_s
        elif t_s - next_t > gap_s:
            pictures.append(model.picture(next_t))
            next_t = t_s
        while next_t <= t_s:
            pictures.append(model.picture(next_t))
            next_t += step_s
        model.apply(t_s, msg)
    if next_t is not None:
        pictures.append(model.picture(next_t))
    return pictures


def picture_at(pictures: list[Picture], t_s: float) -> Picture:
    """The last picture taken at or before ``t_s`` (the first one before the recording starts)."""
    lo, hi = 0, len(pictures)
    while lo < hi:
        mid = (lo + hi) // 2
        if pictures[mid].t_s <= t_s:
            lo = mid + 1
        else:
            hi = mid
    return pictures[max(lo - 1, 0)]


def messages_of(records: Iterable[tuple[float, Msg]]) -> Iterator[tuple[float, Msg]]:
    """``records`` in time order (a tlog several stations appended to may be slightly out of order)."""
    return iter(sorted(records, key=lambda r: r[0]))
