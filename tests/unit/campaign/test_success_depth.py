"""success.depth_m (issue 24 item 5): a run is judged on the truth's depth where the vehicle said COMPLETE;
beyond the bound it is a false COMPLETE (a stuck depth sensor's), not a success."""

from __future__ import annotations

import dataclasses

import pytest

from auv_campaign.metrics import run_row
from auv_campaign.spec import RunSpec, SpecError, parse_spec
from tests.unit.campaign.test_metrics import COL, LIMITS, LINE, _straight

MISSION = {"name": "m", "start": {"x_m": 0, "y_m": 0, "depth_m": 1, "yaw_deg": 0},
           "goals": [{"x_m": 10, "y_m": 0, "depth_m": 1, "yaw_deg": 0}]}  # fmt: skip


def _spec(success: dict[str, float]) -> RunSpec:
    return parse_spec({"name": "t", "missions": [MISSION], "success": success}, "t.yaml").runs[0]


def _judge(spec: RunSpec, truth_depth_m: float) -> dict:
    truth = _straight(0.05)
    for r in truth:
        r[COL["depth_m"]] = truth_depth_m
    args = {"planned": True, "final_state": "COMPLETE", "final_reason": "", "time_limit_s": 60.0}
    return run_row(spec, truth, LINE, **args, arrival_radius_m=0.5, limits=LIMITS)  # type: ignore[arg-type]


def test_a_complete_deeper_than_the_bound_is_a_false_complete() -> None:
    spec = _spec({"depth_m": 0.5})
    assert spec.success_depth_m == 0.5
    deep = _judge(spec, 2.8)  # the depth_stuck run: 1.8 m below the goal's 1 m
    assert deep["false_complete"] and not deep["success"]
    near = _judge(spec, 1.2)
    assert near["success"] and not near["false_complete"]


def test_without_the_bound_the_depth_is_not_judged() -> None:
    spec = _spec({})
    assert spec.success_depth_m is None
    assert _judge(spec, 2.8)["success"]


def test_the_bound_survives_a_round_trip_and_is_checked() -> None:
    spec = _spec({"depth_m": 0.5})
    assert RunSpec.from_dict(spec.to_dict()) == spec
    assert (
        RunSpec.from_dict(dataclasses.replace(spec, success_depth_m=None).to_dict()).success_depth_m is None
    )
    with pytest.raises(SpecError, match=r"success\.depth_m"):
        _spec({"depth_m": -1})
