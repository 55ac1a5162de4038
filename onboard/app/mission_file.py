"""Mission files: YAML of goal poses in metres and degrees (the edge: converted once to SI/radians here).

::

    goals:                      # in order; NED metres, depth positive down, yaw in degrees (omit = free)
      - {x_m: 15.0, y_m: 0.0, depth_m: 1.0, yaw_deg: 0.0}
    obstacles:                  # circles that surround each obstacle
      - {x_m: 5.0, y_m: 3.0, radius_m: 1.5}

``x_m``, ``y_m`` and ``depth_m`` are required for every goal (a missing depth is an error, never 0);
``yaw_deg`` is optional. The file is then checked by the one validator,
:func:`onboard.core.mission.validate.check_mission` (limits from the configuration, a yaw within +-360 deg as
written, and every leg planned; no start pose: the vehicle's pose is not known at start-up), and any problem
is a :class:`MissionError` with one line naming the file, the goal or obstacle and the reason. The mission
returned has its yaws wrapped to (-180, 180], as a MAVLink upload's param4 is.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

import yaml

from auv_common.cli import yaml_error_line
from onboard.core.config import CoreConfig
from onboard.core.mission.model import Goal, Mission, MissionError, Obstacle
from onboard.core.mission.validate import check_mission
from onboard.protocol.conventions import wrap_pi

_GOAL_KEYS = {"x_m", "y_m", "depth_m", "yaw_deg"}
_GOAL_REQUIRED = ("x_m", "y_m", "depth_m")
_OBSTACLE_KEYS = {"x_m", "y_m", "radius_m"}


def _number(where: str, value: Any, key: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise MissionError("type", f"{where}: {key} must be a number, got {value!r}")
    try:
        return float(value)
    except OverflowError:  # a YAML integer too large for a float
        raise MissionError("type", f"{where}: {key} = {value} is too large") from None


def _required(where: str, item: dict[str, Any], key: str) -> float:
    if key not in item:
        raise MissionError("missing", f"{where}: missing {key}")
    return _number(where, item[key], key)


def _mapping(where: str, item: Any, keys: set[str]) -> dict[str, Any]:
    if not isinstance(item, dict) or set(item) - keys:
        raise MissionError("format", f"{where}: expected keys {sorted(keys)}, got {item!r}")
    return item


def _items(where: str, data: dict[str, Any], key: str) -> list[Any]:
    items = data.get(key)
    if items is None:
        return []
    if not isinstance(items, list):
        raise MissionError("format", f"{where}: '{key}' must be a list, got {items!r}")
    return items


def parse_mission(data: Any, where: str = "mission") -> Mission:
    """The :class:`Mission` of parsed YAML, format checks only (keys, types), the yaws as written (not
    wrapped: the validator judges them); raises :class:`MissionError`."""
    if not isinstance(data, dict):
        raise MissionError("format", f"{where}: expected a mapping with 'goals' (and 'obstacles')")
    unknown = set(data) - {"goals", "obstacles"}
    if unknown:
        raise MissionError("format", f"{where}: unknown keys {sorted(unknown)}")
    goals = []
    for i, raw in enumerate(_items(where, data, "goals")):
        w = f"{where}: goal {i}"
        item = _mapping(w, raw, _GOAL_KEYS)
        x_m, y_m, depth_m = (_required(w, item, k) for k in _GOAL_REQUIRED)
        yaw_deg = item.get("yaw_deg")
        yaw_rad = None if yaw_deg is None else math.radians(_number(w, yaw_deg, "yaw_deg"))  # as written
        goals.append(Goal(x_m, y_m, depth_m, yaw_rad))
    obstacles = []
    for i, raw in enumerate(_items(where, data, "obstacles")):
        w = f"{where}: obstacle {i}"
        item = _mapping(w, raw, _OBSTACLE_KEYS)
        obstacles.append(Obstacle(*(_required(w, item, k) for k in ("x_m", "y_m", "radius_m"))))
    return Mission(tuple(goals), tuple(obstacles))


def mission_from_dict(data: Any, config: CoreConfig, where: str = "mission") -> Mission:
    """Parse (:func:`parse_mission`) and check (:func:`check_mission`, no start pose) a mission.

    Raises :class:`MissionError` with one line: ``"<where>: goal 2: depth 25 m is below the failsafe depth
    limit 20 m"`` (and how many more problems there are); its ``reason`` is the problem's field.
    """
    mission = parse_mission(data, where)
    if not mission.goals:  # a file to fly needs a goal (over MAVLink, no goals is a clear)
        raise MissionError("count", f"{where}: a mission needs at least one goal")
    check = check_mission(mission, config)
    if check.first is not None:
        raise MissionError(check.first.field, f"{where}: {check}")
    goals = tuple(
        dataclasses.replace(g, yaw_rad=None if g.yaw_rad is None else wrap_pi(g.yaw_rad))
        for g in mission.goals
    )
    return dataclasses.replace(mission, goals=goals)


def load_mission(path: str | Path, config: CoreConfig) -> Mission:
    """Read and check a mission YAML file; any problem is a :class:`MissionError` with a one-line message."""
    p = Path(path)
    try:
        data = yaml.safe_load(p.read_text())
    except OSError as exc:
        raise MissionError("file", f"{p}: {exc.strerror}") from None
    except (yaml.YAMLError, UnicodeDecodeError) as exc:
        raise MissionError("format", f"{p}: not valid YAML ({yaml_error_line(exc)})") from None
    return mission_from_dict(data, config, str(p))
