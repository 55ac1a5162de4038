"""The mission item encoding, one for the vehicle and the ground station: MAVLink MISSION_ITEM_INT <-> a
plain mission item (:class:`~auv_common.mission_yaml.GoalPose` / :class:`~auv_common.mission_yaml.Circle`,
metres and degrees).

Used by the vehicle's MAVLink adapter (``onboard.adapters.mavlink.mission_protocol``: uploads, downloads,
the stored plans, ``--mission`` files) and by the ground station (``groundstation.mission_files``, the
map). The onboard core never sees it: it speaks metres and radians.

- Frames: ``MAV_FRAME_LOCAL_NED`` with x, y = metres * :data:`LOCAL_SCALE` (1e4) in an int32 and z = depth
  (m, down positive); the global frames (GLOBAL, GLOBAL_INT, GLOBAL_RELATIVE_ALT, GLOBAL_RELATIVE_ALT_INT:
  lat/lon = degrees * :data:`GLOBAL_SCALE`, 1e7) with z = altitude (m, up positive), so depth = -altitude
  in the relative frames (relative to the origin) and origin altitude - altitude in the AMSL ones (as
  ArduSub). :data:`VEHICLE_FRAMES` are the frames the vehicle takes. Yaw (param4) is in degrees, NaN = free.
- A waypoint's param2 is its acceptance radius (m; the MAVLink spec's "Acceptance radius"): 0 = the
  vehicle's default (``[mission] arrival_radius_m``); NaN reads as 0 too (what older ground stations, ours
  before issue 24, sent). Written as the goal's ``radius_m`` (0 when it has none).
- Projection (:func:`global_to_local`, :func:`local_to_global`): flat earth about the vehicle's origin
  (GPS_GLOBAL_ORIGIN), x = radians(dlat) * R, y = radians(dlon) * R * cos(origin latitude), R =
  :data:`EARTH_RADIUS_M`, dlon wrapped into [-180, 180).
- Home (ArduPilot's convention, as MAVProxy ``wp load`` and Mission Planner send a QGC WPL 110 file): a
  ``MAV_CMD_NAV_WAYPOINT`` in an absolute-altitude global frame (``MAV_FRAME_GLOBAL`` / ``_INT``) at seq 0
  of a MISSION plan is the home placeholder (:func:`is_home_placeholder`), not flown, so not a goal: with it
  MAVLink seq = goal index + 1 (:func:`home_offset`).
- Encodable: a local x or y is a metre value whose x * 1e4 rounds into an int32 (|x| <= 214748.3647 m,
  :func:`fits_local`); :func:`to_int` refuses any other with :class:`EncodingError`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import astuple, dataclass

from pymavlink.dialects.v20 import common as mavlink

from auv_common.mission_yaml import Circle, GoalPose

LOCAL_SCALE = 1e4  # MISSION_ITEM_INT local x/y: metres * 1e4
GLOBAL_SCALE = 1e7  # MISSION_ITEM_INT global lat/lon: degrees * 1e7
#: The flat-earth radius of the projection (WGS-84 equatorial), m.
EARTH_RADIUS_M = 6_378_137.0
INT32_MAX = 2**31 - 1
INT32_MIN = -(2**31)

WAYPOINT = mavlink.MAV_CMD_NAV_WAYPOINT
FENCE_CIRCLE = mavlink.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION

FRAME_LOCAL = mavlink.MAV_FRAME_LOCAL_NED
#: Frames whose x, y are metres (scale 1e4); every other frame's are degrees (scale 1e7).
LOCAL_FRAMES = (mavlink.MAV_FRAME_LOCAL_NED, mavlink.MAV_FRAME_LOCAL_ENU, mavlink.MAV_FRAME_LOCAL_OFFSET_NED)
AMSL_FRAMES = (mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_FRAME_GLOBAL_INT)
RELATIVE_FRAMES = (mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT)
GLOBAL_FRAMES = (*AMSL_FRAMES, *RELATIVE_FRAMES)
#: The frames the vehicle takes.
VEHICLE_FRAMES = (FRAME_LOCAL, *GLOBAL_FRAMES)
#: Legacy float MISSION_ITEM frames and the MISSION_ITEM_INT twins they are stored as.
LEGACY_FRAME_TO_INT = {
    mavlink.MAV_FRAME_GLOBAL: mavlink.MAV_FRAME_GLOBAL_INT,
    mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT: mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
}
INT_FRAME_TO_LEGACY = {v: k for k, v in LEGACY_FRAME_TO_INT.items()}


class EncodingError(ValueError):
    """A value that MISSION_ITEM_INT cannot carry (the message names it and why)."""


@dataclass(frozen=True)
class MissionItem:
    """One mission item in MISSION_ITEM_INT encoding (x, y integers; z float)."""

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

    def key(self) -> tuple[str, ...]:
        """A comparison key in which NaN equals NaN."""
        return tuple(repr(v) for v in astuple(self))

    def to_json(self) -> dict[str, float | int | None]:
        """JSON-safe dict (NaN as None)."""
        return {k: (None if isinstance(v, float) and math.isnan(v) else v) for k, v in self.__dict__.items()}

    @classmethod
    def from_json(cls, d: dict[str, float | int | None]) -> MissionItem:
        def f(name: str) -> float:
            v = d[name]
            return math.nan if v is None else float(v)

        return cls(
            frame=int(d["frame"] or 0),
            command=int(d["command"] or 0),
            param1=f("param1"),
            param2=f("param2"),
            param3=f("param3"),
            param4=f("param4"),
            x=int(d["x"] or 0),
            y=int(d["y"] or 0),
            z=f("z"),
            autocontinue=int(d.get("autocontinue") or 0),
        )


@dataclass(frozen=True)
class Origin:
    """The geodetic origin of the local NED frame (GPS_GLOBAL_ORIGIN): degrees, metres AMSL."""

    lat_deg: float
    lon_deg: float
    alt_m: float = 0.0


# ---- scales ----------------------------------------------------------------------------------------
def scale_of(frame: int) -> float:
    """The x/y scale of ``frame``: :data:`LOCAL_SCALE` for the local frames, else :data:`GLOBAL_SCALE`."""
    return LOCAL_SCALE if frame in LOCAL_FRAMES else GLOBAL_SCALE


def fits_int32(value: int) -> bool:
    return INT32_MIN <= value <= INT32_MAX


def fits_local(value_m: float) -> bool:
    """True if a metre value is a local x or y MISSION_ITEM_INT can carry (finite, x * 1e4 an int32)."""
    return math.isfinite(value_m) and fits_int32(round(value_m * LOCAL_SCALE))


def to_int(value: float, scale: float, what: str) -> int:
    """``round(value * scale)``, an x or y of MISSION_ITEM_INT; :class:`EncodingError` naming ``what`` if
    the value is not a number or does not fit an int32."""
    if not math.isfinite(value):
        raise EncodingError(f"{what} must be a number, got {value!r}")
    scaled = round(value * scale)
    if not fits_int32(scaled):
        raise EncodingError(f"{what} = {value!r} does not fit MISSION_ITEM_INT")
    return scaled


def local_problem(name: str, value_m: float) -> str | None:
    """Why a local x or y (``name``, metres) cannot be sent as MISSION_ITEM_INT, or None."""
    if fits_local(value_m):
        return None
    return f"{name} {value_m:g} m is not encodable on MAVLink (int32 of m*1e4)"


# ---- projection ------------------------------------------------------------------------------------
def global_to_local(lat_deg: float, lon_deg: float, origin: Origin) -> tuple[float, float]:
    """(x north, y east) in metres of a position (degrees) about ``origin`` (module docstring)."""
    dlon_deg = (lon_deg - origin.lon_deg + 180.0) % 360.0 - 180.0
    x_m = math.radians(lat_deg - origin.lat_deg) * EARTH_RADIUS_M
    y_m = math.radians(dlon_deg) * EARTH_RADIUS_M * math.cos(math.radians(origin.lat_deg))
    return x_m, y_m


def local_to_global(x_m: float, y_m: float, origin: Origin) -> tuple[float, float]:
    """(lat_deg, lon_deg) of a local NED point: the inverse of :func:`global_to_local` (lon 0 at a pole)."""
    lat_deg = origin.lat_deg + math.degrees(x_m / EARTH_RADIUS_M)
    east = EARTH_RADIUS_M * math.cos(math.radians(origin.lat_deg))
    lon_deg = origin.lon_deg + (math.degrees(y_m / east) if east > 1.0 else 0.0)
    return lat_deg, (lon_deg + 180.0) % 360.0 - 180.0


def item_position(item: MissionItem, origin: Origin | None) -> tuple[float, float, float] | None:
    """(x_m north, y_m east, depth_m) of an item as the vehicle reads it: a local NED item as it is; a
    global one projected about ``origin`` with depth = -altitude (relative frames) or origin altitude -
    altitude (AMSL frames). None for a global item without an origin, or a frame the vehicle does not take.
    """
    if item.frame == FRAME_LOCAL:
        return item.x / LOCAL_SCALE, item.y / LOCAL_SCALE, item.z
    if item.frame not in GLOBAL_FRAMES or origin is None:
        return None
    x_m, y_m = global_to_local(item.x / GLOBAL_SCALE, item.y / GLOBAL_SCALE, origin)
    depth_m = -(item.z - origin.alt_m) if item.frame in AMSL_FRAMES else -item.z
    return x_m, y_m, depth_m


# ---- home ------------------------------------------------------------------------------------------
def is_home_placeholder(item: MissionItem) -> bool:
    """True if ``item``, first in a MISSION plan, is the home placeholder (module docstring)."""
    return item.command == WAYPOINT and item.frame in AMSL_FRAMES


def home_offset(items: Sequence[MissionItem]) -> int:
    """1 if the MISSION plan ``items`` starts with the home placeholder (seq = goal index + 1), else 0."""
    return 1 if items and is_home_placeholder(items[0]) else 0


def home_item(lat_deg: float, lon_deg: float, alt_m: float) -> MissionItem:
    """The home placeholder for a home position (degrees, metres AMSL), as QGC sends ArduPilot its home."""
    return MissionItem(
        frame=mavlink.MAV_FRAME_GLOBAL,
        command=WAYPOINT,
        param1=0.0,
        param2=0.0,
        param3=0.0,
        param4=0.0,
        x=round(lat_deg * GLOBAL_SCALE),
        y=round(lon_deg * GLOBAL_SCALE),
        z=float(alt_m),
    )


# ---- plain items <-> MISSION_ITEM_INT ----------------------------------------------------------------
def goal_item(goal: GoalPose) -> MissionItem:
    """The local-frame waypoint of a goal (yaw None -> param4 NaN; param2 its acceptance radius, 0 = the
    vehicle's default); :class:`EncodingError` if x or y is not encodable."""
    return MissionItem(
        frame=FRAME_LOCAL,
        command=WAYPOINT,
        param1=0.0,
        param2=float(goal.radius_m),
        param3=0.0,
        param4=math.nan if goal.yaw_deg is None else float(goal.yaw_deg),
        x=to_int(goal.x_m, LOCAL_SCALE, "x"),
        y=to_int(goal.y_m, LOCAL_SCALE, "y"),
        z=float(goal.depth_m),
    )


def _circle(frame: int, x: int, y: int, radius_m: float, autocontinue: int = 1) -> MissionItem:
    """A circle exclusion fence item (MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION, param1 the radius, m)."""
    return MissionItem(frame, FENCE_CIRCLE, float(radius_m), 0.0, 0.0, 0.0, x, y, 0.0, autocontinue)


def obstacle_item(circle: Circle) -> MissionItem:
    """The local-frame fence circle of an obstacle; :class:`EncodingError` if x or y is not encodable."""
    x, y = to_int(circle.x_m, LOCAL_SCALE, "x"), to_int(circle.y_m, LOCAL_SCALE, "y")
    return _circle(FRAME_LOCAL, x, y, circle.radius_m)


def fence_circle_item(lat_deg: float, lon_deg: float, radius_m: float) -> MissionItem:
    """The fence item of a QGC exclusion circle, as QGC uploads it (``GeoFenceManager::sendToVehicle``):
    ``MAV_FRAME_GLOBAL``, autocontinue 0."""
    x, y = round(lat_deg * GLOBAL_SCALE), round(lon_deg * GLOBAL_SCALE)
    return _circle(mavlink.MAV_FRAME_GLOBAL, x, y, radius_m, autocontinue=0)


def radius_of_item(item: MissionItem) -> float:
    """A waypoint's acceptance radius as sent (param2, m): NaN reads as 0, the vehicle's default; any other
    value as it is (the vehicle's validator judges it)."""
    return 0.0 if math.isnan(item.param2) else item.param2


def goal_of_item(item: MissionItem, origin: Origin | None) -> GoalPose | None:
    """The goal a waypoint item stands for (:func:`item_position`; param4 NaN -> yaw None, degrees as
    sent, not wrapped; param2 the acceptance radius, :func:`radius_of_item`); None where
    :func:`item_position` is."""
    where = item_position(item, origin)
    if where is None:
        return None
    yaw_deg = None if math.isnan(item.param4) else item.param4
    return GoalPose(*where, yaw_deg=yaw_deg, radius_m=radius_of_item(item))


def circle_of_item(item: MissionItem, origin: Origin | None) -> Circle | None:
    """The obstacle circle a fence item stands for (param1 the radius); None where :func:`item_position`
    is."""
    where = item_position(item, origin)
    return None if where is None else Circle(where[0], where[1], item.param1)


__all__ = [
    "AMSL_FRAMES",
    "EARTH_RADIUS_M",
    "FENCE_CIRCLE",
    "FRAME_LOCAL",
    "GLOBAL_FRAMES",
    "GLOBAL_SCALE",
    "INT32_MAX",
    "INT32_MIN",
    "INT_FRAME_TO_LEGACY",
    "LEGACY_FRAME_TO_INT",
    "LOCAL_FRAMES",
    "LOCAL_SCALE",
    "RELATIVE_FRAMES",
    "VEHICLE_FRAMES",
    "WAYPOINT",
    "EncodingError",
    "MissionItem",
    "Origin",
    "circle_of_item",
    "fence_circle_item",
    "fits_int32",
    "fits_local",
    "global_to_local",
    "goal_item",
    "goal_of_item",
    "home_item",
    "home_offset",
    "is_home_placeholder",
    "item_position",
    "local_problem",
    "local_to_global",
    "obstacle_item",
    "radius_of_item",
    "scale_of",
    "to_int",
]
