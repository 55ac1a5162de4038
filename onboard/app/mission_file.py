"""Mission files: YAML of goal poses in metres and degrees (the edge: converted once to SI/radians here).

::

    goals:                      # in order; NED metres, depth positive down, yaw in degrees (omit = free)
      - {x_m: 15.0, y_m: 0.0, depth_m: 1.0, yaw_deg: 0.0}
    obstacles:                  # circles that surround each obstacle
      - {x_m: 5.0, y_m: 3.0, radius_m: 1.5}
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import yaml

from onboard.core.mission.model import Goal, Mission, MissionError, Obstacle

_GOAL_KEYS = {"x_m", "y_m", "depth_m", "yaw_deg"}
_OBSTACLE_KEYS = {"x_m", "y_m", "radius_m"}


def _number(where: str, item: dict[str, Any], key: str, default: float | None = None) -> float:
    if key not in item:
        if default is not None:
            return default
        raise MissionError("missing", f"{where}: missing {key}")
    value = item[key]
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise MissionError("type", f"{where}: {key} must be a number, got {value!r}")
    return float(value)


def mission_from_dict(data: Any, where: str = "mission") -> Mission:
    """Build and validate a :class:`Mission` from parsed YAML; raises :class:`MissionError`."""
    if not isinstance(data, dict):
        raise MissionError("format", f"{where}: expected a mapping with 'goals' (and 'obstacles')")
    unknown = set(data) - {"goals", "obstacles"}
    if unknown:
        raise MissionError("format", f"{where}: unknown keys {sorted(unknown)}")
    goals = []
    for i, item in enumerate(data.get("goals") or []):
        w = f"{where} goal {i}"
        if not isinstance(item, dict) or set(item) - _GOAL_KEYS:
            raise MissionError("format", f"{w}: expected keys {sorted(_GOAL_KEYS)}, got {item!r}")
        yaw_deg = item.get("yaw_deg")
        if yaw_deg is not None and (isinstance(yaw_deg, bool) or not isinstance(yaw_deg, int | float)):
            raise MissionError("type", f"{w}: yaw_deg must be a number, got {yaw_deg!r}")
        goals.append(
            Goal(
                _number(w, item, "x_m"),
                _number(w, item, "y_m"),
                _number(w, item, "depth_m", 0.0),
                None if yaw_deg is None else math.radians(float(yaw_deg)),
            )
        )
    obstacles = []
    for i, item in enumerate(data.get("obstacles") or []):
        w = f"{where} obstacle {i}"
        if not isinstance(item, dict) or set(item) - _OBSTACLE_KEYS:
            raise MissionError("format", f"{w}: expected keys {sorted(_OBSTACLE_KEYS)}, got {item!r}")
        obstacles.append(
            Obstacle(_number(w, item, "x_m"), _number(w, item, "y_m"), _number(w, item, "radius_m"))
        )
    if not goals:
        raise MissionError("empty", f"{where}: a mission needs at least one goal")
    mission = Mission(tuple(goals), tuple(obstacles))
    mission.validate()
    return mission


def load_mission(path: str | Path) -> Mission:
    """Read a mission YAML file; any problem is a :class:`MissionError` with a one-line message."""
    p = Path(path)
    try:
        data = yaml.safe_load(p.read_text())
    except OSError as exc:
        raise MissionError("file", f"{p}: {exc.strerror}") from None
    except yaml.YAMLError as exc:
        raise MissionError("format", f"{p}: not valid YAML ({str(exc).splitlines()[0]})") from None
    return mission_from_dict(data, str(p))
