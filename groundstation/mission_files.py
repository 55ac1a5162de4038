"""Mission files for ``auv-gcs``: YAML goal poses (metres, degrees, depth) and QGC WPL 110 plain text.

YAML::

    goals:                      # MAV_CMD_NAV_WAYPOINT in MAV_FRAME_LOCAL_NED
      - {x_m: 20.0, y_m: 5.0, depth_m: 2.0, yaw_deg: 90}   # yaw_deg optional (null/absent = planner's choice)
    obstacles:                  # MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION
      - {x_m: 10.0, y_m: 2.0, radius_m: 3.0}

QGC WPL 110 (https://mavlink.io/en/file_formats/): ``seq current frame command p1 p2 p3 p4 x y z autocont``
tab separated. Local frames: x, y in metres, z = depth; global frames: lat, lon in degrees, z = altitude.
A first line with frame 0 and current = 1 is the home position (MAVProxy/ArduPilot convention) and skipped.
Fence items (command 5001..5004) go to the fence plan, everything else to the mission plan.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import yaml
from pymavlink.dialects.v20 import common as mavlink

from auv_common.cli import yaml_error_line
from groundstation.mavclient import Item

LOCAL_SCALE = 1e4
GLOBAL_SCALE = 1e7
FENCE_COMMANDS = range(5000, 5005)
LOCAL_FRAMES = (mavlink.MAV_FRAME_LOCAL_NED, mavlink.MAV_FRAME_LOCAL_ENU, mavlink.MAV_FRAME_LOCAL_OFFSET_NED)


class MissionFileError(ValueError):
    """A mission file that cannot be read; the message names the file and the place."""


def goal_item(x_m: float, y_m: float, depth_m: float, yaw_deg: float | None) -> Item:
    return Item(
        frame=mavlink.MAV_FRAME_LOCAL_NED,
        command=mavlink.MAV_CMD_NAV_WAYPOINT,
        param1=0.0,
        param2=math.nan,
        param3=0.0,
        param4=math.nan if yaw_deg is None else float(yaw_deg),
        x=round(x_m * LOCAL_SCALE),
        y=round(y_m * LOCAL_SCALE),
        z=float(depth_m),
    )


def obstacle_item(x_m: float, y_m: float, radius_m: float) -> Item:
    return Item(
        frame=mavlink.MAV_FRAME_LOCAL_NED,
        command=mavlink.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION,
        param1=float(radius_m),
        param2=0.0,
        param3=0.0,
        param4=0.0,
        x=round(x_m * LOCAL_SCALE),
        y=round(y_m * LOCAL_SCALE),
        z=0.0,
    )


def _num(where: str, d: dict[str, Any], key: str, optional: bool = False) -> float | None:
    v = d.get(key)
    if v is None:
        if optional:
            return None
        raise MissionFileError(f"{where}: missing {key}")
    if isinstance(v, bool) or not isinstance(v, int | float):
        raise MissionFileError(f"{where}: {key} must be a number, got {v!r}")
    return float(v)


def load_yaml(path: Path) -> tuple[list[Item], list[Item]]:
    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise MissionFileError(f"{path}: {exc}") from None
    except yaml.YAMLError as exc:
        raise MissionFileError(f"{path}: not valid YAML ({yaml_error_line(exc)})") from None
    if not isinstance(data, dict):
        raise MissionFileError(f"{path}: expected a mapping with 'goals' and/or 'obstacles'")
    unknown = set(data) - {"goals", "obstacles"}
    if unknown:
        raise MissionFileError(f"{path}: unknown keys {sorted(unknown)}")
    goals, obstacles = [], []
    for i, g in enumerate(data.get("goals") or []):
        where = f"{path}: goals[{i}]"
        if not isinstance(g, dict) or set(g) - {"x_m", "y_m", "depth_m", "yaw_deg"}:
            raise MissionFileError(f"{where}: expected x_m, y_m, depth_m and optional yaw_deg")
        x, y, z = (_num(where, g, k) for k in ("x_m", "y_m", "depth_m"))
        assert x is not None and y is not None and z is not None
        goals.append(goal_item(x, y, z, _num(where, g, "yaw_deg", optional=True)))
    for i, o in enumerate(data.get("obstacles") or []):
        where = f"{path}: obstacles[{i}]"
        if not isinstance(o, dict) or set(o) - {"x_m", "y_m", "radius_m"}:
            raise MissionFileError(f"{where}: expected x_m, y_m, radius_m")
        x, y, r = (_num(where, o, k) for k in ("x_m", "y_m", "radius_m"))
        assert x is not None and y is not None and r is not None
        obstacles.append(obstacle_item(x, y, r))
    return goals, obstacles


def load_wpl(path: Path) -> tuple[list[Item], list[Item]]:
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except OSError as exc:
        raise MissionFileError(f"{path}: {exc}") from None
    if not lines or not lines[0].startswith("QGC WPL 110"):
        raise MissionFileError(f"{path}: not a QGC WPL 110 file")
    goals, fences = [], []
    for n, line in enumerate(lines[1:], start=2):
        if not line.strip():
            continue
        f = line.split()
        if len(f) != 12:
            raise MissionFileError(f"{path}:{n}: expected 12 fields, got {len(f)}")
        try:
            seq, current, frame, command = (int(v) for v in f[:4])
            p1, p2, p3, p4, x, y, z = (float(v) for v in f[4:11])
            autocontinue = int(f[11])
        except ValueError:
            raise MissionFileError(f"{path}:{n}: bad number") from None
        if seq == 0 and current == 1 and frame == mavlink.MAV_FRAME_GLOBAL:
            continue  # home position
        scale = LOCAL_SCALE if frame in LOCAL_FRAMES else GLOBAL_SCALE
        item = Item(frame, command, p1, p2, p3, p4, round(x * scale), round(y * scale), z, autocontinue)
        (fences if command in FENCE_COMMANDS else goals).append(item)
    return goals, fences


def load(path: str | Path) -> tuple[list[Item], list[Item]]:
    """(mission items, fence items) from a YAML or QGC WPL 110 file."""
    p = Path(path)
    try:
        head = p.read_text(encoding="utf-8")[:16]
    except OSError as exc:
        raise MissionFileError(f"{p}: {exc}") from None
    return load_wpl(p) if head.startswith("QGC WPL") else load_yaml(p)


def to_yaml(goals: list[Item], fences: list[Item]) -> str:
    """YAML text for downloaded plans (local-frame items in metres; other frames as raw items)."""
    out: dict[str, list[dict[str, Any]]] = {"goals": [], "obstacles": []}
    for it in goals:
        if it.frame == mavlink.MAV_FRAME_LOCAL_NED:
            yaw = None if math.isnan(it.param4) else round(it.param4, 6)
            out["goals"].append(
                {
                    "x_m": it.x / LOCAL_SCALE,
                    "y_m": it.y / LOCAL_SCALE,
                    "depth_m": round(it.z, 6),
                    "yaw_deg": yaw,
                }
            )
        else:
            out["goals"].append({"raw": list(it.__dict__.values())})
    for it in fences:
        out["obstacles"].append({"x_m": it.x / LOCAL_SCALE, "y_m": it.y / LOCAL_SCALE, "radius_m": it.param1})
    return yaml.safe_dump(out, sort_keys=False)


def to_wpl(goals: list[Item], fences: list[Item]) -> str:
    lines = ["QGC WPL 110"]
    for seq, it in enumerate([*goals, *fences]):
        scale = LOCAL_SCALE if it.frame in LOCAL_FRAMES else GLOBAL_SCALE
        vals = [it.param1, it.param2, it.param3, it.param4, it.x / scale, it.y / scale, it.z]
        lines.append(
            "\t".join([str(seq), "0", str(it.frame), str(it.command), *map(repr, vals), str(it.autocontinue)])
        )
    return "\n".join(lines) + "\n"
