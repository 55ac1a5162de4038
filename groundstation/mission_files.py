"""Mission files for ``auv-gcs``: YAML goal poses, QGC WPL 110 plain text and QGroundControl ``.plan`` JSON.

:func:`load` tells them apart by content; :func:`to_yaml`, :func:`to_wpl` and :func:`to_plan` write them
(:func:`dump` by format name, :func:`format_for` picks one from a file name). Items are
:class:`auv_common.mission_items.MissionItem` in MISSION_ITEM_INT encoding: frames, scales, the projection
and the home rule are :mod:`auv_common.mission_items`, the encoding the vehicle uses too, and the YAML format
is :mod:`auv_common.mission_yaml`, the parser the vehicle's ``--mission`` and campaign specs use.

YAML::

    goals:                      # MAV_CMD_NAV_WAYPOINT in MAV_FRAME_LOCAL_NED
      - {x_m: 20.0, y_m: 5.0, depth_m: 2.0, yaw_deg: 90}   # yaw_deg optional (null/absent = planner's choice)
      - {x_m: 40.0, y_m: 5.0, depth_m: 2.0, radius_m: 3}   # radius_m (param2) optional (absent = default)
    obstacles:                  # MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION
      - {x_m: 10.0, y_m: 2.0, radius_m: 3.0}

QGC WPL 110 (https://mavlink.io/en/file_formats/): ``seq current frame command p1 p2 p3 p4 x y z autocont``
tab separated. Local frames: x, y in metres, z = depth; global frames: lat, lon in degrees, z = altitude.
A first line with frame 0 and current = 1 is the home position (MAVProxy/ArduPilot convention, see *Home*).
Fence items (command 5001..5004) go to the fence plan, everything else to the mission plan.

QGC plan (https://docs.qgroundcontrol.com/master/en/qgc-dev-guide/file_formats/plan.html; the keys QGC
requires are those of its ``MissionController::_loadJsonMissionFileV2``, ``MissionItem::load``,
``GeoFenceController::load`` and ``QGCFenceCircle::loadFromJson``): ``fileType "Plan"``, ``version 1``,
``mission`` (``version 2``, ``firmwareType``, ``plannedHomePosition [lat, lon, alt]``, ``items``),
optional ``geoFence`` (``version 2``, ``circles``, ``polygons``) and ``rallyPoints``.

- A ``SimpleItem`` is one MAVLink item, as QGC uploads it: ``command``, ``frame``, ``params`` = param1..4,
  x (lat), y (lon), z; ``null`` = NaN; ``autoContinue``. QGC's older form with ``coordinate [lat, lon, alt]``
  and four params is read too (a waypoint's param2, QGC's "Acceptance radius", is the goal's radius_m:
  0 = the vehicle's default). ``MAV_CMD_NAV_WAYPOINT`` is a goal, ``MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION`` an
  obstacle (as in our WPL files).
- A ``geoFence`` exclusion circle is the fence item QGC uploads for it (``GeoFenceManager::sendToVehicle``):
  ``MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION`` in ``MAV_FRAME_GLOBAL``, param1 = radius (m), z = 0, autocontinue 0.
- ``plannedHomePosition`` is not a goal (see *Home*).
- Refused, each with a :class:`MissionFileError` naming the item and why, never dropped: another command
  (the vehicle flies waypoints only), a frame the vehicle does not take, a ``ComplexItem`` (survey, corridor
  scan, structure scan, landing pattern), an inclusion circle, a polygon, a breach return point, rally
  points. The vehicle judges what is left (area, depth, counts, a goal's yaw NaN or within [-360, 360] deg:
  its mission validator, the one owner of those rules; its refusal, e.g. MAV_MISSION_INVALID_PARAM4
  "goal 1: yaw 999 deg is outside [-360, 360] deg", is what ``auv-gcs upload`` prints).

Positions and z, in every format exactly as the vehicle reads them (the shared
:func:`auv_common.mission_items.item_position`): ``MAV_FRAME_LOCAL_NED`` x, y = metres north, east and
z = depth (m, down positive);
the global frames lat, lon in degrees and z = altitude (m, up positive: depth = -altitude; relative to
the vehicle's origin in ``MAV_FRAME_GLOBAL_RELATIVE_ALT(_INT)`` (QGC's is relative to its planned home:
the same with the home at the origin's surface), above mean sea level in ``MAV_FRAME_GLOBAL(_INT)``).
So a QGC waypoint 2 m under the surface has altitude -2 in QGC's default relative frame (as ArduSub's).
No file converts between frames (a file does not know the vehicle's origin; the map, which hears it,
draws global items in metres with :func:`local_ned`, the vehicle's projection). A local-frame plan is valid
JSON QGC opens, but QGC draws its metres as degrees: plan in a global frame to edit in QGC. A local-frame
obstacle has no QGC circle (a circle is lat/lon only), so :func:`to_plan` writes it as a ``SimpleItem``.

Home. The vehicle takes a ``MAV_CMD_NAV_WAYPOINT`` at seq 0 in ``MAV_FRAME_GLOBAL`` / ``MAV_FRAME_GLOBAL_INT``
as its home placeholder (ArduPilot's convention) and does not fly it (:func:`is_home_placeholder`). Writing,
such a leading item is the file's home (the WPL home line, ``plannedHomePosition``), not a goal. Reading, the
file's home is put back in front as that placeholder only where the first goal is itself a waypoint in
an AMSL global frame, which the vehicle would otherwise take as its home and not fly (QGC does the same
when it uploads to ArduPilot); else it is dropped. So ``load(to_plan(x)) == x`` and ``load(to_wpl(x)) == x``
for every plan that does not start with a home placeholder, and the goals flown are the same for those that
do; ``load(to_yaml(x)) == x`` for local-frame goals and obstacles made by :func:`goal_item` /
:func:`obstacle_item`.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import yaml
from pymavlink.dialects.v20 import common as mavlink

from auv_common import mission_items as enc
from auv_common import mission_yaml
from auv_common.mission_items import (  # the one mission item encoding (the vehicle's too)
    GLOBAL_FRAMES,
    GLOBAL_SCALE,
    LOCAL_FRAMES,
    LOCAL_SCALE,
    VEHICLE_FRAMES,
    Origin,
    fence_circle_item,
    home_item,
)
from auv_common.mission_items import MissionItem as Item
from auv_common.mission_yaml import NESTED_TOO_DEEP, Circle, GoalPose

FLOAT32_MAX = 3.4028234663852886e38  # MAVLink's float fields
FENCE_COMMANDS = range(5000, 5005)

#: Output formats of :func:`dump`, and the one each file suffix means (:func:`format_for`).
FORMATS = ("plan", "wpl", "yaml")
SUFFIX_FORMATS = {".plan": "plan", ".waypoints": "wpl", ".txt": "wpl", ".yaml": "yaml", ".yml": "yaml"}

PLAN_GROUND_STATION = "auv-gcs"
#: QGC's speeds for its time estimates only (m/s; not read back): the vehicle's guidance default speed.
PLAN_SPEED_MPS = 1.0


class MissionFileError(ValueError):
    """A mission file that cannot be read; the message names the file and the place."""


def goal_item(x_m: float, y_m: float, depth_m: float, yaw_deg: float | None, radius_m: float = 0.0) -> Item:
    """The local-frame waypoint of a goal (:func:`auv_common.mission_items.goal_item`; ``radius_m`` its
    acceptance radius, param2, 0 = the vehicle's default); a position that MISSION_ITEM_INT cannot carry is
    a :class:`MissionFileError`."""
    try:
        return enc.goal_item(GoalPose(x_m, y_m, depth_m, yaw_deg, radius_m))
    except enc.EncodingError as exc:
        raise MissionFileError(str(exc)) from None


def obstacle_item(x_m: float, y_m: float, radius_m: float) -> Item:
    """The local-frame fence circle of an obstacle (:func:`auv_common.mission_items.obstacle_item`)."""
    try:
        return enc.obstacle_item(Circle(x_m, y_m, radius_m))
    except enc.EncodingError as exc:
        raise MissionFileError(str(exc)) from None


def local_ned(item: Item, origin: Origin | None) -> tuple[float, float, float] | None:
    """(x_m north, y_m east, depth_m) of an item as the vehicle reads it
    (:func:`auv_common.mission_items.item_position`); None for a global item without an origin, or another
    frame."""
    return enc.item_position(item, origin)


def load_yaml(path: Path) -> tuple[list[Item], list[Item]]:
    """(mission items, fence items) of our YAML mission file (:mod:`auv_common.mission_yaml`, the one parser
    of the format: the vehicle's ``--mission`` and campaign specs read it too), local frame."""
    try:
        plan = mission_yaml.load_plan(path)
    except mission_yaml.MissionYamlError as exc:
        raise MissionFileError(f"{path}: {exc}") from None
    goals, obstacles = [], []
    for kind, i, item in [("goals", i, g) for i, g in enumerate(plan.goals)] + [
        ("obstacles", i, o) for i, o in enumerate(plan.obstacles)
    ]:
        try:
            if isinstance(item, GoalPose):
                goals.append(enc.goal_item(item))
            else:
                obstacles.append(enc.obstacle_item(item))
        except enc.EncodingError as exc:
            raise MissionFileError(f"{path}: {kind}[{i}]: {exc}") from None
    return goals, obstacles


def is_home_placeholder(goals: Sequence[Item]) -> bool:
    """True if the first item of a MISSION plan is what the vehicle takes as its home placeholder and does
    not fly (:func:`auv_common.mission_items.is_home_placeholder`, ArduPilot's convention)."""
    return enc.home_offset(goals) == 1


def _with_home(goals: list[Item], home: Item | None) -> list[Item]:
    """The goals read from a file, with its home in front where the vehicle needs it (module docstring)."""
    if home is not None and goals and enc.is_home_placeholder(goals[0]):
        return [home, *goals]
    return goals


def _file_home(
    goals: Sequence[Item], fences: Sequence[Item], home: tuple[float, float, float] | None
) -> tuple[Item | None, tuple[float, float, float], list[Item]]:
    """(the home placeholder or None, the file's home (lat deg, lon deg, alt m), the goals to write).

    The home is ``home`` if given, else the placeholder's position, else the first global item's lat/lon at
    altitude 0 (the surface), else (0, 0, 0)."""
    placeholder = goals[0] if is_home_placeholder(goals) else None
    rest = list(goals[1:] if placeholder is not None else goals)
    if home is not None:
        where = (float(home[0]), float(home[1]), float(home[2]))
    elif placeholder is not None:
        where = (placeholder.x / GLOBAL_SCALE, placeholder.y / GLOBAL_SCALE, placeholder.z)
    else:
        first = next((it for it in [*rest, *fences] if it.frame in GLOBAL_FRAMES), None)
        where = (
            (first.x / GLOBAL_SCALE, first.y / GLOBAL_SCALE, 0.0) if first is not None else (0.0, 0.0, 0.0)
        )
    return placeholder, where, rest


def _nan(v: float) -> float:
    """NaN as the one ``math.nan`` object, so that items read from files compare equal."""
    return math.nan if math.isnan(v) else v


def _read(path: Path) -> str:
    try:
        return path.read_text(encoding="utf-8")
    except OSError as exc:
        raise MissionFileError(f"{path}: {exc}") from None


def load_wpl(path: Path) -> tuple[list[Item], list[Item]]:
    lines = _read(path).splitlines()
    if not lines or not lines[0].startswith("QGC WPL 110"):
        raise MissionFileError(f"{path}: not a QGC WPL 110 file")
    goals: list[Item] = []
    fences: list[Item] = []
    home: Item | None = None
    for n, line in enumerate(lines[1:], start=2):
        if not line.strip():
            continue
        f = line.split()
        if len(f) != 12:
            raise MissionFileError(f"{path}:{n}: expected 12 fields, got {len(f)}")
        try:
            seq, current, frame, command = (int(v) for v in f[:4])
            p1, p2, p3, p4, x, y, z = (_nan(float(v)) for v in f[4:11])
            autocontinue = int(f[11])
        except ValueError:
            raise MissionFileError(f"{path}:{n}: bad number") from None
        local = frame in LOCAL_FRAMES
        scale = LOCAL_SCALE if local else GLOBAL_SCALE
        place = f"{path}:{n}"
        xi = _scaled(place, x, scale, "x" if local else "x (latitude)")
        yi = _scaled(place, y, scale, "y" if local else "y (longitude)")
        item = Item(frame, command, p1, p2, p3, p4, xi, yi, z, autocontinue)
        if seq == 0 and current == 1 and frame == mavlink.MAV_FRAME_GLOBAL:
            home = item  # the home line: not a goal
            continue
        (fences if command in FENCE_COMMANDS else goals).append(item)
    return _with_home(goals, home), fences


# ---- QGC plan ---------------------------------------------------------------------------------------
_KINDS: dict[str, tuple[str, Any]] = {
    "object": ("an object", lambda v: isinstance(v, dict)),
    "array": ("an array", lambda v: isinstance(v, list)),
    "string": ("a string", lambda v: isinstance(v, str)),
    "boolean": ("true or false", lambda v: isinstance(v, bool)),
    "number": ("a number", lambda v: isinstance(v, int | float) and not isinstance(v, bool)),
    "integer": (
        "an integer",
        lambda v: (
            (isinstance(v, int) and not isinstance(v, bool)) or (isinstance(v, float) and v.is_integer())
        ),
    ),
}


def _short(v: Any) -> str:
    text = json.dumps(v, allow_nan=True)
    return text if len(text) <= 40 else text[:37] + "..."


def _field(path: Path, d: dict[str, Any], key: str, where: str, kind: str) -> Any:
    """``d[key]``, which must be of ``kind`` (a key of :data:`_KINDS`); ``where`` names ``d`` in the file."""
    place = f"{where}: " if where else ""
    if key not in d:
        raise MissionFileError(f"{path}: {place}missing {key!r}")
    v = d[key]
    name, ok = _KINDS[kind]
    if not ok(v):
        raise MissionFileError(f"{path}: {place}{key} must be {name}, got {_short(v)}")
    return v


def _object(path: Path, v: Any, where: str) -> dict[str, Any]:
    if not isinstance(v, dict):
        raise MissionFileError(f"{path}: {where}: expected an object, got {_short(v)}")
    return v


def _coordinate(path: Path, v: Any, where: str, sizes: tuple[int, ...]) -> list[float]:
    """A QGC coordinate ``[lat, lon]`` or ``[lat, lon, alt]`` (``sizes``: the lengths allowed)."""
    ok = isinstance(v, list) and len(v) in sizes and all(_KINDS["number"][1](c) for c in v)
    if not ok or not all(math.isfinite(c) for c in v):
        shape = " or ".join(("[lat, lon]", "[lat, lon, alt]")[n - 2] for n in sizes)
        raise MissionFileError(f"{path}: {where}: expected {shape} (numbers), got {_short(v)}")
    return [float(c) for c in v]


def _name(enum: str, value: int) -> str:
    entry = mavlink.enums[enum].get(value)
    return f"{value} ({entry.name})" if entry is not None else f"{value} (unknown)"


def _scaled(place: str, value: float, scale: float, what: str) -> int:
    """A MISSION_ITEM_INT x or y from a file's float (metres or degrees), which must fit an int32: the one
    check of every reader (``place`` names the file and the place in it, ``what`` the number)."""
    if not math.isfinite(value):
        raise MissionFileError(f"{place}: {what} must be a number, got {_short(value)}")
    scaled = round(value * scale)
    if not enc.fits_int32(scaled):
        raise MissionFileError(f"{place}: {what} = {value!r} does not fit MISSION_ITEM_INT")
    return scaled


def _simple_item(path: Path, d: dict[str, Any], where: str) -> Item:
    """The MAVLink item of a QGC ``SimpleItem`` (as QGC uploads it), refused unless the vehicle takes it."""
    command = int(_field(path, d, "command", where, "integer"))
    frame = int(_field(path, d, "frame", where, "integer"))
    params = list(_field(path, d, "params", where, "array"))
    if "coordinate" in d:  # QGC's older form: four params and [lat, lon, alt]
        if len(params) != 4:
            raise MissionFileError(f"{path}: {where}: params must hold 4 values with a coordinate")
        params += _coordinate(path, d["coordinate"], f"{where}.coordinate", (3,))
    elif len(params) != 7:
        raise MissionFileError(f"{path}: {where}: params must hold 7 values, got {len(params)}")
    values: list[float] = []
    for i, v in enumerate(params):
        if v is not None and not _KINDS["number"][1](v):
            raise MissionFileError(f"{path}: {where}: params[{i}] must be a number or null, got {_short(v)}")
        values.append(math.nan if v is None else _nan(float(v)))
    autocontinue = _field(path, d, "autoContinue", where, "boolean")
    if command not in (mavlink.MAV_CMD_NAV_WAYPOINT, mavlink.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION):
        raise MissionFileError(
            f"{path}: {where}: command {_name('MAV_CMD', command)} is not supported: the vehicle flies "
            "MAV_CMD_NAV_WAYPOINT goals and takes MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION obstacles only"
        )
    if frame not in VEHICLE_FRAMES:
        raise MissionFileError(
            f"{path}: {where}: frame {_name('MAV_FRAME', frame)} is not supported: the vehicle takes "
            "MAV_FRAME_LOCAL_NED, MAV_FRAME_GLOBAL(_INT) and MAV_FRAME_GLOBAL_RELATIVE_ALT(_INT)"
        )
    scale = LOCAL_SCALE if frame == mavlink.MAV_FRAME_LOCAL_NED else GLOBAL_SCALE
    x_name, y_name = ("x", "y") if scale == LOCAL_SCALE else ("latitude", "longitude")
    x = _scaled(f"{path}: {where}", values[4], scale, f"params[4] ({x_name})")
    y = _scaled(f"{path}: {where}", values[5], scale, f"params[5] ({y_name})")
    p1, p2, p3, p4 = values[:4]
    return Item(frame, command, p1, p2, p3, p4, x, y, values[6], int(autocontinue))


def _plan_items(path: Path, mission: dict[str, Any]) -> tuple[list[Item], list[Item]]:
    goals: list[Item] = []
    fences: list[Item] = []
    for i, raw in enumerate(_field(path, mission, "items", "mission", "array")):
        where = f"mission.items[{i}]"
        d = _object(path, raw, where)
        kind = _field(path, d, "type", where, "string")
        if kind == "ComplexItem":
            what = d.get("complexItemType", "?")
            raise MissionFileError(
                f"{path}: {where}: ComplexItem {what!r} is not supported: the vehicle takes single waypoints "
                "(SimpleItem) only"
            )
        if kind != "SimpleItem":
            raise MissionFileError(f"{path}: {where}: unknown item type {kind!r}")
        item = _simple_item(path, d, where)
        (fences if item.command == mavlink.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION else goals).append(item)
    return goals, fences


def _plan_fence(path: Path, fence: dict[str, Any]) -> list[Item]:
    version = fence.get("version")
    if version is None or version == 1:  # QGC ignores a fence before version 2: so do we, if it is empty
        if any(fence.get(k) for k in ("polygon", "polygons", "circles")):
            raise MissionFileError(
                f"{path}: geoFence: a version {_short(version)} fence is not supported (QGC ignores it; 2 is)"
            )
        return []
    if version != 2:
        raise MissionFileError(f"{path}: geoFence: version {_short(version)} is not supported (2 is)")
    circles = _field(path, fence, "circles", "geoFence", "array")
    polygons = _field(path, fence, "polygons", "geoFence", "array")
    for i, raw in enumerate(polygons):
        d = _object(path, raw, f"geoFence.polygons[{i}]")
        kind = "an inclusion" if d.get("inclusion", True) else "an exclusion"
        raise MissionFileError(
            f"{path}: geoFence.polygons[{i}]: {kind} polygon is not supported: the vehicle takes exclusion "
            "circles only"
        )
    if "breachReturn" in fence:
        raise MissionFileError(f"{path}: geoFence.breachReturn: a fence return point is not supported")
    items = []
    for i, raw in enumerate(circles):
        where = f"geoFence.circles[{i}]"
        d = _object(path, raw, where)
        circle = _field(path, d, "circle", where, "object")
        center = _coordinate(path, circle.get("center"), f"{where}.circle.center", (2, 3))
        radius = float(_field(path, circle, "radius", f"{where}.circle", "number"))
        if _field(path, d, "inclusion", where, "boolean"):
            raise MissionFileError(
                f"{path}: {where}: an inclusion circle is not supported: the vehicle takes exclusion circles "
                "(obstacles) only"
            )
        items.append(fence_circle_item(center[0], center[1], radius))
    return items


def _json_constant(name: str) -> float:
    if name == "NaN":
        return math.nan
    raise ValueError(f"{name} is not a number a mission can hold")


def _parse_json(path: Path, text: str) -> Any:
    try:
        return json.loads(text, parse_constant=_json_constant)
    except json.JSONDecodeError as exc:
        raise MissionFileError(
            f"{path}: not valid JSON (line {exc.lineno}, column {exc.colno}: {exc.msg})"
        ) from None
    except ValueError as exc:
        raise MissionFileError(f"{path}: not valid JSON ({exc})") from None
    except RecursionError:
        raise MissionFileError(f"{path}: not valid JSON ({NESTED_TOO_DEEP})") from None


def _load_plan_data(path: Path, data: Any) -> tuple[list[Item], list[Item]]:
    if not isinstance(data, dict):
        raise MissionFileError(f"{path}: expected a JSON object (a QGC plan), got {_short(data)}")
    if data.get("fileType") != "Plan":
        raise MissionFileError(f'{path}: fileType is {_short(data.get("fileType"))}, not "Plan" (a QGC plan)')
    if _field(path, data, "version", "", "integer") != 1:
        raise MissionFileError(f"{path}: version {_short(data['version'])} is not supported (1 is)")
    mission = _field(path, data, "mission", "", "object")
    if _field(path, mission, "version", "mission", "integer") != 2:
        raise MissionFileError(
            f"{path}: mission: version {_short(mission['version'])} is not supported (2 is)"
        )
    _field(path, mission, "firmwareType", "mission", "integer")
    where = "mission.plannedHomePosition"
    home = _coordinate(path, _field(path, mission, "plannedHomePosition", "mission", "array"), where, (3,))
    if abs(home[0]) > 90.0 or abs(home[1]) > 180.0:
        raise MissionFileError(f"{path}: {where}: latitude / longitude out of range, got {_short(home)}")
    goals, fences = _plan_items(path, mission)
    if "geoFence" in data:
        fences += _plan_fence(path, _object(path, data["geoFence"], "geoFence"))
    if "rallyPoints" in data:
        rally = _object(path, data["rallyPoints"], "rallyPoints")
        if rally.get("points"):
            raise MissionFileError(f"{path}: rallyPoints.points: rally points are not supported")
    return _with_home(goals, home_item(*home)), fences


def load_plan(path: Path) -> tuple[list[Item], list[Item]]:
    """(mission items, fence items) of a QGroundControl ``.plan`` file (module docstring)."""
    return _load_plan_data(path, _parse_json(path, _read(path)))


def load(path: str | Path) -> tuple[list[Item], list[Item]]:
    """(mission items, fence items) from a YAML, QGC WPL 110 or QGC plan file, told apart by content: the
    WPL header, else JSON with a ``fileType`` (or a ``.plan`` file) is a plan, else YAML. Every param and z
    must fit MAVLink's float32 (1e300 would be refused at the upload with a traceback)."""
    p = Path(path)
    goals, fences = _load_any(p)
    for kind, items in (("goal", goals), ("fence item", fences)):
        for i, it in enumerate(items):
            for name in ("param1", "param2", "param3", "param4", "z"):
                v = getattr(it, name)
                if math.isfinite(v) and abs(v) > FLOAT32_MAX:
                    raise MissionFileError(f"{p}: {kind} {i}: {name} = {v!r} does not fit MAVLink's float32")
    return goals, fences


def _load_any(p: Path) -> tuple[list[Item], list[Item]]:
    text = _read(p)
    if text.startswith("QGC WPL"):
        return load_wpl(p)
    if p.suffix.lower() == ".plan":
        return load_plan(p)
    if text.lstrip().startswith("{"):
        try:
            data = json.loads(text, parse_constant=_json_constant)
        except ValueError:
            data = None  # not JSON: a YAML flow mapping, say
        except RecursionError:
            raise MissionFileError(f"{p}: {NESTED_TOO_DEEP}") from None
        if isinstance(data, dict) and "fileType" in data:
            return _load_plan_data(p, data)
    return load_yaml(p)


def format_for(path: Path | None) -> str:
    """The output format for ``path`` from its suffix (:data:`SUFFIX_FORMATS`); yaml for stdout (None) and
    other suffixes."""
    return "yaml" if path is None else SUFFIX_FORMATS.get(path.suffix.lower(), "yaml")


def dump(
    fmt: str, goals: list[Item], fences: list[Item], home: tuple[float, float, float] | None = None
) -> str:
    """The text of a plan in format ``fmt`` (one of :data:`FORMATS`); ``home`` as in :func:`to_plan` (YAML
    has none)."""
    if fmt == "plan":
        return to_plan(goals, fences, home)
    if fmt == "wpl":
        return to_wpl(goals, fences, home)
    if fmt == "yaml":
        return to_yaml(goals, fences)
    raise ValueError(f"unknown mission file format {fmt!r} (one of {', '.join(FORMATS)})")


def to_yaml(goals: list[Item], fences: list[Item]) -> str:
    """YAML text for downloaded plans (local-frame items in metres; other frames as raw items)."""
    out: dict[str, list[dict[str, Any]]] = {"goals": [], "obstacles": []}
    for it in goals:
        if it.frame == mavlink.MAV_FRAME_LOCAL_NED:
            yaw = None if math.isnan(it.param4) else round(it.param4, 6)
            goal: dict[str, Any] = {
                "x_m": it.x / LOCAL_SCALE,
                "y_m": it.y / LOCAL_SCALE,
                "depth_m": round(it.z, 6),
                "yaw_deg": yaw,
            }
            radius_m = enc.radius_of_item(it)
            if radius_m != 0.0:  # its own acceptance radius (0: the vehicle's default, left out)
                goal["radius_m"] = round(radius_m, 6)
            out["goals"].append(goal)
        else:
            out["goals"].append({"raw": list(it.__dict__.values())})
    for it in fences:
        if it.frame == mavlink.MAV_FRAME_LOCAL_NED:
            out["obstacles"].append(
                {"x_m": it.x / LOCAL_SCALE, "y_m": it.y / LOCAL_SCALE, "radius_m": it.param1}
            )
        else:  # lat/lon are no metres
            out["obstacles"].append({"raw": list(it.__dict__.values())})
    return yaml.safe_dump(out, sort_keys=False)


def to_wpl(goals: list[Item], fences: list[Item], home: tuple[float, float, float] | None = None) -> str:
    """QGC WPL 110 text: the home line first (QGC, Mission Planner and MAVProxy read line 0 as home), then
    the goals and the fence items. Home: ``home`` (lat deg, lon deg, alt m AMSL) if given, else a leading
    home placeholder of ``goals`` (written as it is), else the first global item's lat/lon at altitude 0,
    else 0/0/0 (as MAVProxy writes an unknown home)."""
    placeholder, (lat, lon, alt), rest = _file_home(goals, fences, home)
    if placeholder is not None and home is None:
        first = placeholder
    else:
        first = home_item(lat, lon, alt)
    lines = ["QGC WPL 110"]
    for seq, it in enumerate([first, *rest, *fences]):
        scale = LOCAL_SCALE if it.frame in LOCAL_FRAMES else GLOBAL_SCALE
        vals = [it.param1, it.param2, it.param3, it.param4, it.x / scale, it.y / scale, it.z]
        current = "1" if seq == 0 else "0"
        lines.append(
            "\t".join(
                [str(seq), current, str(it.frame), str(it.command), *map(repr, vals), str(it.autocontinue)]
            )
        )
    return "\n".join(lines) + "\n"


def _json_number(v: float) -> float | None:
    return None if math.isnan(v) else v


def _simple_item_json(it: Item, jump_id: int) -> dict[str, Any]:
    scale = LOCAL_SCALE if it.frame in LOCAL_FRAMES else GLOBAL_SCALE
    params = [it.param1, it.param2, it.param3, it.param4, it.x / scale, it.y / scale, it.z]
    return {
        "autoContinue": bool(it.autocontinue),
        "command": it.command,
        "doJumpId": jump_id,
        "frame": it.frame,
        "params": [_json_number(v) for v in params],
        "type": "SimpleItem",
    }


def _is_zero(v: float) -> bool:
    return v == 0.0 and math.copysign(1.0, v) > 0.0  # +0.0 only: -0.0 would read back as +0.0


def _is_qgc_circle(it: Item) -> bool:
    """True if ``it`` is exactly what QGC uploads for an exclusion circle (so the circle reads back as it)."""
    return (
        it.frame == mavlink.MAV_FRAME_GLOBAL
        and it.command == mavlink.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION
        and math.isfinite(it.param1)
        and all(_is_zero(v) for v in (it.param2, it.param3, it.param4, it.z))
        and it.autocontinue == 0
    )


def to_plan(goals: list[Item], fences: list[Item], home: tuple[float, float, float] | None = None) -> str:
    """QGroundControl ``.plan`` JSON text (the keys QGC requires, sorted and indented as QGC writes them).

    ``goals`` become ``SimpleItem`` s. ``fences``: the exclusion circles in QGC's upload form
    (:func:`fence_circle_item`) at the end of the list become ``geoFence`` circles; the others (a
    local-frame circle has no QGC circle) ``SimpleItem`` s after the goals, where :func:`load_plan` reads
    them.
    ``plannedHomePosition`` (lat deg, lon deg, alt m AMSL): ``home`` if given, else the vehicle's home
    placeholder leading ``goals`` (which is then not written as a goal), else the first global item's
    lat/lon at altitude 0 (the surface), else [0, 0, 0]. firmwareType MAV_AUTOPILOT_GENERIC and vehicleType
    MAV_TYPE_SUBMARINE, as the vehicle's HEARTBEAT says.
    """
    _, (lat, lon, alt), rest = _file_home(goals, fences, home)
    k = len(fences)
    while k > 0 and _is_qgc_circle(fences[k - 1]):
        k -= 1
    items = [_simple_item_json(it, n) for n, it in enumerate([*rest, *fences[:k]], start=1)]
    circles = [
        {
            "circle": {"center": [it.x / GLOBAL_SCALE, it.y / GLOBAL_SCALE], "radius": it.param1},
            "inclusion": False,
            "version": 1,
        }
        for it in fences[k:]
    ]
    plan = {
        "fileType": "Plan",
        "geoFence": {"circles": circles, "polygons": [], "version": 2},
        "groundStation": PLAN_GROUND_STATION,
        "mission": {
            "cruiseSpeed": PLAN_SPEED_MPS,
            "firmwareType": mavlink.MAV_AUTOPILOT_GENERIC,
            "hoverSpeed": PLAN_SPEED_MPS,
            "items": items,
            "plannedHomePosition": [lat, lon, alt],
            "vehicleType": mavlink.MAV_TYPE_SUBMARINE,
            "version": 2,
        },
        "rallyPoints": {"points": [], "version": 2},
        "version": 1,
    }
    return json.dumps(plan, indent=4, sort_keys=True, allow_nan=False) + "\n"
