"""Mission files: YAML of goal poses in metres and degrees (the edge: converted once to SI/radians here).

::

    goals:                      # in order; NED metres, depth positive down, yaw in degrees (omit = free)
      - {x_m: 15.0, y_m: 0.0, depth_m: 1.0, yaw_deg: 0.0}
    obstacles:                  # circles that surround each obstacle
      - {x_m: 5.0, y_m: 3.0, radius_m: 1.5}

The format (keys, numbers; ``x_m``, ``y_m`` and ``depth_m`` required, a missing depth an error, never 0;
``yaw_deg`` optional) is the one parser of the YAML mission format, :mod:`auv_common.mission_yaml`, which the
ground station and campaign specs use too: a format problem is one line naming the file and the key
(``m.yaml: goals[1].depth_m: missing``). The mission is then checked by the one validator,
:func:`onboard.core.mission.validate.check_mission` (limits from the configuration, a yaw within +-360 deg as
written, and every leg planned; no start pose: the vehicle's pose is not known at start-up), and every
position must fit a MAVLink mission item (the vehicle serves and stores it as one:
:func:`auv_common.mission_items.fits_local`); any problem is a :class:`MissionError` with one line naming
the file, the goal or obstacle and the reason. The mission returned has its yaws wrapped to (-180, 180], as
a MAVLink upload's param4 is.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

from auv_common import mission_yaml
from auv_common.mission_items import local_problem
from onboard.core.config import CoreConfig
from onboard.core.mission.model import Goal, Mission, MissionError, Obstacle
from onboard.core.mission.validate import check_mission
from onboard.protocol.conventions import wrap_pi


def parse_mission(data: Any, where: str = "mission") -> Mission:
    """The :class:`Mission` of parsed YAML, format checks only (:func:`auv_common.mission_yaml.parse_plan`),
    the yaws as written (degrees to radians, not wrapped: the validator judges them); raises
    :class:`MissionError` (reason: the parser's kind of problem)."""
    try:
        plan = mission_yaml.parse_plan(data)
    except mission_yaml.MissionYamlError as exc:
        raise MissionError(exc.reason, f"{where}: {exc}") from None
    goals = tuple(
        Goal(g.x_m, g.y_m, g.depth_m, None if g.yaw_deg is None else math.radians(g.yaw_deg), g.radius_m)
        for g in plan.goals
    )
    obstacles = tuple(Obstacle(c.x_m, c.y_m, c.radius_m) for c in plan.obstacles)
    return Mission(goals, obstacles)


def _encoding_problem(mission: Mission) -> tuple[str, str] | None:
    """(field, "goal i: why") of the first position a MAVLink mission item cannot carry, or None (a value
    that is not a finite number is the validator's to name)."""
    items: list[tuple[str, int, Goal | Obstacle]] = [("goal", i, g) for i, g in enumerate(mission.goals)]
    items += [("obstacle", i, o) for i, o in enumerate(mission.obstacles)]
    for kind, i, item in items:
        for name, value in (("x", item.x_m), ("y", item.y_m)):
            why = local_problem(name if kind == "goal" else f"centre {name}", value)
            if why is not None and math.isfinite(value):
                return name, f"{kind} {i}: {why}"
    return None


def mission_from_dict(data: Any, config: CoreConfig, where: str = "mission") -> Mission:
    """Parse (:func:`parse_mission`) and check (the encoding, then :func:`check_mission`, no start pose)
    a mission.

    Raises :class:`MissionError` with one line: ``"<where>: goal 2: depth 25 m is below the failsafe depth
    limit 20 m"`` (and how many more problems there are); its ``reason`` is the problem's field.
    """
    mission = parse_mission(data, where)
    if not mission.goals:  # a file to fly needs a goal (over MAVLink, no goals is a clear)
        raise MissionError("count", f"{where}: a mission needs at least one goal")
    unencodable = _encoding_problem(mission)  # first: a far-out obstacle would only be "in the way"
    if unencodable is not None:
        raise MissionError(unencodable[0], f"{where}: {unencodable[1]}")
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
        data = mission_yaml.read_yaml(p)
    except mission_yaml.MissionYamlError as exc:
        raise MissionError(exc.reason, f"{p}: {exc}") from None
    return mission_from_dict(data, config, str(p))
