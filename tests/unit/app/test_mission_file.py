"""``--mission`` files: parsed at the edge, then checked by the one validator; one line per refusal."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from onboard.app.mission_file import load_mission
from onboard.core.config import CoreConfig
from onboard.core.mission.model import MissionError
from onboard.core.safety.failsafe import FailsafeParams

CFG = CoreConfig(failsafe=FailsafeParams(max_depth_m=20.0))


def mission_file(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "m.yaml"
    p.write_text(text)
    return p


def test_a_good_file_loads_in_si_units(tmp_path: Path) -> None:
    p = mission_file(
        tmp_path,
        "goals:\n"
        "  - {x_m: 15.0, y_m: 0.0, depth_m: 1.0, yaw_deg: 0.0}\n"
        "  - {x_m: 30.0, y_m: 10.0, depth_m: 2.0, yaw_deg: 270}\n"
        "  - {x_m: 10.0, y_m: 30.0, depth_m: 2.0}\n"
        "obstacles:\n"
        "  - {x_m: 5.0, y_m: 30.0, radius_m: 1.5}\n",
    )
    m = load_mission(p, CFG)
    assert len(m.goals) == 3 and m.goals[2].yaw_rad is None
    assert m.goals[1].yaw_rad == pytest.approx(math.radians(-90.0))  # wrapped, as MAVLink's param4 is
    assert m.obstacles[0].radius_m == 1.5


def test_a_missing_depth_is_an_error_naming_the_goal(tmp_path: Path) -> None:
    # the format is the one parser's (auv_common.mission_yaml): the key path, as in a campaign spec
    p = mission_file(tmp_path, "goals:\n  - {x_m: 15.0, y_m: 0.0, depth_m: 1.0}\n  - {x_m: 30.0, y_m: 0.0}\n")
    with pytest.raises(MissionError, match=r"m\.yaml: goals\[1\]\.depth_m: missing$"):
        load_mission(p, CFG)


def test_a_goal_below_the_failsafe_depth_is_refused_with_one_line(tmp_path: Path) -> None:
    p = mission_file(
        tmp_path, "goals:\n  - {x_m: 15.0, y_m: 0.0, depth_m: 1.0}\n  - {x_m: 30.0, y_m: 0, depth_m: 25}\n"
    )
    with pytest.raises(MissionError) as err:
        load_mission(p, CFG)
    assert str(err.value) == f"{p}: goal 1: depth 25 m is below the failsafe depth limit 20 m"
    assert err.value.reason == "depth" and "\n" not in str(err.value)


def test_several_problems_give_the_first_and_the_count(tmp_path: Path) -> None:
    p = mission_file(
        tmp_path, "goals:\n  - {x_m: 5000, y_m: 0, depth_m: 1}\n  - {x_m: 0, y_m: 0, depth_m: .nan}\n"
    )
    with pytest.raises(MissionError, match=r"goal 0: x 5000 m is outside .* \(and 1 more\)$"):
        load_mission(p, CFG)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("goals: []\n", "m.yaml: a mission needs at least one goal"),
        (
            "goals:\n  - {x_m: 1, y_m: 0, depth_m: true}\n",
            r"goals\[0\]\.depth_m: expected a number, got True",
        ),
        ("goals:\n  - {x_m: .inf, y_m: 0, depth_m: 1}\n", "goal 0: x is not a finite number"),
        (
            "goals:\n  - {x_m: 1, y_m: 0, depth_m: 1, speed: 2}\n",
            r"goals\[0\]\.speed: unknown key \(known: depth_m, radius_m, x_m, y_m, yaw_deg\)",
        ),
        ("goals: {x_m: 1}\n", "goals: expected a list"),
        ("waypoints: []\n", "waypoints: unknown key"),
        ("goals: [\n", "not valid YAML"),
        (
            "goals:\n  - {x_m: 10, y_m: 0, depth_m: 1}\nobstacles:\n  - {x_m: 10, y_m: 0, radius_m: 1}\n",
            "obstacle 0",
        ),
    ],
)
def test_format_and_limit_errors(tmp_path: Path, text: str, match: str) -> None:
    with pytest.raises(MissionError, match=match):
        load_mission(mission_file(tmp_path, text), CFG)


def test_a_missing_file(tmp_path: Path) -> None:
    with pytest.raises(MissionError, match="No such file"):
        load_mission(tmp_path / "nope.yaml", CFG)


def test_a_broken_yaml_file_is_one_line_with_its_place_at_every_door(tmp_path: Path) -> None:
    # GIVEN a flow list left open (PyYAML's message spans five lines with a caret drawing)
    from groundstation.mission_files import MissionFileError, load_yaml

    broken = mission_file(tmp_path, "goals: [{x_m: 1}\n")
    # THEN the onboard's loader and the ground station's each say it in one line, with the place
    with pytest.raises(MissionError) as onboard:
        load_mission(broken, CFG)
    with pytest.raises(MissionFileError) as gcs:
        load_yaml(broken)
    for text in (str(onboard.value), str(gcs.value)):
        assert "\n" not in text and "not valid YAML (line 2, column 1: expected ',' or ']'" in text


def test_a_position_no_mavlink_mission_item_carries_is_refused_at_the_file_door(tmp_path: Path) -> None:
    # GIVEN an obstacle whose centre is 1000 km out (it reaches the area: radius 999 km) - the vehicle
    # serves and stores a --mission file as MISSION_ITEM_INT (local x, y = m * 1e4 in an int32)
    p = mission_file(
        tmp_path,
        "goals:\n  - {x_m: 10, y_m: 0, depth_m: 1}\n"
        "obstacles:\n  - {x_m: 1000000, y_m: 0, radius_m: 999000}\n",
    )
    # WHEN it is loaded THEN one line names the obstacle and why (the encoding's rule, not the core's)
    with pytest.raises(MissionError) as err:
        load_mission(p, CFG)
    assert str(err.value) == f"{p}: obstacle 0: centre x 1e+06 m is not encodable on MAVLink (int32 of m*1e4)"
