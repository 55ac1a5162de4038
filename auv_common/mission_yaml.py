"""The YAML mission format, parsed once for every door: ``auv-onboard run --mission``, ``auv-gcs`` (upload,
fly) and the missions of a campaign spec.

::

    goals:                      # in order; NED metres, depth positive down, yaw in degrees (omit/null = free)
      - {x_m: 15.0, y_m: 0.0, depth_m: 1.0, yaw_deg: 0.0}
      - {x_m: 40.0, y_m: 5.0, depth_m: 1.0, radius_m: 3.0}   # its acceptance radius (omit/0 = the default)
    obstacles:                  # circles that surround each obstacle
      - {x_m: 5.0, y_m: 3.0, radius_m: 1.5}

The parse is the *format* only: the keys, numbers that are numbers (a YAML boolean or string is not one;
YAML 1.1 reads ``1e-3`` as a string, which the message says), ``x_m``, ``y_m`` and ``depth_m`` required
(a missing depth is an error, never 0), ``yaw_deg`` and ``radius_m`` (the goal's acceptance radius, m;
MAVLink NAV_WAYPOINT param2; 0 or absent = the vehicle's ``[mission] arrival_radius_m``) optional. The
result is plain data in the file's units (:class:`GoalPose`, :class:`Circle`, metres and degrees as
written: nothing wrapped, NaN and infinities kept). What the values may be (finite, a yaw within +-360
deg, a radius > 0, a goal's radius 0 or within MIS_ARRIVE_R_M's range, the operating area, the depth
limit) is the vehicle's to judge: its mission validator, ``onboard.core.mission.validate``, is the one
owner of those rules (``auv_common`` imports nothing of ours, so it cannot ask it, and the ground station
must not guess it: the vehicle answers an upload with its reason).

Every problem is one :class:`MissionYamlError` whose ``key`` is the dotted path of the value in the data
(``goals[1].depth_m``) and whose ``problem`` says what is wrong (``missing``); ``str()`` is
``"goals[1].depth_m: missing"``. A door puts its own place in front (the file, or the mission's key in a
campaign spec: ``missions[0].goals[1].depth_m: missing``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, TypeVar

import yaml

from auv_common.cli import yaml_error_line

GOAL_KEYS = ("x_m", "y_m", "depth_m", "yaw_deg", "radius_m")
#: A pose (a campaign's start) is a goal without an acceptance radius.
POSE_KEYS = GOAL_KEYS[:4]
CIRCLE_KEYS = ("x_m", "y_m", "radius_m")
PLAN_KEYS = ("goals", "obstacles")
#: Why a file of lists in lists in lists ... (past Python's recursion limit) is not read.
NESTED_TOO_DEEP = "nested too deep (lists or objects inside each other past what the reader follows)"

#: ``MissionYamlError.reason``: the kind of problem (a door may map it to its own code).
Reason = Literal["file", "format", "missing", "type"]

T = TypeVar("T")


@dataclass(frozen=True)
class GoalPose:
    """A goal as written: NED metres, depth positive down, yaw in degrees (None = free heading)."""

    x_m: float
    y_m: float
    depth_m: float
    yaw_deg: float | None = None
    #: The goal's acceptance radius, m (0 = the vehicle's default, ``[mission] arrival_radius_m``).
    radius_m: float = 0.0


@dataclass(frozen=True)
class Circle:
    """An obstacle as written: the circle that surrounds it (centre and radius in metres, NED)."""

    x_m: float
    y_m: float
    radius_m: float


@dataclass(frozen=True)
class MissionPlan:
    """The goals (in order) and obstacle circles of a mission file."""

    goals: tuple[GoalPose, ...] = ()
    obstacles: tuple[Circle, ...] = ()


class MissionYamlError(ValueError):
    """One problem in mission YAML: ``key`` the dotted path of the value ("" for the whole document),
    ``problem`` what is wrong, ``reason`` its kind (:data:`Reason`)."""

    def __init__(self, key: str, problem: str, reason: Reason = "format") -> None:
        super().__init__(f"{key}: {problem}" if key else problem)
        self.key = key
        self.problem = problem
        self.reason: Reason = reason


def join(key: str, sub: str) -> str:
    """``key.sub`` (either may be empty)."""
    return f"{key}.{sub}" if key and sub else key or sub


def describe(value: Any) -> str:
    """``repr(value)``, with a hint for YAML 1.1's ``1e-3`` (a string, not a number)."""
    text = repr(value)
    if isinstance(value, str) and "e" in value.lower():
        try:
            float(value)
        except ValueError:
            return text
        text += " (YAML reads 1e-3 as a string: write 1.0e-3)"
    return text


def number(key: str, value: Any) -> float:
    """``value`` as a float: an int or a float (not a bool); NaN and infinities pass (the vehicle judges
    them). Raises :class:`MissionYamlError` (reason ``type``)."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise MissionYamlError(key, f"expected a number, got {describe(value)}", "type")
    try:
        return float(value)
    except OverflowError:  # a YAML integer too large for a float
        raise MissionYamlError(key, f"{value} is too large", "type") from None


def mapping(key: str, value: Any, allowed: tuple[str, ...], required: tuple[str, ...] = ()) -> dict[str, Any]:
    """``value`` as a mapping with only ``allowed`` keys and every ``required`` one."""
    if not isinstance(value, dict):
        raise MissionYamlError(key, f"expected a mapping, got {value!r}")
    for k in value:
        if k not in allowed:
            raise MissionYamlError(join(key, str(k)), f"unknown key (known: {', '.join(sorted(allowed))})")
    for k in required:
        if k not in value:
            raise MissionYamlError(join(key, k), "missing", "missing")
    return value


def items(key: str, value: Any, parse_one: Callable[[str, Any], T]) -> tuple[T, ...]:
    """A list parsed item by item (``key[i]``); ``None`` (an absent or empty key) is no item."""
    if value is None:
        return ()
    if not isinstance(value, list):
        raise MissionYamlError(key, f"expected a list, got {value!r}")
    return tuple(parse_one(f"{key}[{i}]", v) for i, v in enumerate(value))


def parse_goal(key: str, value: Any, *, yaw_required: bool = False) -> GoalPose:
    """One goal pose ``{x_m, y_m, depth_m, yaw_deg, radius_m}``; ``yaw_deg`` may be absent or null (free)
    and ``radius_m`` absent (0: the vehicle's default), unless ``yaw_required``: then it is a pose (a
    campaign's start: ``yaw_deg`` present, null still None, the caller judges; no ``radius_m``)."""
    allowed, required = (POSE_KEYS, POSE_KEYS) if yaw_required else (GOAL_KEYS, GOAL_KEYS[:3])
    d = mapping(key, value, allowed, required)
    x_m, y_m, depth_m = (number(join(key, k), d[k]) for k in GOAL_KEYS[:3])
    raw = d.get("yaw_deg")
    radius_m = number(join(key, "radius_m"), d["radius_m"]) if "radius_m" in d else 0.0
    return GoalPose(x_m, y_m, depth_m, None if raw is None else number(join(key, "yaw_deg"), raw), radius_m)


def parse_circle(key: str, value: Any) -> Circle:
    """One obstacle circle ``{x_m, y_m, radius_m}``, all required."""
    d = mapping(key, value, CIRCLE_KEYS, CIRCLE_KEYS)
    return Circle(*(number(join(key, k), d[k]) for k in CIRCLE_KEYS))


def parse_plan(data: Any, key: str = "") -> MissionPlan:
    """The :class:`MissionPlan` of parsed YAML ``{goals: [...], obstacles: [...]}`` (either may be absent:
    whether a mission needs a goal is the door's rule)."""
    if not isinstance(data, dict):
        raise MissionYamlError(key, f"expected a mapping with goals and/or obstacles, got {describe(data)}")
    d = mapping(key, data, PLAN_KEYS)
    return MissionPlan(
        goals=items(join(key, "goals"), d.get("goals"), parse_goal),
        obstacles=items(join(key, "obstacles"), d.get("obstacles"), parse_circle),
    )


def read_yaml(path: Path) -> Any:
    """The parsed YAML of a file; a file that cannot be read or parsed is one :class:`MissionYamlError`
    line (key "": the door names the file)."""
    try:
        return yaml.safe_load(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise MissionYamlError("", exc.strerror or str(exc), "file") from None
    except (yaml.YAMLError, UnicodeDecodeError) as exc:
        raise MissionYamlError("", f"not valid YAML ({yaml_error_line(exc)})") from None
    except RecursionError:
        raise MissionYamlError("", NESTED_TOO_DEEP) from None


def load_plan(path: str | Path) -> MissionPlan:
    """:func:`read_yaml` then :func:`parse_plan`."""
    return parse_plan(read_yaml(Path(path)))


def goal_data(goal: GoalPose) -> dict[str, float]:
    """The YAML mapping of a goal (``yaw_deg`` left out when free, ``radius_m`` when 0: the default)."""
    d = {"x_m": goal.x_m, "y_m": goal.y_m, "depth_m": goal.depth_m}
    if goal.yaw_deg is not None:
        d["yaw_deg"] = goal.yaw_deg
    if goal.radius_m != 0.0:
        d["radius_m"] = goal.radius_m
    return d


def plan_data(plan: MissionPlan) -> dict[str, list[dict[str, float]]]:
    """The YAML data of a plan (the inverse of :func:`parse_plan`)."""
    return {
        "goals": [goal_data(g) for g in plan.goals],
        "obstacles": [{"x_m": c.x_m, "y_m": c.y_m, "radius_m": c.radius_m} for c in plan.obstacles],
    }


__all__ = [
    "CIRCLE_KEYS",
    "GOAL_KEYS",
    "NESTED_TOO_DEEP",
    "POSE_KEYS",
    "Circle",
    "GoalPose",
    "MissionPlan",
    "MissionYamlError",
    "describe",
    "goal_data",
    "items",
    "join",
    "load_plan",
    "mapping",
    "number",
    "parse_circle",
    "parse_goal",
    "parse_plan",
    "plan_data",
    "read_yaml",
]
