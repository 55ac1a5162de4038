"""Campaign spec: expansion, run ids, defaults, JSON round trip, random missions, one error per bad key."""

from __future__ import annotations

import copy
import itertools
import json
import math
import re
from pathlib import Path
from typing import Any

import pytest

from auv_campaign.results import ID_COLUMNS
from auv_campaign.spec import (
    AXES,
    CAMPAIGN_TABLES,
    MAX_RANDOM_GOALS,
    MAX_RANDOM_MISSIONS,
    MAX_RUNS,
    CampaignSpec,
    MissionSpec,
    RunSpec,
    SpecError,
    check_onboard_sets,
    current_label,
    load_spec,
    normalise_current,
    parse_spec,
    random_missions,
)
from auv_common.config import ConfigError

EXAMPLE = Path(__file__).with_name("example.yaml")


def minimal() -> dict[str, Any]:
    return {
        "name": "t",
        "missions": [
            {
                "start": {"x_m": -15, "y_m": 5, "depth_m": 1, "yaw_deg": 0},
                "goals": [{"x_m": 10, "y_m": -2, "depth_m": 1, "yaw_deg": 270}],
            }
        ],
    }


@pytest.fixture(scope="module")
def example() -> CampaignSpec:
    return load_spec(EXAMPLE)


@pytest.fixture(scope="module")
def example_listed() -> CampaignSpec:
    """The example without its random missions."""
    import yaml

    data = yaml.safe_load(EXAMPLE.read_text())
    del data["random_missions"]
    return parse_spec(data, "example.yaml")


# ----------------------------------------------------------------------------------------------------
# Expansion


def test_example_expands_to_the_product(example_listed: CampaignSpec, example: CampaignSpec) -> None:
    assert len(example_listed.runs) == 1 * 3 * 3 * 2 * 2 * 2 == 72
    assert len(example.runs) == 72 + 50 * 72
    assert example.name == "turn-in-current"
    assert example.path == str(EXAMPLE)
    assert list(example.axes) == list(AXES)
    counts = [len(example.axes[a]) for a in AXES]
    assert counts == [51, 3, 3, 2, 2, 2]
    assert math.prod(counts) == len(example.runs)


def test_axes_and_labels(example_listed: CampaignSpec) -> None:
    assert example_listed.axes == {
        "mission": ["m0"],
        "seed": ["s0", "s1", "s2"],
        "current": ["c0d0", "c0.3d0", "c0.3d90"],
        "profile": ["basin", "sea"],
        "onboard": ["default", "o1"],
        "vehicle": ["nominal", "v1"],
    }
    for run in example_listed.runs:
        labels = run.axis_labels()
        assert set(labels) == set(AXES)
        for axis, label in labels.items():
            assert label in example_listed.axes[axis]
    assert example_listed.legend["onboard"]["o1"] == "control.improved.Kp5=-0.3"
    assert "fin_lift=0.7" in example_listed.legend["vehicle"]["v1"]


def test_run_ids_unique_stable_and_filename_safe(example: CampaignSpec) -> None:
    ids = [r.run_id for r in example.runs]
    assert len(set(ids)) == len(ids)
    assert all(re.fullmatch(r"[A-Za-z0-9_.-]+", i) for i in ids)
    again = load_spec(EXAMPLE)
    assert [r.run_id for r in again.runs] == ids
    assert again.runs == example.runs
    assert "m0_s0_c0.3d90_basin_default_nominal" in ids


def test_run_order_missions_outer_vehicle_inner(example_listed: CampaignSpec) -> None:
    ids = [r.run_id for r in example_listed.runs]
    assert ids[:5] == [
        "m0_s0_c0d0_basin_default_nominal",
        "m0_s0_c0d0_basin_default_v1",
        "m0_s0_c0d0_basin_o1_nominal",
        "m0_s0_c0d0_basin_o1_v1",
        "m0_s0_c0d0_sea_default_nominal",
    ]
    assert ids[-1] == "m0_s2_c0.3d90_sea_o1_v1"
    run = example_listed.runs[3]
    assert run.onboard == (("control.improved.Kp5", -0.3),)
    assert dict(run.vehicle_scale) == {
        "fin_lift": 0.7,
        "added_mass": 1.25,
        "damping": 1.25,
        "actuator_time": 1.3,
    }
    assert run.vehicle_set == ()


def test_defaults() -> None:
    spec = parse_spec(minimal(), "spec.yaml")
    (run,) = spec.runs
    assert run.run_id == "m0_s0_c0d0_basin_default_nominal"
    assert (run.seed, run.current_speed_mps, run.current_dir_deg, run.profile) == (0, 0.0, 0.0, "basin")
    assert (run.onboard, run.onboard_label, run.vehicle_scale, run.vehicle_set, run.vehicle_label) == (
        (),
        "default",
        (),
        (),
        "nominal",
    )
    assert (run.time_limit_factor, run.success_position_m, run.success_course_deg) == (2.0, 0.3, 10.0)
    assert run.mission == MissionSpec("m0", (-15.0, 5.0, 1.0, 0.0), ((10.0, -2.0, 1.0, 270.0),), ())
    assert run.onboard_sets() == []


def test_free_heading_names_and_obstacles() -> None:
    data = minimal()
    data["missions"][0]["goals"] = [
        {"x_m": 1, "y_m": 2, "depth_m": 3},
        {"x_m": 4, "y_m": 5, "depth_m": 1, "yaw_deg": None},
    ]
    data["missions"][0]["obstacles"] = [{"x_m": 0, "y_m": 3, "radius_m": 1.5}]
    data["missions"].append({**copy.deepcopy(data["missions"][0]), "name": "second"})
    spec = parse_spec(data, "spec.yaml")
    first, second = (r.mission for r in spec.runs)
    assert first.goals == ((1.0, 2.0, 3.0, None), (4.0, 5.0, 1.0, None))
    assert first.obstacles == ((0.0, 3.0, 1.5),)
    assert (first.name, second.name) == ("m0", "second")
    assert first.to_mission_file() == {
        "goals": [{"x_m": 1.0, "y_m": 2.0, "depth_m": 3.0}, {"x_m": 4.0, "y_m": 5.0, "depth_m": 1.0}],
        "obstacles": [{"x_m": 0.0, "y_m": 3.0, "radius_m": 1.5}],
    }


def test_mission_file_format_is_the_onboards() -> None:
    from onboard.app.mission_file import parse_mission

    mission = parse_spec(minimal(), "spec.yaml").runs[0].mission
    parsed = parse_mission(mission.to_mission_file(), "m0")
    assert len(parsed.goals) == 1


def test_seed_offsets() -> None:
    data = minimal()
    data["sweep"] = {"seed": [0, 1]}
    data["random_missions"] = {"count": 2, "seed": 7, "area_m": 40}
    base = parse_spec(data, "spec.yaml")
    shifted = parse_spec(data, "spec.yaml", seed_offset=100, random_seed_offset=1)
    assert sorted({r.seed for r in shifted.runs}) == [100, 101]
    assert shifted.axes["seed"] == ["s100", "s101"]
    assert not {r.run_id for r in shifted.runs} & {r.run_id for r in base.runs}
    held_out = [r.mission for r in shifted.runs if r.mission.name.startswith("r")]
    assert held_out[0] in random_missions(2, 8, 40.0)
    assert held_out[0] not in random_missions(2, 7, 40.0)


def test_identity_matches_the_result_columns(example_listed: CampaignSpec) -> None:
    run = example_listed.runs[-1]
    assert tuple(run.identity()) == ID_COLUMNS
    assert run.identity()["onboard"] == "o1"
    assert run.identity()["vehicle"] == "v1"


# ----------------------------------------------------------------------------------------------------
# Onboard overrides and the JSON round trip


def test_onboard_set_syntax_is_the_onboards() -> None:
    from onboard.app.runtime import build_config

    data = minimal()
    data["sweep"] = {
        "onboard": [
            {
                "guidance.mode": "los",
                "control.improved.Kp5": -0.3,
                "control.speed_map_mps": [0.0, 1.5, 2.0],
                "mission.max_tries": 2,
            }
        ]
    }
    (run,) = parse_spec(data, "spec.yaml").runs
    assert run.onboard_sets() == [
        'guidance.mode="los"',
        "control.improved.Kp5=-0.3",
        "control.speed_map_mps=[0.0, 1.5, 2.0]",
        "mission.max_tries=2",
    ]
    assert run.onboard_label == "o0"
    cfg = build_config(None, run.onboard_sets())
    assert cfg.guidance.mode == "los"
    assert cfg.mission.max_tries == 2


def test_nested_onboard_overrides_are_flattened() -> None:
    data = minimal()
    data["sweep"] = {"onboard": [{"control": {"improved": {"Kp5": -0.3}}, "guidance.mode": "ilos"}]}
    (run,) = parse_spec(data, "spec.yaml").runs
    assert run.onboard == (("control.improved.Kp5", -0.3), ("guidance.mode", "ilos"))


def test_round_trip(example_listed: CampaignSpec) -> None:
    data = minimal()
    data["missions"][0]["goals"].append({"x_m": 3, "y_m": 4, "depth_m": 2})
    data["missions"][0]["obstacles"] = [{"x_m": 0, "y_m": 3, "radius_m": 1.5}]
    data["sweep"] = {
        "onboard": [{"control.speed_map_mps": [0.0, 1.5, 2.0], "guidance.mode": "los"}],
        "vehicle": [{"set": {"fins.area_m2": 0.035}, "scale": {"fin_lift": 0.9}}],
        "current": [[0.25, -45]],
    }
    runs = list(parse_spec(data, "spec.yaml").runs) + list(example_listed.runs)
    for run in runs:
        back = RunSpec.from_dict(json.loads(json.dumps(run.to_dict())))
        assert back == run
        assert hash(back) == hash(run)
        assert back.onboard_sets() == run.onboard_sets()
    assert runs[0].onboard[0][1] == (0.0, 1.5, 2.0)
    assert runs[0].mission.goals[1][3] is None
    assert runs[0].run_id == "m0_s0_c0.25d315_basin_o0_v0"  # -45 deg normalised to [0, 360)
    assert runs[0].current_dir_deg == 315.0


# ----------------------------------------------------------------------------------------------------
# Random missions


def test_random_missions_deterministic() -> None:
    a = random_missions(20, 3, 60.0, obstacles=(0, 5), radius_m=(1.0, 4.0), depth_m=(1.0, 3.0), goals=2)
    b = random_missions(20, 3, 60.0, obstacles=(0, 5), radius_m=(1.0, 4.0), depth_m=(1.0, 3.0), goals=2)
    assert a == b
    assert a != random_missions(
        20, 4, 60.0, obstacles=(0, 5), radius_m=(1.0, 4.0), depth_m=(1.0, 3.0), goals=2
    )
    assert [m.name for m in a] == [f"r{i}" for i in range(20)]


def _on_grid(value: float, step: float) -> bool:
    return abs(value / step - round(value / step)) < 1e-6


def test_random_missions_respect_the_constraints() -> None:
    area, min_d = 60.0, 15.0
    missions = random_missions(
        200,
        11,
        area,
        obstacles=(1, 4),
        radius_m=(1.0, 4.0),
        depth_m=(0.5, 2.0),
        goals=2,
        min_distance_m=min_d,
    )
    counts = set()
    for m in missions:
        points = [m.start[:2]] + [g[:2] for g in m.goals]
        for x, y in points:
            assert -area / 2 <= x <= area / 2 and -area / 2 <= y <= area / 2
            assert _on_grid(x, 0.01) and _on_grid(y, 0.01)
        for a, b in itertools.pairwise(points):
            assert math.dist(a, b) >= min_d
        for pose in (m.start, *m.goals):
            assert pose[3] is not None and 0.0 <= pose[3] < 360.0 and _on_grid(pose[3], 0.1)
            assert 0.5 <= pose[2] <= 2.0
        assert len(m.goals) == 2
        assert len(m.obstacles) <= 4
        counts.add(len(m.obstacles))
        for cx, cy, r in m.obstacles:
            assert 1.0 <= r <= 4.0
            assert -area / 2 <= cx <= area / 2 and -area / 2 <= cy <= area / 2
            assert all(math.dist((cx, cy), p) > r + 0.5 for p in points)
    assert counts >= {1, 2, 3, 4}  # the whole (inclusive) range is drawn


def test_random_missions_default_distance_and_no_obstacles() -> None:
    for m in random_missions(100, 0, 30.0):
        assert math.dist(m.start[:2], m.goals[0][:2]) >= 10.0
        assert m.obstacles == ()
        assert m.start[2] == 1.0


def test_random_missions_bad_arguments() -> None:
    with pytest.raises(ValueError, match="min_distance_m"):
        random_missions(1, 0, 10.0, min_distance_m=20.0)
    with pytest.raises(ValueError, match="radius_m"):
        random_missions(1, 0, 10.0, radius_m=(0.0, 1.0))
    with pytest.raises(ValueError, match="count"):
        random_missions(MAX_RANDOM_MISSIONS + 1, 0, 10.0)
    with pytest.raises(ValueError, match="goals"):
        random_missions(1, 0, 10.0, goals=MAX_RANDOM_GOALS + 1)
    with pytest.raises(ValueError, match="depth_m"):
        random_missions(1, 0, 10.0, depth_m=(-1.0, 1.0))


def test_random_missions_in_a_spec() -> None:
    data = {"name": "r", "random_missions": {"count": 3, "seed": 5, "area_m": 40, "obstacles": 2, "goals": 2}}
    spec = parse_spec(data, "spec.yaml")
    assert [r.mission for r in spec.runs] == random_missions(3, 5, 40.0, obstacles=(2, 2), goals=2)


# ----------------------------------------------------------------------------------------------------
# Caps, currents, the campaign's onboard tables


def test_caps_are_documented_and_the_obstacle_cap_is_the_onboards() -> None:
    import auv_campaign.spec as module
    from onboard.app.runtime import build_config

    doc = module.__doc__ or ""
    for text in ("100000", "<= 100 ", "max_obstacles", "64", "1000000", "[bus]", "[loop]", "[mavlink]"):
        assert text in doc, text
    assert (MAX_RANDOM_MISSIONS, MAX_RANDOM_GOALS, MAX_RUNS) == (100_000, 100, 1_000_000)
    assert set(CAMPAIGN_TABLES) == {"bus", "loop", "mavlink"}
    cap = build_config(None, []).mission.max_obstacles
    assert cap == 64
    data = {"name": "r", "random_missions": {"count": 1, "seed": 0, "area_m": 60, "obstacles": [0, cap]}}
    assert len(parse_spec(data, "spec.yaml").runs) == 1
    data["random_missions"]["obstacles"] = [0, cap + 1]
    with pytest.raises(SpecError, match=rf"^spec\.yaml: random_missions\.obstacles: must be <= {cap} "):
        parse_spec(data, "spec.yaml")


def test_run_count_is_refused_before_anything_is_drawn(monkeypatch: pytest.MonkeyPatch) -> None:
    import auv_campaign.spec as module

    def no_draw(*args: Any, **kwargs: Any) -> list[MissionSpec]:
        raise AssertionError("random missions drawn before the run count was checked")

    monkeypatch.setattr(module, "random_missions", no_draw)
    data = minimal()
    data["random_missions"] = {"count": MAX_RANDOM_MISSIONS, "seed": 0, "area_m": 60}
    data["sweep"] = {"seed": list(range(10))}
    with pytest.raises(SpecError) as info:
        parse_spec(data, "spec.yaml")
    message = str(info.value)
    assert message.startswith("spec.yaml: sweep: 1000010 runs (100001 mission x 10 seed x 1 current x "), (
        message
    )
    assert message.endswith(f"exceed the cap of {MAX_RUNS} runs")
    assert "\n" not in message


def test_run_count_is_the_product_of_the_axes() -> None:
    data = minimal()
    data["sweep"] = {"seed": list(range(1001)), "current": [[0.001 * i, 0] for i in range(1000)]}
    with pytest.raises(SpecError, match=r"^spec\.yaml: sweep: 1001000 runs \(1 mission x 1001 seed x 1000 "):
        parse_spec(data, "spec.yaml")


def test_currents_are_normalised() -> None:
    assert normalise_current(0.1, 360.0) == (0.1, 0.0)
    assert normalise_current(0.1, -90.0) == (0.1, 270.0)
    assert normalise_current(0.1, -360.0) == (0.1, 0.0)
    assert normalise_current(0.1, -1e-20) == (0.1, 0.0)  # rounds up to 360
    assert normalise_current(0.0, 20.0) == (0.0, 0.0)
    speed, direction = normalise_current(-0.0, -0.0)
    assert math.copysign(1.0, speed) == 1.0 and math.copysign(1.0, direction) == 1.0
    assert current_label(0.3, -90) == "c0.3d270"
    assert current_label(0.0, 45) == current_label(-0.0, 0) == "c0d0"
    data = minimal()
    data["sweep"] = {"current": [[0.1, 360], [0, 20], [0.2, -45]]}
    spec = parse_spec(data, "spec.yaml")
    assert [(r.current_speed_mps, r.current_dir_deg) for r in spec.runs] == [
        (0.1, 0.0),
        (0.0, 0.0),
        (0.2, 315.0),
    ]
    assert spec.axes["current"] == ["c0.1d0", "c0d0", "c0.2d315"]
    assert [r.run_id.split("_")[2] for r in spec.runs] == spec.axes["current"]


def test_check_onboard_sets() -> None:
    check_onboard_sets("tune", [])
    check_onboard_sets("tune", ["control.improved.Kp5=-0.3", 'guidance.mode="los"'])
    for sets, pattern in (
        (['loop.telemetry_csv="runs.csv"'], r"^tune\.loop\.telemetry_csv: \[loop\] is set by the campaign"),
        (["control.improved.Kp5=-0.3", 'bus.interface="virtual"'], r"^tune\.bus\.interface: \[bus\] is set"),
        (['mavlink.endpoints=["udpout:127.0.0.1:1"]'], r"^tune\.mavlink\.endpoints: \[mavlink\] is set"),
        (['guidance.mode="bogus"'], r"^tune\.guidance\.mode: must be one of"),
        (["bogus.x=1"], r"^tune: unknown key bogus"),
    ):
        with pytest.raises(SpecError, match=pattern) as info:
            check_onboard_sets("tune", sets)
        assert "\n" not in str(info.value)
        assert isinstance(info.value, ConfigError)


# ----------------------------------------------------------------------------------------------------
# Bad specs: one SpecError line naming the key


def _with(path: str, value: Any) -> dict[str, Any]:
    """The minimal spec with ``value`` at ``path`` (dotted; an int part indexes a list; DELETE removes)."""
    data = minimal()
    *parents, leaf = [int(p) if p.isdigit() else p for p in path.split("/")]
    node: Any = data
    for p in parents:
        if isinstance(node, dict) and p not in node:
            node[p] = {}
        node = node[p]
    if value is DELETE:
        del node[leaf]
    else:
        node[leaf] = value
    return data


class _Delete:
    """The key is removed. Its repr is stable: the test ids are the same in every process (pytest-xdist
    compares the workers' collections)."""

    def __repr__(self) -> str:
        return "DELETE"


DELETE = _Delete()
START = "missions/0/start"
GOAL = "missions/0/goals/0"

BAD: list[tuple[str, Any, str]] = [
    (
        "bogus",
        1,
        "bogus: unknown key (known: missions, name, observe_after_end_s, random_missions, success, sweep, "
        "time_limit_factor)",
    ),
    ("name", DELETE, "name: missing"),
    ("name", "has space", "name: expected a name"),
    ("missions", DELETE, "missions: no mission"),
    ("missions", [], "missions: no mission"),
    ("missions", {"a": 1}, "missions: expected a list"),
    ("missions/0/bogus", 1, "missions[0].bogus: unknown key"),
    ("missions/0/name", "a/b", "missions[0].name: expected a name"),
    (START, DELETE, "missions[0].start: missing"),
    (f"{START}/yaw_deg", DELETE, "missions[0].start.yaw_deg: missing"),
    (f"{START}/yaw_deg", None, "missions[0].start.yaw_deg: the start needs a heading"),
    (f"{START}/x_m", "far", "missions[0].start.x_m: expected a number, got 'far'"),
    (f"{START}/y_m", float("inf"), "missions[0].start.y_m: must be finite"),
    (f"{START}/zz", 1, "missions[0].start.zz: unknown key"),
    (f"{START}/depth_m", -0.5, "missions[0].start.depth_m: must be >= 0 (positive down; < 0 is above the"),
    (f"{GOAL}/depth_m", -1, "missions[0].goals[0].depth_m: depth -1 m is above the surface"),  # the vehicle's
    ("missions/0/goals", [], "missions[0].goals: must not be empty"),
    ("missions/0/goals", DELETE, "missions[0].goals: missing"),
    (f"{GOAL}/depth_m", DELETE, "missions[0].goals[0].depth_m: missing"),
    (f"{GOAL}/yaw_deg", True, "missions[0].goals[0].yaw_deg: expected a number, got True"),
    (f"{GOAL}/x_m", "1e-3", "missions[0].goals[0].x_m: expected a number, got '1e-3' (YAML reads"),
    (
        "missions/0/obstacles",
        [{"x_m": 0, "y_m": 0, "radius_m": 0}],
        "missions[0].obstacles[0].radius_m: radius 0 m must be positive",  # the vehicle's rule
    ),
    ("missions/0/obstacles", [{"x_m": 0, "y_m": 0}], "missions[0].obstacles[0].radius_m: missing"),
    ("missions/0/obstacles", 3, "missions[0].obstacles: expected a list"),
    ("sweep", [1], "sweep: expected a mapping"),
    (
        "sweep/bogus",
        [1],
        "sweep.bogus: unknown key (known: current, faults, onboard, profile, seed, vehicle)",
    ),
    ("sweep/seed", 3, "sweep.seed: expected a list, got 3"),
    ("sweep/seed", [], "sweep.seed: must not be empty"),
    ("sweep/seed", [0, 1.5], "sweep.seed[1]: expected an integer, got 1.5"),
    ("sweep/seed", [-1], "sweep.seed[0]: seed + offset must be >= 0"),
    ("sweep/seed", [0, 1, 0], "sweep.seed[2]: same as sweep.seed[0]"),
    ("sweep/current", [[0.0, 0], [0.3]], "sweep.current[1]: expected [speed_mps, direction_deg], got [0.3]"),
    ("sweep/current", [0.3, 0], "sweep.current[0]: expected [speed_mps, direction_deg], got 0.3"),
    ("sweep/current", [[3.5, 0]], "sweep.current[0]: speed must be in [0, 3] m/s, got 3.5"),
    ("sweep/current", [[-0.1, 0]], "sweep.current[0]: speed must be in [0, 3] m/s"),
    ("sweep/current", [["fast", 0]], "sweep.current[0][0]: expected a number"),
    ("sweep/current", [[0.3, float("nan")]], "sweep.current[0][1]: must be finite"),
    ("sweep/current", [[0.3, 90], [0.3, 90.0]], "sweep.current[1]: same as sweep.current[0]"),
    ("sweep/current", [[0.1, 0], [0.1, 360]], "sweep.current[1]: same as sweep.current[0]"),
    ("sweep/current", [[0.1, -90], [0.1, 270]], "sweep.current[1]: same as sweep.current[0]"),
    ("sweep/current", [[0, 10], [0.2, 0], [0, 20]], "sweep.current[2]: same as sweep.current[0]"),
    ("sweep/current", [[0.1, 361]], "sweep.current[0]: direction must be in [-360, 360] deg"),
    ("sweep/profile", ["basin", "lake"], "sweep.profile[1]: must be one of basin, sea, got 'lake'"),
    ("sweep/profile", ["sea", "sea"], "sweep.profile[1]: same as sweep.profile[0]"),
    ("sweep/onboard", [{}, {}], "sweep.onboard[1]: same as sweep.onboard[0]"),
    ("sweep/onboard", [{}, [1]], "sweep.onboard[1]: expected a mapping"),
    ("sweep/onboard", [{"a.b": 1}, {"a.b": 1}], "sweep.onboard[1]: same as sweep.onboard[0]"),
    ("sweep/onboard", [{"Kp5": -0.3}], "sweep.onboard[0].Kp5: expected a dotted key"),
    (
        "sweep/onboard",
        [{"guidance.mode": None}],
        "sweep.onboard[0].guidance.mode: expected a number, boolean",
    ),
    ("sweep/onboard", [{"guidance.mode": "bogus"}], "sweep.onboard[0].guidance.mode: must be one of"),
    (
        "sweep/onboard",
        [{}, {"control.improved.Kp5": "x"}],
        "sweep.onboard[1].control.improved.Kp5: expected a number",
    ),
    ("sweep/onboard", [{"bogus.x": 1}], "sweep.onboard[0]: unknown key bogus"),
    (
        "sweep/onboard",
        [{}, {"loop.telemetry_csv": "runs.csv"}],
        "sweep.onboard[1].loop.telemetry_csv: [loop] is set by the campaign for every run",
    ),
    ("sweep/onboard", [{"loop": {"rate_hz": 50.0}}], "sweep.onboard[0].loop.rate_hz: [loop] is set by the"),
    ("sweep/onboard", [{"bus.interface": "virtual"}], "sweep.onboard[0].bus.interface: [bus] is set by the"),
    (
        "sweep/onboard",
        [{"mavlink.endpoints": ["udpout:127.0.0.1:1"]}],
        "sweep.onboard[0].mavlink.endpoints: [mavlink] is set by the campaign",
    ),
    (
        "sweep/onboard",
        [{"guidance.speed_mps": -1}],
        "sweep.onboard[0].guidance: speed_mps must be >= 0.8 m/s (min_water_speed_mps where above 0.1)",
    ),
    (
        "sweep/onboard",
        [{"control.improved.Kp5": 1, "control": {"improved": {"Kp5": 2}}}],
        "sweep.onboard[0].control.improved.Kp5: set twice",
    ),
    ("sweep/vehicle", [{}, {"scales": {}}], "sweep.vehicle[1].scales: unknown key (known: scale, set)"),
    ("sweep/vehicle", [{"scale": [1]}], "sweep.vehicle[0].scale: expected a mapping"),
    ("sweep/vehicle", [{"scale": {"fin_lift": "x"}}], "sweep.vehicle[0].scale.fin_lift: expected a number"),
    (
        "sweep/vehicle",
        [{"scale": {"fin_lif": 0.7}}],
        "sweep.vehicle[0].scale.fin_lif: unknown group (known: actuator_time",
    ),
    (
        "sweep/vehicle",
        [{"scale": {"fin_lift": 0}}],
        "sweep.vehicle[0].scale.fin_lift: factor must be finite and > 0",
    ),
    (
        "sweep/vehicle",
        [{"set": {"fins.area_m3": 0.03}}],
        "sweep.vehicle[0].set.fins.area_m3: unknown key 'area_m3'",
    ),
    (
        "sweep/vehicle",
        [{"set": {"fins.area_m2": 0.5}}],
        "sweep.vehicle[0].set.fins.area_m2: area_m2 must be in (0, 0.1) m^2, got 0.5",
    ),
    ("sweep/vehicle", [{}, {}], "sweep.vehicle[1]: same as sweep.vehicle[0]"),
    ("time_limit_factor", 0, "time_limit_factor: must be > 0, got 0"),
    ("time_limit_factor", "2", "time_limit_factor: expected a number"),
    ("success/position_m", -0.1, "success.position_m: must be > 0"),
    ("success/course_deg", None, "success.course_deg: expected a number"),
    (
        "success/bogus",
        1,
        "success.bogus: unknown key (known: course_deg, cross_track_m, depth_m, position_m)",
    ),
    ("random_missions", [1], "random_missions: expected a mapping"),
    ("random_missions", {"count": 2, "seed": 1}, "random_missions.area_m: missing"),
    ("random_missions", {"count": 0, "seed": 1, "area_m": 9}, "random_missions.count: must be >= 1"),
    (
        "random_missions",
        {"count": 100_001, "seed": 1, "area_m": 9},
        "random_missions.count: must be <= 100000, got 100001",
    ),
    (
        "random_missions",
        {"count": 100_000_000, "seed": 1, "area_m": 9},
        "random_missions.count: must be <= 100000",
    ),
    (
        "random_missions",
        {"count": 1, "seed": 1, "area_m": 9, "goals": 101},
        "random_missions.goals: must be <= 100, got 101",
    ),
    (
        "random_missions",
        {"count": 1, "seed": 1, "area_m": 9, "obstacles": [0, 65]},
        "random_missions.obstacles: must be <= 64 (the onboard's [mission] max_obstacles)",
    ),
    (
        "random_missions",
        {"count": 1, "seed": 1, "area_m": 9, "obstacles": 10**9},
        "random_missions.obstacles: must be <= 64",
    ),
    (
        "random_missions",
        {"count": 1, "seed": 1, "area_m": 9, "depth_m": [-1, 2]},
        "random_missions.depth_m: must be >= 0",
    ),
    (
        "random_missions",
        {"count": 1, "seed": 1, "area_m": 9, "bogus": 1},
        "random_missions.bogus: unknown key",
    ),
    ("random_missions", {"count": 1, "seed": 1, "area_m": -9}, "random_missions.area_m: must be > 0"),
    (
        "random_missions",
        {"count": 1, "seed": 1, "area_m": 9, "obstacles": [5, 1]},
        "random_missions.obstacles:",
    ),
    (
        "random_missions",
        {"count": 1, "seed": 1, "area_m": 9, "obstacles": [-1, 1]},
        "random_missions.obstacles",
    ),
    ("random_missions", {"count": 1, "seed": 1, "area_m": 9, "radius_m": [0, 1]}, "random_missions.radius_m"),
    ("random_missions", {"count": 1, "seed": 1, "area_m": 9, "radius_m": [1]}, "random_missions.radius_m"),
    (
        "random_missions",
        {"count": 1, "seed": 1, "area_m": 9, "goals": 0},
        "random_missions.goals: must be >= 1",
    ),
    (
        "random_missions",
        {"count": 1, "seed": 1, "area_m": 9, "min_distance_m": 10},
        "random_missions.min_distance_m",
    ),
]


@pytest.mark.parametrize(("path", "value", "expected"), BAD, ids=[f"{b[0]}={b[1]!r}"[:60] for b in BAD])
def test_bad_spec_names_the_key(path: str, value: Any, expected: str) -> None:
    with pytest.raises(SpecError) as info:
        parse_spec(_with(path, value), "spec.yaml")
    message = str(info.value)
    assert message.startswith(f"spec.yaml: {expected}"), message
    assert "\n" not in message
    assert isinstance(info.value, ConfigError)


def test_duplicate_mission_names() -> None:
    data = minimal()
    data["missions"].append({**copy.deepcopy(data["missions"][0]), "name": "m0"})
    with pytest.raises(SpecError, match=r"^spec\.yaml: missions\[1\]\.name: duplicate mission name 'm0'"):
        parse_spec(data, "spec.yaml")
    data = _with("missions/0/name", "r0")
    data["random_missions"] = {"count": 2, "seed": 1, "area_m": 30}
    with pytest.raises(SpecError, match=r"^spec\.yaml: random_missions: duplicate mission name 'r0'"):
        parse_spec(data, "spec.yaml")


def test_not_a_mapping() -> None:
    with pytest.raises(SpecError, match=r"^spec\.yaml: spec: expected a mapping"):
        parse_spec([1, 2], "spec.yaml")
    with pytest.raises(SpecError, match=r"^spec\.yaml: spec: expected a mapping"):
        parse_spec(None, "spec.yaml")


def test_load_spec_file_errors(tmp_path: Path) -> None:
    with pytest.raises(SpecError, match="no such spec file"):
        load_spec(tmp_path / "missing.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: [unclosed\nmissions: 3\n")
    with pytest.raises(SpecError, match=r"bad\.yaml: not valid YAML") as info:
        load_spec(bad)
    assert "\n" not in str(info.value)
    wrong = tmp_path / "wrong.yaml"
    wrong.write_text("name: w\nmissions: []\nsweep: {current: [[0.3]]}\n")
    with pytest.raises(SpecError, match=r"wrong\.yaml: "):
        load_spec(wrong)
