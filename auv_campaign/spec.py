"""The campaign spec: a YAML file of missions and sweep axes, expanded into runs, checked before any starts.

::

    name: turn-in-current
    missions:                         # each with its own start and goals; optional name (default m0, m1, ...)
      - start: {x_m: -15, y_m: 5, depth_m: 1, yaw_deg: 0}
        goals: [{x_m: 10, y_m: -2, depth_m: 1, yaw_deg: 270}]   # yaw_deg optional / null = free heading;
                                      # radius_m optional: the goal's acceptance radius (0 = the default)
        obstacles: [{x_m: 0, y_m: 3, radius_m: 1.5}]           # optional
    random_missions: {count: 50, seed: 7, area_m: 60, obstacles: [0, 5], radius_m: [1, 4]}   # optional
    sweep:                            # the product of every axis; each optional, defaults below
      seed: [0, 1, 2]                 # sensor noise seed; default [0]
      current: [[0.0, 0], [0.3, 90]]  # [speed_mps, direction_deg] (towards, from north); default [[0, 0]]
      profile: [basin, sea]           # sensor profile; default [basin]
      onboard: [{}, {control.improved.Kp5: -0.3}]   # onboard --set overrides; default [{}]
      vehicle: [{}, {scale: {fin_lift: 0.7}, set: {fins.area_m2: 0.035}}]   # default [{}]
      faults: [[], [{kind: dvl_dropout, start_s: 10, duration_s: 20}]]   # a list per run; default: no axis
    time_limit_factor: 2.0            # default 2.0 (x the nominal time of the mission)
    observe_after_end_s: 20           # default 20: simulated s the run goes on after COMPLETE, HOLD or ABORT
    success: {position_m: 0.3, course_deg: 10, cross_track_m: 2, depth_m: 0.5}   # defaults 0.3 m, 10 deg,
                                      # no path bound, no depth bound (the truth's depth where the vehicle
                                      # said COMPLETE: beyond it, a false COMPLETE)

At least one of ``missions`` / ``random_missions``. Missions are the listed ones, then the random ones
(:func:`random_missions`, names r0, r1, ...). The runs are ``itertools.product`` of missions, seeds,
currents, profiles, onboard override sets and vehicle variants, in that order (deterministic), then, when the
spec sweeps them, the fault lists (:mod:`hil_sim.model.faults`: each entry a run's list of faults, ``[]`` for
none; parsed by the bench's own parser; a spec without ``sweep.faults`` has no ``faults`` axis, and its run
ids and runs are those of before faults existed).

Caps (refused before anything is drawn or expanded): ``random_missions.count`` <= 100000
(:data:`MAX_RANDOM_MISSIONS`), ``random_missions.goals`` <= 100 (:data:`MAX_RANDOM_GOALS`),
``random_missions.obstacles`` hi <= the onboard's ``[mission] max_obstacles`` (of the packaged
``onboard.toml``, 64), and the total number of runs (the product of the number of missions and of every
axis) <= 1000000 (:data:`MAX_RUNS`).

A mission's goals and obstacles are in the mission file format, read by its one parser
(:mod:`auv_common.mission_yaml`), and their values judged by the vehicle's own rules
(``onboard.core.mission.validate.check_goal_values`` / ``check_obstacle_values``: finite, a goal's depth
>= 0 and yaw within +-360 deg, a goal's radius_m 0 or within MIS_ARRIVE_R_M's range, an obstacle's radius
> 0). A goal's own radius is sent to the vehicle (its mission file) and judges the run (success,
false_complete: :mod:`auv_campaign.metrics`). Depths are >= 0 (positive down: a start, goal or random depth
above the surface is refused). A current's
direction is normalised to [0, 360) deg, and to 0 when its speed is 0 (:func:`normalise_current`), before
duplicate detection, labels and run ids: ``[0.1, 360]`` is ``[0.1, 0]``, ``[0, 20]`` is ``[0, 0]``,
``[0.25, -45]`` is ``c0.25d315``.

The campaign owns the onboard's ``[bus]``, ``[loop]`` and ``[mavlink]`` tables (each run's bus, clock,
telemetry and links): ``sweep.onboard`` may not set them (:func:`check_onboard_sets`).

Units: metres, m/s, degrees (as in the onboard's mission files). An onboard override entry maps dotted keys of
``onboard.toml`` to values (a nested mapping is flattened: ``{control: {improved: {Kp5: -0.3}}}`` is
``control.improved.Kp5``); it is judged by the onboard's own configuration loader. A vehicle variant has
``scale`` (group -> factor) and ``set`` (dotted key of ``isimi100.toml`` -> value), judged by
:func:`hil_sim.model.variants.vehicle_params`. Whether a mission is feasible is the onboard validator's
call at run time (a refused mission is a run with ``planned = False``, not a spec error).

Every problem is one :class:`SpecError` line ``SPEC_PATH: key.path: what is wrong``, raised before any run.
Note that YAML 1.1 reads ``1e-3`` as a string: write ``1.0e-3``.
"""

from __future__ import annotations

import functools
import itertools
import json
import math
import re
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

import numpy as np
import yaml

from auv_common import mission_yaml
from auv_common.cli import yaml_error_line
from auv_common.config import ConfigError
from hil_sim.model import faults as fault_model
from hil_sim.model.faults import Fault

#: Sensor profiles of the simulator (``[sensors.*]`` of ``hil_sim/params/isimi100.toml``).
PROFILES = ("basin", "sea")
#: The largest current speed a sweep may ask for (m/s).
MAX_CURRENT_MPS = 3.0
#: The most random missions a spec may draw (``random_missions.count``).
MAX_RANDOM_MISSIONS = 100_000
#: The most goals of one random mission (``random_missions.goals``).
MAX_RANDOM_GOALS = 100
#: The most runs a spec may expand to (the product of missions and every sweep axis).
MAX_RUNS = 1_000_000
#: Tables of ``onboard.toml`` the campaign sets for every run (an onboard override may not).
CAMPAIGN_TABLES = ("bus", "loop", "mavlink")
#: The sweep axes, outer to inner (the order of the runs and of :attr:`CampaignSpec.axes`).
AXES = ("mission", "seed", "current", "profile", "onboard", "vehicle")

_TOP_KEYS = (
    "name", "missions", "random_missions", "sweep", "time_limit_factor", "observe_after_end_s", "success"
)  # fmt: skip
_SWEEP_KEYS = ("seed", "current", "profile", "onboard", "vehicle", "faults")
#: The fault axis (after :data:`AXES`; only in a spec that sweeps ``faults``).
FAULT_AXIS = "faults"
_MISSION_KEYS = ("name", "start", "goals", "obstacles")
T = TypeVar("T")
#: The YAML key of each field a mission validator problem names (``Problem.field``).
_KEY_OF_FIELD = {
    "x": "x_m", "y": "y_m", "depth": "depth_m", "yaw": "yaw_deg",
    "radius": "radius_m", "arrival_radius": "radius_m",
}  # fmt: skip
_RANDOM_KEYS = ("count", "seed", "area_m", "obstacles", "radius_m", "depth_m", "goals", "min_distance_m")
_SUCCESS_KEYS = ("position_m", "course_deg", "cross_track_m", "depth_m")
#: The default of ``observe_after_end_s`` (simulated s after the end: a glide, a sink, a collision show).
OBSERVE_AFTER_END_S = 20.0
#: The most ``observe_after_end_s`` may ask (simulated s).
MAX_OBSERVE_AFTER_END_S = 600.0
#: Keys of the vehicle's ``[current]`` table a variant may not set: the mean current is the sweep's
#: ``current`` axis (the bench takes the mean from it; only the variation comes from the vehicle file).
_CURRENT_MEAN_KEYS = ("current.north_mps", "current.east_mps", "current.down_mps")
_VEHICLE_KEYS = ("scale", "set")
_NAME_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")

#: Random missions: an obstacle centre is redrawn while its circle (radius + this, m) holds a start or goal.
OBSTACLE_CLEARANCE_M = 0.5
_OBSTACLE_DRAWS = 100
_GOAL_DRAWS = 10_000


class SpecError(ConfigError):
    """A bad campaign spec: one line ``SPEC_PATH: key.path: what is wrong``."""


class _Invalid(Exception):
    """Internal: a problem at ``key`` (the spec path is added by :func:`parse_spec`)."""

    def __init__(self, key: str, message: str) -> None:
        super().__init__(f"{key}: {message}")
        self.key = key
        self.message = message


# ----------------------------------------------------------------------------------------------------
# The expanded runs


@dataclass(frozen=True)
class MissionSpec:
    """One mission: a start pose, goals and obstacle circles (metres, degrees; depth positive down).

    ``start`` is (x_m, y_m, depth_m, yaw_deg); each goal (x_m, y_m, depth_m, yaw_deg or None = free arrival
    heading); each obstacle (x_m, y_m, radius_m). ``goal_radii_m``: each goal's acceptance radius (m; 0 =
    the vehicle's ``[mission] arrival_radius_m``), empty when no goal gives one (:meth:`goal_radius_m`).
    """

    name: str
    start: tuple[float, float, float, float]
    goals: tuple[tuple[float, float, float, float | None], ...]
    obstacles: tuple[tuple[float, float, float], ...] = ()
    goal_radii_m: tuple[float, ...] = ()

    def goal_radius_m(self, index: int) -> float:
        """Goal ``index``'s own acceptance radius as the spec gives it (m; 0 = the vehicle's default)."""
        return self.goal_radii_m[index] if index < len(self.goal_radii_m) else 0.0

    def to_mission_file(self) -> dict[str, Any]:
        """The goals and obstacles in the mission file format (:mod:`auv_common.mission_yaml`)."""
        plan = mission_yaml.MissionPlan(
            tuple(
                mission_yaml.GoalPose(*g, radius_m=self.goal_radius_m(i)) for i, g in enumerate(self.goals)
            ),
            tuple(mission_yaml.Circle(*o) for o in self.obstacles),
        )
        return mission_yaml.plan_data(plan)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: ``{"name", "start": [4], "goals": [[4]...], "obstacles": [[3]...]}`` and
        ``"goal_radii_m": [...]`` when a goal gives its own radius."""
        d: dict[str, Any] = {
            "name": self.name,
            "start": list(self.start),
            "goals": [list(g) for g in self.goals],
            "obstacles": [list(o) for o in self.obstacles],
        }
        if any(self.goal_radii_m):
            d["goal_radii_m"] = list(self.goal_radii_m)
        return d

    @staticmethod
    def from_dict(d: Mapping[str, Any]) -> MissionSpec:
        """The inverse of :meth:`to_dict`."""
        sx, sy, sd, syaw = (float(v) for v in d["start"])
        return MissionSpec(
            name=str(d["name"]),
            start=(sx, sy, sd, syaw),
            goals=tuple(
                (float(x), float(y), float(z), None if yaw is None else float(yaw))
                for x, y, z, yaw in d["goals"]
            ),
            obstacles=tuple((float(x), float(y), float(r)) for x, y, r in d.get("obstacles", ())),
            goal_radii_m=tuple(float(r) for r in d.get("goal_radii_m", ())),
        )


def _freeze(value: Any) -> Any:
    """Lists (from YAML or JSON) as tuples, recursively, so that a run is hashable and compares equal."""
    if isinstance(value, list | tuple):
        return tuple(_freeze(v) for v in value)
    return value


def _thaw(value: Any) -> Any:
    if isinstance(value, tuple):
        return [_thaw(v) for v in value]
    return value


def set_argument(key: str, value: Any) -> str:
    """``KEY=VALUE`` as ``auv-onboard run --set`` takes it: the value in JSON (which is TOML for numbers,
    booleans, strings and lists; a frozen spec value is thawed first), e.g. ``guidance.mode="los"``."""
    return f"{key}={json.dumps(_thaw(value))}"


@dataclass(frozen=True)
class RunSpec:
    """One run: a mission under one value of every sweep axis.

    ``seed`` is the sensor-noise seed; current speed (m/s) and direction (deg, the direction it flows
    towards, clockwise from north, in [0, 360) and 0 when the speed is 0: :func:`normalise_current`);
    ``profile`` the simulator's sensor profile; ``onboard`` the onboard configuration overrides ((dotted
    key, value), in spec order) and ``onboard_label`` ("default" for none, else ``o<index in the axis>``);
    ``vehicle_scale`` ((group, factor), ...) and ``vehicle_set`` ((dotted key, value), ...) the vehicle
    variant, ``vehicle_label`` ("nominal" or ``v<index>``); ``time_limit_factor`` times the mission's
    nominal time is the run's time limit; a success needs every goal's position within
    ``success_position_m`` (m) and course within ``success_course_deg`` (deg), and the path within
    ``success_cross_track_m`` (m) of the plan when it is given, and the truth's depth where the vehicle said
    COMPLETE within ``success_depth_m`` (m) of the last goal's when it is given (beyond it the COMPLETE is a
    false one); the run goes on ``observe_after_end_s``
    simulated seconds after the end (COMPLETE, HOLD or ABORT).
    """

    run_id: str
    mission: MissionSpec
    seed: int
    current_speed_mps: float
    current_dir_deg: float
    profile: str
    onboard: tuple[tuple[str, Any], ...]
    onboard_label: str
    vehicle_scale: tuple[tuple[str, float], ...]
    vehicle_set: tuple[tuple[str, Any], ...]
    vehicle_label: str
    time_limit_factor: float
    success_position_m: float
    success_course_deg: float
    success_cross_track_m: float | None = None
    observe_after_end_s: float = OBSERVE_AFTER_END_S
    success_depth_m: float | None = None
    #: the bench's faults for this run (:mod:`hil_sim.model.faults`) and the run id's label of them ("": the
    #: spec does not sweep faults)
    faults: tuple[Fault, ...] = ()
    faults_label: str = ""

    @property
    def faults_description(self) -> str:
        """The ``faults`` column and axis label (:func:`hil_sim.model.faults.describe`; "": no axis)."""
        return fault_model.describe(self.faults) if self.faults_label else ""

    def onboard_sets(self) -> list[str]:
        """The overrides as ``auv-onboard run --set`` arguments: ``KEY=VALUE`` with the value in JSON (which
        is TOML for numbers, booleans, strings and lists), e.g. ``guidance.mode="los"``."""
        return [set_argument(key, value) for key, value in self.onboard]

    def axis_labels(self) -> dict[str, str]:
        """This run's label on every axis (the labels of :attr:`CampaignSpec.axes`)."""
        return {
            "mission": self.mission.name,
            "seed": seed_label(self.seed),
            "current": current_label(self.current_speed_mps, self.current_dir_deg),
            "profile": self.profile,
            "onboard": self.onboard_label,
            "vehicle": self.vehicle_label,
        } | ({FAULT_AXIS: self.faults_description} if self.faults_label else {})

    def identity(self) -> dict[str, Any]:
        """The identity columns of a result row (:data:`auv_campaign.results.ID_COLUMNS`)."""
        return {
            "run_id": self.run_id,
            "mission": self.mission.name,
            "seed": self.seed,
            "current_speed_mps": self.current_speed_mps,
            "current_dir_deg": self.current_dir_deg,
            "profile": self.profile,
            "onboard": self.onboard_label,
            "vehicle": self.vehicle_label,
            "faults": self.faults_description,
        }

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready (pairs as lists); :meth:`from_dict` restores the tuples."""
        return (
            {
                "run_id": self.run_id,
                "mission": self.mission.to_dict(),
                "seed": self.seed,
                "current_speed_mps": self.current_speed_mps,
                "current_dir_deg": self.current_dir_deg,
                "profile": self.profile,
                "onboard": [[k, _thaw(v)] for k, v in self.onboard],
                "onboard_label": self.onboard_label,
                "vehicle_scale": [[k, v] for k, v in self.vehicle_scale],
                "vehicle_set": [[k, _thaw(v)] for k, v in self.vehicle_set],
                "vehicle_label": self.vehicle_label,
                "time_limit_factor": self.time_limit_factor,
                "success_position_m": self.success_position_m,
                "success_course_deg": self.success_course_deg,
                "success_cross_track_m": self.success_cross_track_m,
                "observe_after_end_s": self.observe_after_end_s,
            }
            | ({"success_depth_m": self.success_depth_m} if self.success_depth_m is not None else {})
            | (
                {"faults": [fault_model.to_dict(f) for f in self.faults], "faults_label": self.faults_label}
                if self.faults_label
                else {}
            )
        )

    @staticmethod
    def from_dict(d: Mapping[str, Any]) -> RunSpec:
        """The inverse of :meth:`to_dict` (e.g. after a JSON round trip)."""
        return RunSpec(
            run_id=str(d["run_id"]),
            mission=MissionSpec.from_dict(d["mission"]),
            seed=int(d["seed"]),
            current_speed_mps=float(d["current_speed_mps"]),
            current_dir_deg=float(d["current_dir_deg"]),
            profile=str(d["profile"]),
            onboard=tuple((str(k), _freeze(v)) for k, v in d["onboard"]),
            onboard_label=str(d["onboard_label"]),
            vehicle_scale=tuple((str(k), float(v)) for k, v in d["vehicle_scale"]),
            vehicle_set=tuple((str(k), _freeze(v)) for k, v in d["vehicle_set"]),
            vehicle_label=str(d["vehicle_label"]),
            time_limit_factor=float(d["time_limit_factor"]),
            success_position_m=float(d["success_position_m"]),
            success_course_deg=float(d["success_course_deg"]),
            success_cross_track_m=(
                None if d.get("success_cross_track_m") is None else float(d["success_cross_track_m"])
            ),
            observe_after_end_s=float(d.get("observe_after_end_s", OBSERVE_AFTER_END_S)),
            success_depth_m=None if d.get("success_depth_m") is None else float(d["success_depth_m"]),
            faults=fault_model.parse_faults(d.get("faults", [])),
            faults_label=str(d.get("faults_label", "")),
        )


@dataclass(frozen=True)
class CampaignSpec:
    """The expanded campaign.

    ``path`` is the spec file (or the ``where`` given to :func:`parse_spec`); ``runs`` in run order;
    ``axes`` maps each axis of :data:`AXES` to the labels of its values in spec order (mission names,
    ``s<seed>``, ``c<speed>d<direction>``, profile names, ``default``/``o<i>``, ``nominal``/``v<i>``, as in
    :meth:`RunSpec.axis_labels`); ``legend`` maps the onboard and vehicle labels to what they stand for
    (e.g. ``{"onboard": {"o1": "control.improved.Kp5=-0.3"}}``).
    """

    name: str
    path: str
    runs: tuple[RunSpec, ...]
    axes: dict[str, list[str]]
    legend: dict[str, dict[str, str]] = field(default_factory=dict)


def seed_label(seed: int) -> str:
    """The label of a noise seed in run ids and axes: ``s<seed>``."""
    return f"s{seed}"


def normalise_current(speed_mps: float, direction_deg: float) -> tuple[float, float]:
    """``(speed, direction)`` with the direction in [0, 360) deg, and 0 when the speed is 0 (no ``-0.0``)."""
    speed = float(speed_mps) + 0.0
    if speed == 0.0:
        return speed, 0.0
    direction = float(direction_deg) % 360.0
    if direction >= 360.0:  # a tiny negative direction rounds up to 360
        direction = 0.0
    return speed, direction + 0.0


def current_label(speed_mps: float, direction_deg: float) -> str:
    """The label of a current in run ids and axes: ``c<speed>d<direction>`` (``%g``, after
    :func:`normalise_current`), e.g. ``c0.3d90``."""
    speed, direction = normalise_current(speed_mps, direction_deg)
    return f"c{speed:g}d{direction:g}"


def make_run_id(
    mission: str,
    seed: int,
    speed_mps: float,
    direction_deg: float,
    profile: str,
    onboard: str,
    vehicle: str,
    faults: str = "",
) -> str:
    """``{mission}_s{seed}_c{speed}d{dir}_{profile}_{onboard}_{vehicle}[_{faults}]``, e.g.
    ``m0_s0_c0.3d90_basin_default_nominal`` or ``turn_s0_c0d0_basin_default_nominal_dvl_dropout``
    (readable, filename-safe, unique within a spec; the faults part only in a spec that sweeps faults)."""
    parts = (mission, seed_label(seed), current_label(speed_mps, direction_deg), profile, onboard, vehicle)
    return "_".join((*parts, faults) if faults else parts)


# ----------------------------------------------------------------------------------------------------
# Random missions


def random_missions(
    count: int,
    seed: int,
    area_m: float,
    obstacles: tuple[int, int] = (0, 0),
    radius_m: tuple[float, float] = (1.0, 4.0),
    depth_m: tuple[float, float] = (1.0, 1.0),
    goals: int = 1,
    min_distance_m: float | None = None,
) -> list[MissionSpec]:
    """``count`` missions drawn with ``numpy.random.default_rng(seed)`` (deterministic for a seed).

    Start and goals are uniform in the square [-area_m/2, area_m/2]^2 (positions rounded to 0.01 m), depths
    uniform in ``depth_m`` (m, rounded to 0.01 m), headings uniform in [0, 360) deg rounded to 0.1 deg; each
    goal is at least ``min_distance_m`` (default area_m / 3) from the point before it (the start or the
    previous goal; redrawn). The number of obstacles is uniform in ``obstacles`` (inclusive), each radius
    uniform in ``radius_m`` (m, rounded to 0.01 m) and each centre uniform in the square, redrawn while the
    circle (radius + 0.5 m) holds the start or a goal (at most 100 draws, then that obstacle is dropped).
    Names r0, r1, .... Raises :class:`ValueError` on bad arguments (``count`` at most
    :data:`MAX_RANDOM_MISSIONS`, ``goals`` at most :data:`MAX_RANDOM_GOALS`, depths >= 0).
    """
    if isinstance(count, bool) or not isinstance(count, int) or not 0 <= count <= MAX_RANDOM_MISSIONS:
        raise ValueError(f"count must be an integer in [0, {MAX_RANDOM_MISSIONS}], got {count!r}")
    if isinstance(goals, bool) or not isinstance(goals, int) or not 1 <= goals <= MAX_RANDOM_GOALS:
        raise ValueError(f"goals must be an integer in [1, {MAX_RANDOM_GOALS}], got {goals!r}")
    if not (math.isfinite(area_m) and area_m > 0.0):
        raise ValueError(f"area_m must be > 0, got {area_m!r}")
    o_lo, o_hi = obstacles
    r_lo, r_hi = radius_m
    d_lo, d_hi = depth_m
    if not 0 <= o_lo <= o_hi:
        raise ValueError(f"obstacles must be [lo, hi] with 0 <= lo <= hi, got {obstacles!r}")
    if not 0.0 < r_lo <= r_hi:
        raise ValueError(f"radius_m must be [lo, hi] with 0 < lo <= hi, got {radius_m!r}")
    if not 0.0 <= d_lo <= d_hi:
        raise ValueError(f"depth_m must be [lo, hi] with 0 <= lo <= hi, got {depth_m!r}")
    min_d = area_m / 3.0 if min_distance_m is None else float(min_distance_m)
    if not 0.0 <= min_d <= area_m:
        raise ValueError(f"min_distance_m must be in [0, area_m], got {min_distance_m!r}")

    rng = np.random.default_rng(seed)
    half = 0.5 * area_m

    def point() -> tuple[float, float]:
        x, y = rng.uniform(-half, half, size=2)
        return round(float(x), 2), round(float(y), 2)

    def depth() -> float:
        return round(float(rng.uniform(d_lo, d_hi)), 2)

    def heading() -> float:
        h = round(float(rng.uniform(0.0, 360.0)), 1)
        return 0.0 if h >= 360.0 else h

    out: list[MissionSpec] = []
    for k in range(count):
        sx, sy = point()
        start = (sx, sy, depth(), heading())
        points = [(sx, sy)]
        goal_list: list[tuple[float, float, float, float | None]] = []
        for _ in range(goals):
            for _ in range(_GOAL_DRAWS):
                gx, gy = point()
                if math.hypot(gx - points[-1][0], gy - points[-1][1]) >= min_d:
                    break
            else:  # pragma: no cover - min_d <= area_m makes this vanishingly unlikely
                raise ValueError(f"no goal {min_d} m away found in {_GOAL_DRAWS} draws")
            goal_list.append((gx, gy, depth(), heading()))
            points.append((gx, gy))
        obstacle_list: list[tuple[float, float, float]] = []
        for _ in range(int(rng.integers(o_lo, o_hi, endpoint=True))):
            radius = round(float(rng.uniform(r_lo, r_hi)), 2)
            for _ in range(_OBSTACLE_DRAWS):
                cx, cy = point()
                if all(math.hypot(cx - px, cy - py) > radius + OBSTACLE_CLEARANCE_M for px, py in points):
                    obstacle_list.append((cx, cy, radius))
                    break
        out.append(MissionSpec(f"r{k}", start, tuple(goal_list), tuple(obstacle_list)))
    return out


# ----------------------------------------------------------------------------------------------------
# Parsing


_describe = mission_yaml.describe  # repr with the hint for YAML 1.1's 1e-3 (the mission format's own)


def _number(key: str, value: Any) -> float:
    out = _mission_format(mission_yaml.number, key, value)
    if not math.isfinite(out):
        raise _Invalid(key, f"must be finite, got {value!r}")
    return out


def _positive(key: str, value: Any) -> float:
    out = _number(key, value)
    if out <= 0.0:
        raise _Invalid(key, f"must be > 0, got {value!r}")
    return out


def _integer(key: str, value: Any, minimum: int | None = None, maximum: int | None = None) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise _Invalid(key, f"expected an integer, got {_describe(value)}")
    if minimum is not None and value < minimum:
        raise _Invalid(key, f"must be >= {minimum}, got {value}")
    if maximum is not None and value > maximum:
        raise _Invalid(key, f"must be <= {maximum}, got {value}")
    return value


def _mapping(key: str, value: Any, allowed: Iterable[str], required: Iterable[str] = ()) -> dict[str, Any]:
    """``value`` as a mapping with only ``allowed`` keys and every ``required`` one (``None`` is ``{}``)."""
    if value is None:
        value = {}
    if not isinstance(value, dict):
        raise _Invalid(key, f"expected a mapping, got {value!r}")
    known = tuple(allowed)
    for k in value:
        if k not in known:
            raise _Invalid(_join(key, str(k)), f"unknown key (known: {', '.join(sorted(known))})")
    for k in required:
        if k not in value:
            raise _Invalid(_join(key, k), "missing")
    return value


def _list(key: str, value: Any, *, non_empty: bool = False) -> list[Any]:
    if not isinstance(value, list):
        raise _Invalid(key, f"expected a list, got {value!r}")
    if non_empty and not value:
        raise _Invalid(key, "must not be empty")
    return value


def _join(key: str, sub: str) -> str:
    """``key.sub`` (either may be empty)."""
    return f"{key}.{sub}" if key and sub else key or sub


def _name(key: str, value: Any) -> str:
    if not isinstance(value, str) or not _NAME_RE.match(value):
        raise _Invalid(key, f"expected a name of letters, digits, '_', '.', '-', got {value!r}")
    return value


def _any_mapping(key: str, value: Any) -> dict[Any, Any]:
    """``value`` as a mapping of any keys (``None`` is ``{}``)."""
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise _Invalid(key, f"expected a mapping, got {value!r}")
    return value


def _flatten(key: str, value: Any) -> list[tuple[str, Any]]:
    """A mapping of dotted keys (nested mappings flattened) -> its (key, value) pairs, values checked."""
    pairs: list[tuple[str, Any]] = []

    def walk(node: Any, prefix: str) -> None:
        for k, v in _any_mapping(_join(key, prefix.rstrip(".")), node).items():
            if not isinstance(k, str) or not k:
                raise _Invalid(_join(key, prefix.rstrip(".")), f"expected dotted keys, got {k!r}")
            full = prefix + k
            if isinstance(v, dict):
                if not v:
                    raise _Invalid(f"{key}.{full}", "empty mapping")
                walk(v, full + ".")
            else:
                if any(full == seen for seen, _ in pairs):
                    raise _Invalid(f"{key}.{full}", "set twice")
                pairs.append((full, _value(f"{key}.{full}", v)))

    walk(value, "")
    return pairs


def _value(key: str, value: Any) -> Any:
    """An override value: a number, boolean, string or a list of them (frozen)."""
    if isinstance(value, list):
        return tuple(_value(f"{key}[{i}]", v) for i, v in enumerate(value))
    if isinstance(value, bool | str):
        return value
    if isinstance(value, int | float):
        _number(key, value)
        return value
    raise _Invalid(key, f"expected a number, boolean, string or list, got {value!r}")


def _mission_format(parse: Callable[[str, Any], T], key: str, value: Any) -> T:
    """``parse(key, value)`` of the mission YAML format (:mod:`auv_common.mission_yaml`, the one parser of
    goals and obstacles: the vehicle's ``--mission`` files and ``auv-gcs`` read them with it too); its
    problem as a spec problem at the same key."""
    try:
        return parse(key, value)
    except mission_yaml.MissionYamlError as exc:
        raise _Invalid(exc.key, exc.problem) from None


def _refuse_problems(key: str, problems: list[Any]) -> None:
    """The first of the vehicle validator's problems (``onboard.core.mission.validate.Problem``) at the key
    of its field."""
    if problems:
        p = problems[0]
        raise _Invalid(_join(key, _KEY_OF_FIELD.get(p.field, "")), p.reason)


def _start(key: str, value: Any) -> tuple[float, float, float, float]:
    """The start pose (the simulator's initial state, not a goal): finite, a heading, depth >= 0."""
    pose = _mission_format(functools.partial(mission_yaml.parse_goal, yaw_required=True), key, value)
    for k in ("x_m", "y_m", "depth_m", "yaw_deg"):
        v = getattr(pose, k)
        if v is not None and not math.isfinite(v):
            raise _Invalid(_join(key, k), f"must be finite, got {v!r}")
    _not_above_surface(key, pose.depth_m)
    if pose.yaw_deg is None:
        raise _Invalid(_join(key, "yaw_deg"), "the start needs a heading")
    return pose.x_m, pose.y_m, pose.depth_m, pose.yaw_deg


def _not_above_surface(key: str, depth_m: float) -> None:
    if depth_m < 0.0:
        raise _Invalid(
            _join(key, "depth_m"), f"must be >= 0 (positive down; < 0 is above the surface), got {depth_m:g}"
        )


def _goal(key: str, index: int, value: Any) -> mission_yaml.GoalPose:
    """A goal pose in the mission format (with its acceptance radius ``radius_m``, 0 = the vehicle's
    default); its values judged by the onboard's one rule (``check_goal_values``: finite, depth >= 0, a yaw
    NaN or within +-360 deg, a radius 0 or within MIS_ARRIVE_R_M's range), so a spec refuses what the
    vehicle would."""
    from onboard.core.mission.model import Goal
    from onboard.core.mission.validate import check_goal_values

    g = _mission_format(mission_yaml.parse_goal, key, value)
    yaw_rad = None if g.yaw_deg is None else math.radians(g.yaw_deg)
    _refuse_problems(key, check_goal_values(index, Goal(g.x_m, g.y_m, g.depth_m, yaw_rad, g.radius_m)))
    return g


def _obstacle(key: str, index: int, value: Any) -> tuple[float, float, float]:
    """An obstacle circle in the mission format; its values judged by the onboard's one rule
    (``check_obstacle_values``: finite, radius > 0)."""
    from onboard.core.mission.model import Obstacle
    from onboard.core.mission.validate import check_obstacle_values

    c = _mission_format(mission_yaml.parse_circle, key, value)
    _refuse_problems(key, check_obstacle_values(index, Obstacle(c.x_m, c.y_m, c.radius_m)))
    return c.x_m, c.y_m, c.radius_m


def _mission(key: str, value: Any, default_name: str) -> MissionSpec:
    item = _mapping(key, value, _MISSION_KEYS, ("start", "goals"))
    name = _name(_join(key, "name"), item["name"]) if "name" in item else default_name
    start = _start(_join(key, "start"), item["start"])
    poses = tuple(
        _goal(f"{key}.goals[{i}]", i, g)
        for i, g in enumerate(_list(_join(key, "goals"), item["goals"], non_empty=True))
    )
    obstacles = tuple(
        _obstacle(f"{key}.obstacles[{i}]", i, raw)
        for i, raw in enumerate(_list(_join(key, "obstacles"), item.get("obstacles") or []))
    )
    goals = tuple((g.x_m, g.y_m, g.depth_m, g.yaw_deg) for g in poses)
    radii = tuple(g.radius_m for g in poses) if any(g.radius_m for g in poses) else ()
    return MissionSpec(name, start, goals, obstacles, radii)


def _range(key: str, value: Any, *, integer: bool) -> tuple[Any, Any]:
    """``[lo, hi]`` (or one value for both), lo <= hi."""
    raw = value if isinstance(value, list) else [value, value]
    if len(raw) != 2:
        raise _Invalid(key, f"expected [lo, hi], got {value!r}")
    check = _integer if integer else _number
    lo, hi = check(f"{key}[0]", raw[0]), check(f"{key}[1]", raw[1])
    if lo > hi:
        raise _Invalid(key, f"expected lo <= hi, got {value!r}")
    return lo, hi


def _max_obstacles() -> int:
    """The onboard's ``[mission] max_obstacles`` (the packaged ``onboard.toml``)."""
    from onboard.app.runtime import build_config

    return int(build_config(None, []).mission.max_obstacles)


def _random(key: str, value: Any, seed_offset: int) -> dict[str, Any]:
    """The checked arguments of :func:`random_missions` (none drawn yet: the run count is checked first)."""
    item = _mapping(key, value, _RANDOM_KEYS, ("count", "seed", "area_m"))
    count = _integer(f"{key}.count", item["count"], 1, MAX_RANDOM_MISSIONS)
    seed = _integer(f"{key}.seed", item["seed"], 0) + seed_offset
    if seed < 0:
        raise _Invalid(f"{key}.seed", f"seed + offset must be >= 0, got {seed}")
    area = _positive(f"{key}.area_m", item["area_m"])
    obstacles = _range(f"{key}.obstacles", item.get("obstacles", 0), integer=True)
    if obstacles[0] < 0:
        raise _Invalid(f"{key}.obstacles", f"must be >= 0, got {item['obstacles']!r}")
    cap = _max_obstacles()
    if obstacles[1] > cap:
        raise _Invalid(
            f"{key}.obstacles",
            f"must be <= {cap} (the onboard's [mission] max_obstacles), got {item['obstacles']!r}",
        )
    radius = _range(f"{key}.radius_m", item.get("radius_m", [1.0, 4.0]), integer=False)
    if radius[0] <= 0.0:
        raise _Invalid(f"{key}.radius_m", f"must be > 0, got {item['radius_m']!r}")
    depth = _range(f"{key}.depth_m", item.get("depth_m", 1.0), integer=False)
    if depth[0] < 0.0:
        raise _Invalid(
            f"{key}.depth_m",
            f"must be >= 0 (positive down; < 0 is above the surface), got {item['depth_m']!r}",
        )
    goals = _integer(f"{key}.goals", item.get("goals", 1), 1, MAX_RANDOM_GOALS)
    min_distance = None
    if item.get("min_distance_m") is not None:
        min_distance = _number(f"{key}.min_distance_m", item["min_distance_m"])
        if not 0.0 <= min_distance <= area:
            raise _Invalid(
                f"{key}.min_distance_m", f"must be in [0, area_m = {area:g}], got {min_distance:g}"
            )
    return {
        "count": count,
        "seed": seed,
        "area_m": area,
        "obstacles": obstacles,
        "radius_m": radius,
        "depth_m": depth,
        "goals": goals,
        "min_distance_m": min_distance,
    }


def _axis(sweep: dict[str, Any], name: str, default: list[Any]) -> list[Any]:
    if name not in sweep:
        return default
    return _list(f"sweep.{name}", sweep[name], non_empty=True)


def _canonical(pairs: tuple[tuple[str, Any], ...]) -> tuple[tuple[str, Any], ...]:
    """Pairs in key order (two entries with the same keys and values in another order are the same)."""
    return tuple(sorted(pairs, key=lambda kv: kv[0]))


def _no_duplicates(axis: str, labels: list[Any]) -> None:
    seen: dict[Any, int] = {}
    for i, label in enumerate(labels):
        if label in seen:
            raise _Invalid(
                f"sweep.{axis}[{i}]", f"same as sweep.{axis}[{seen[label]}] (run ids would collide)"
            )
        seen[label] = i


def _reraise(key: str, text: str) -> _Invalid:
    """A loader's message ``SUBKEY: what`` (``SUBKEY`` may be empty) as a problem at ``key.SUBKEY``."""
    sub, sep, message = text.partition(": ")
    if sep and sub and " " not in sub:
        return _Invalid(f"{key}.{sub}", message)
    return _Invalid(key, text)


def _owned(key: str, dotted: str) -> None:
    """Refuse an override of a table the campaign sets (:data:`CAMPAIGN_TABLES`)."""
    table = dotted.split(".", 1)[0]
    if table in CAMPAIGN_TABLES:
        raise _Invalid(
            f"{key}.{dotted}",
            f"[{table}] is set by the campaign for every run ([bus], [loop] and [mavlink] are the "
            "campaign's), not an onboard override",
        )


def _check_onboard(key: str, sets: list[str]) -> None:
    """The onboard's own loader judges the overrides (unknown keys, types, ranges); the campaign's tables
    are refused first."""
    from onboard.app.config import DEFAULT_CONFIG_PATH
    from onboard.app.runtime import build_config

    for entry in sets:
        _owned(key, entry.partition("=")[0].strip())
    try:
        build_config(None, sets)
    except ConfigError as exc:
        text, base = str(exc), str(DEFAULT_CONFIG_PATH)
        if text.startswith(base + "."):
            raise _reraise(key, text[len(base) + 1 :]) from None
        raise _Invalid(key, text.removeprefix(base + ": ")) from None


def check_onboard_sets(key: str, sets: list[str]) -> None:
    """Judge ``auv-onboard run --set`` arguments (``KEY=VALUE``, as :meth:`RunSpec.onboard_sets`) as a
    campaign would: refused if one sets a table of :data:`CAMPAIGN_TABLES`, or if the onboard's own loader
    refuses them over the packaged ``onboard.toml`` (unknown keys, types, ranges).

    Raises :class:`SpecError`, one line ``KEY[.SUBKEY]: what`` naming ``key`` (the caller puts its file in
    ``key`` if it wants it there, e.g. ``"tune.yaml: params"``), e.g.
    ``sweep.onboard[0].loop.telemetry_csv: [loop] is set by the campaign ...``.
    """
    try:
        _check_onboard(key, list(sets))
    except _Invalid as exc:
        raise SpecError(str(exc)) from None


def _check_vehicle(key: str, scale: dict[str, float], sets: dict[str, Any]) -> None:
    """The simulator's parameter loader judges the variant (groups, key paths, types, ranges)."""
    from hil_sim.model.variants import vehicle_params

    for dotted in sets:
        if dotted in _CURRENT_MEAN_KEYS:
            raise _Invalid(
                f"{key}.set.{dotted}",
                "the mean current is the sweep's current axis ([speed_mps, direction_deg]); a vehicle "
                "variant may set only its variation (current.variation_std_mps, "
                "current.variation_period_s)",
            )
    try:
        vehicle_params(scale, {k: _thaw(v) for k, v in sets.items()}, where=key)
    except ConfigError as exc:
        text = str(exc)
        if text.startswith(key + "."):
            raise _reraise(key, text[len(key) + 1 :]) from None
        raise _Invalid(key, text.removeprefix(key + ": ")) from None


def _describe_pairs(pairs: Iterable[tuple[str, Any]]) -> str:
    return ", ".join(set_argument(k, v) for k, v in pairs)


def parse_spec(data: Any, where: str, *, seed_offset: int = 0, random_seed_offset: int = 0) -> CampaignSpec:
    """Check and expand parsed YAML (``where`` names it in errors); raises :class:`SpecError`.

    ``seed_offset`` is added to every sweep seed, ``random_seed_offset`` to ``random_missions.seed`` (a
    held-out set drawn from the same spec).
    """
    try:
        return _parse(data, where, seed_offset, random_seed_offset)
    except _Invalid as exc:
        raise SpecError(f"{where}: {exc}") from None


def _parse(data: Any, where: str, seed_offset: int, random_seed_offset: int) -> CampaignSpec:
    if not isinstance(data, dict):
        raise _Invalid("spec", f"expected a mapping with name, missions and sweep, got {type(data).__name__}")
    top = _mapping("", data, _TOP_KEYS, ("name",))
    name = _name("name", top["name"])

    # Missions: the listed ones, then the random ones.
    missions: list[MissionSpec] = []
    listed = top.get("missions")
    if listed is not None:
        missions = [_mission(f"missions[{i}]", m, f"m{i}") for i, m in enumerate(_list("missions", listed))]
    drawn: dict[str, Any] | None = None
    if top.get("random_missions") is not None:
        drawn = _random("random_missions", top["random_missions"], random_seed_offset)
    n_missions = len(missions) + (drawn["count"] if drawn else 0)
    if not n_missions:
        raise _Invalid("missions", "no mission (give missions or random_missions)")

    # Sweep axes.
    sweep = _mapping("sweep", top.get("sweep"), _SWEEP_KEYS)
    seeds: list[int] = []
    for i, raw in enumerate(_axis(sweep, "seed", [0])):
        seed = _integer(f"sweep.seed[{i}]", raw) + seed_offset
        if seed < 0:
            raise _Invalid(f"sweep.seed[{i}]", f"seed + offset must be >= 0, got {seed}")
        seeds.append(seed)
    _no_duplicates("seed", seeds)

    currents: list[tuple[float, float]] = []
    for i, raw in enumerate(_axis(sweep, "current", [[0.0, 0.0]])):
        key = f"sweep.current[{i}]"
        if not isinstance(raw, list) or len(raw) != 2:
            raise _Invalid(key, f"expected [speed_mps, direction_deg], got {raw!r}")
        speed, direction = _number(f"{key}[0]", raw[0]), _number(f"{key}[1]", raw[1])
        if not 0.0 <= speed <= MAX_CURRENT_MPS:
            raise _Invalid(key, f"speed must be in [0, {MAX_CURRENT_MPS:g}] m/s, got {speed:g}")
        if not -360.0 <= direction <= 360.0:
            raise _Invalid(key, f"direction must be in [-360, 360] deg, got {direction:g}")
        currents.append(normalise_current(speed, direction))
    _no_duplicates("current", [current_label(s, d) for s, d in currents])

    profiles: list[str] = []
    for i, raw in enumerate(_axis(sweep, "profile", ["basin"])):
        if raw not in PROFILES:
            raise _Invalid(f"sweep.profile[{i}]", f"must be one of {', '.join(PROFILES)}, got {raw!r}")
        profiles.append(raw)
    _no_duplicates("profile", profiles)

    onboards: list[tuple[str, tuple[tuple[str, Any], ...]]] = []
    for i, raw in enumerate(_axis(sweep, "onboard", [{}])):
        key = f"sweep.onboard[{i}]"
        pairs = tuple(_flatten(key, raw))
        for k, _ in pairs:
            if "." not in k:
                raise _Invalid(f"{key}.{k}", "expected a dotted key TABLE.KEY of onboard.toml")
            _owned(key, k)
        label = f"o{i}" if pairs else "default"
        onboards.append((label, pairs))
    _no_duplicates("onboard", [_canonical(p) for _, p in onboards])
    _no_duplicates("onboard", [label for label, _ in onboards])

    vehicles: list[tuple[str, tuple[tuple[str, float], ...], tuple[tuple[str, Any], ...]]] = []
    for i, raw in enumerate(_axis(sweep, "vehicle", [{}])):
        key = f"sweep.vehicle[{i}]"
        item = _mapping(key, raw, _VEHICLE_KEYS)
        scale_raw = _any_mapping(f"{key}.scale", item.get("scale"))
        scale = tuple((str(g), _number(f"{key}.scale.{g}", f)) for g, f in scale_raw.items())
        sets = tuple(_flatten(f"{key}.set", item.get("set")))
        label = f"v{i}" if scale or sets else "nominal"
        vehicles.append((label, scale, sets))
    _no_duplicates("vehicle", [(_canonical(s), _canonical(t)) for _, s, t in vehicles])
    _no_duplicates("vehicle", [label for label, _, _ in vehicles])

    fault_lists = _fault_axis(sweep)
    # The size, before anything is drawn or expanded.
    sizes = {
        "mission": n_missions,
        "seed": len(seeds),
        "current": len(currents),
        "profile": len(profiles),
        "onboard": len(onboards),
        "vehicle": len(vehicles),
        FAULT_AXIS: len(fault_lists),
    }
    total = math.prod(sizes.values())
    if total > MAX_RUNS:
        raise _Invalid(
            "sweep",
            f"{total} runs ({' x '.join(f'{n} {axis}' for axis, n in sizes.items())}) exceed the cap of "
            f"{MAX_RUNS} runs",
        )

    time_limit_factor = _positive("time_limit_factor", top.get("time_limit_factor", 2.0))
    success = _mapping("success", top.get("success"), _SUCCESS_KEYS)
    position_m = _positive("success.position_m", success.get("position_m", 0.3))
    course_deg = _positive("success.course_deg", success.get("course_deg", 10.0))
    cross_track_m = (
        None
        if success.get("cross_track_m") is None
        else _positive("success.cross_track_m", success["cross_track_m"])
    )
    depth_m = None if success.get("depth_m") is None else _positive("success.depth_m", success["depth_m"])
    observe_s = _number("observe_after_end_s", top.get("observe_after_end_s", OBSERVE_AFTER_END_S))
    if not 0.0 <= observe_s <= MAX_OBSERVE_AFTER_END_S:
        raise _Invalid(
            "observe_after_end_s", f"must be in [0, {MAX_OBSERVE_AFTER_END_S:g}] s, got {observe_s:g}"
        )

    # The onboard and the simulator judge their own overrides, once per entry.
    for i, (_, pairs) in enumerate(onboards):
        if pairs:
            _check_onboard(f"sweep.onboard[{i}]", [set_argument(k, v) for k, v in pairs])
    for i, (_, scale, sets) in enumerate(vehicles):
        if scale or sets:
            _check_vehicle(f"sweep.vehicle[{i}]", dict(scale), dict(sets))

    if drawn is not None:
        missions += random_missions(**drawn)
    names: dict[str, int] = {}
    for i, m in enumerate(missions):
        if m.name in names:
            key = f"missions[{i}].name" if i < len(listed or []) else "random_missions"
            raise _Invalid(key, f"duplicate mission name {m.name!r} (run ids would collide)")
        names[m.name] = i

    runs: list[RunSpec] = []
    for mission, seed, (speed, direction), profile, (o_label, pairs), (
        v_label,
        scale,
        sets,
    ), (f_label, faults) in itertools.product(
        missions, seeds, currents, profiles, onboards, vehicles, fault_lists
    ):
        runs.append(
            RunSpec(
                run_id=make_run_id(mission.name, seed, speed, direction, profile, o_label, v_label, f_label),
                mission=mission,
                seed=seed,
                current_speed_mps=speed,
                current_dir_deg=direction,
                profile=profile,
                onboard=pairs,
                onboard_label=o_label,
                vehicle_scale=scale,
                vehicle_set=sets,
                vehicle_label=v_label,
                time_limit_factor=time_limit_factor,
                success_position_m=position_m,
                success_course_deg=course_deg,
                success_cross_track_m=cross_track_m,
                observe_after_end_s=observe_s,
                success_depth_m=depth_m,
                faults=faults,
                faults_label=f_label,
            )
        )
    ids: set[str] = set()
    for run in runs:
        if run.run_id in ids:  # pragma: no cover - the per-axis checks above prevent it
            raise _Invalid("spec", f"run id {run.run_id!r} twice")
        ids.add(run.run_id)

    axes = {
        "mission": [m.name for m in missions],
        "seed": [seed_label(s) for s in seeds],
        "current": [current_label(s, d) for s, d in currents],
        "profile": list(profiles),
        "onboard": [label for label, _ in onboards],
        "vehicle": [label for label, _, _ in vehicles],
    }
    if "faults" in sweep:
        axes[FAULT_AXIS] = [fault_model.describe(faults) for _, faults in fault_lists]
    legend = {
        "onboard": {label: _describe_pairs(pairs) or "packaged onboard.toml" for label, pairs in onboards},
        "vehicle": {
            label: "; ".join(
                part
                for part in (
                    f"scale {_describe_pairs(scale)}" if scale else "",
                    f"set {_describe_pairs(sets)}" if sets else "",
                )
                if part
            )
            or "packaged isimi100.toml"
            for label, scale, sets in vehicles
        },
    }
    return CampaignSpec(name=name, path=where, runs=tuple(runs), axes=axes, legend=legend)


def _fault_axis(sweep: dict[str, Any]) -> list[tuple[str, tuple[Fault, ...]]]:
    """``sweep.faults``: (run id label, faults) per entry, parsed by the bench's own parser
    (:func:`hil_sim.model.faults.parse_faults`); without the key one entry ``("", ())``: no axis, the run ids
    of a spec without faults. A label is the kinds (``none``, ``dvl_dropout``, ``fin_stuck+thrust_loss``),
    with ``-<index>`` when two entries share their kinds."""
    if "faults" not in sweep:
        return [("", ())]
    entries: list[tuple[str, tuple[Fault, ...]]] = []
    for i, raw in enumerate(_list("sweep.faults", sweep["faults"], non_empty=True)):
        key = f"sweep.faults[{i}]"
        if not isinstance(raw, list):
            raise _Invalid(key, f"expected a list of faults ([] for none), got {raw!r}")
        try:
            faults = fault_model.parse_faults(raw)
        except fault_model.FaultError as exc:
            raise _Invalid(f"{key}{exc.key}", exc.problem) from None
        entries.append((fault_model.short_label(faults), faults))
    _no_duplicates(FAULT_AXIS, [fault_model.describe(faults) for _, faults in entries])
    kinds = [label for label, _ in entries]
    return [(label if kinds.count(label) == 1 else f"{label}-{i}", f) for i, (label, f) in enumerate(entries)]


def load_spec(path: str | Path, *, seed_offset: int = 0, random_seed_offset: int = 0) -> CampaignSpec:
    """Read (``yaml.safe_load``), check and expand a campaign spec file; raises :class:`SpecError`."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise SpecError(f"{p}: no such spec file") from None
    except OSError as exc:
        raise SpecError(f"{p}: cannot read: {exc.strerror}") from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise SpecError(f"{p}: not valid YAML: {yaml_error_line(exc)}") from None
    return parse_spec(data, str(p), seed_offset=seed_offset, random_seed_offset=random_seed_offset)


__all__ = [
    "AXES",
    "CAMPAIGN_TABLES",
    "FAULT_AXIS",
    "MAX_CURRENT_MPS",
    "MAX_RANDOM_GOALS",
    "MAX_RANDOM_MISSIONS",
    "MAX_RUNS",
    "PROFILES",
    "CampaignSpec",
    "MissionSpec",
    "RunSpec",
    "SpecError",
    "check_onboard_sets",
    "current_label",
    "load_spec",
    "make_run_id",
    "normalise_current",
    "parse_spec",
    "random_missions",
    "seed_label",
]
