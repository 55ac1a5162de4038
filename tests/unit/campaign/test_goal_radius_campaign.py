"""Campaign specs give a goal its acceptance radius (issue 24 item 1): ``goals: [{..., radius_m: 3}]`` is
parsed by the one mission parser, refused with the vehicle's reason when out of range, sent to the vehicle
and used to judge the run: success and false_complete by the goal's radius, not a fixed one."""

from __future__ import annotations

from typing import Any

import pytest

from auv_campaign.runner import mission_of
from auv_campaign.spec import MissionSpec, SpecError, parse_spec
from tests.unit.campaign.test_verdict import START, _judge, _line, _track


def _spec(radius_m: float | None, x: float = 20.0) -> Any:
    goal: dict[str, Any] = {"x_m": x, "y_m": 0, "depth_m": 1, "yaw_deg": 0}
    if radius_m is not None:
        goal["radius_m"] = radius_m
    data = {"name": "t", "missions": [{"name": "m", "start": START, "goals": [goal]}]}
    return parse_spec(data, "t.yaml").runs[0]


def test_a_goals_radius_is_parsed_kept_in_the_run_and_sent_to_the_vehicle() -> None:
    run = _spec(3.0)
    assert run.mission.goal_radii_m == (3.0,) and run.mission.goal_radius_m(0) == 3.0
    assert mission_of(run).goals[0].radius_m == 3.0
    assert run.mission.to_mission_file()["goals"][0]["radius_m"] == 3.0
    assert MissionSpec.from_dict(run.mission.to_dict()) == run.mission  # the run JSON keeps it
    plain = _spec(None)
    assert plain.mission.goal_radii_m == () and "goal_radii_m" not in plain.mission.to_dict()


@pytest.mark.parametrize(
    ("radius", "why"),
    [
        (-1, "arrival radius -1 m is negative"),
        (80, "arrival radius 80 m is above 50 m"),
        (True, "expected a number"),
    ],
)
def test_a_bad_radius_is_refused_at_its_key_with_the_vehicles_reason(radius: object, why: str) -> None:
    with pytest.raises(SpecError) as err:
        _spec(radius)  # type: ignore[arg-type]
    assert "missions[0].goals[0].radius_m" in str(err.value) and why in str(err.value), str(err.value)


def test_the_run_is_judged_by_the_goals_radius() -> None:
    # GIVEN a goal at x = 20 with a 3 m radius: the vehicle says COMPLETE 2.5 m short and stops there
    spec = _spec(3.0)
    truth = _track([(0.0, 0.0), (17.5, 0.0)], end_x=17.5)
    row = _judge(spec, truth, legs=[_line(0.0, 20.0)])
    # THEN that is no false COMPLETE (within its radius, not the default 0.5 m) and a success
    assert row["false_complete"] is False and row["success"] is True, row
    # AND 3.5 m short is a false COMPLETE and no success
    short = _judge(spec, _track([(0.0, 0.0), (16.5, 0.0)], end_x=16.5), legs=[_line(0.0, 20.0)])
    assert short["false_complete"] is True and short["success"] is False


def test_without_a_radius_the_default_judges_as_before() -> None:
    spec = _spec(None)
    row = _judge(spec, _track([(0.0, 0.0), (17.5, 0.0)], end_x=17.5), legs=[_line(0.0, 20.0)])
    assert row["false_complete"] is True and row["success"] is False
