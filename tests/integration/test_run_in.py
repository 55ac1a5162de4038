"""The run-in to the last goal slows on a straight, not in the last turn (issue 23 item 3).

Before: the run-in's deceleration (1 -> 0.25 m/s at 0.025 m/s^2: 18.75 m) began in the last turn, the
straight before the goal being 5 m (``[planner] goal_run_in_m``). Slow in the turn, the fins lost their
force, and in a following current the estimate had not yet seen (it read 0.03 of 0.5 m/s along the first
straight) the vehicle was carried through the turn: current.yaml's two runs at 0.5 m/s towards 0 deg
crossed the goal 12.1 / 11.7 deg off its course (80/82). Now the last goal is approached along a straight
as long as the deceleration (``onboard.core.plans.last_goal_run_in_m``).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from auv_campaign.runner import fly
from auv_campaign.spec import load_spec

pytestmark = pytest.mark.slow

CAMPAIGNS = Path(__file__).resolve().parents[2] / "hil_sim" / "campaigns"


def test_the_turn_in_a_following_current_arrives_on_the_goals_course() -> None:
    # GIVEN current.yaml's turn in 0.5 m/s flowing towards 0 deg (along the first straight), seed 0
    run = next(
        r for r in load_spec(CAMPAIGNS / "current.yaml").runs if r.run_id.startswith("turn_s0_c0.5d0_")
    )
    # WHEN it is flown closed loop with the packaged settings
    m = fly(run).row
    # THEN it completes within the spec's bounds: 0.3 m and 10 deg of the goal's course
    assert m["final_state"] == "COMPLETE", m["final_reason"]
    assert abs(m["final_course_error_deg"]) <= 10.0, m
    assert m["success"], m


def test_the_depth_change_is_done_before_the_slow_run_in() -> None:
    # GIVEN depth.yaml's dive 1 -> 10 m over 50 m, seed 0 (0.42 m short of the goal's depth before)
    run = next(r for r in load_spec(CAMPAIGNS / "depth.yaml").runs if r.run_id.startswith("dive10_s0_"))
    # WHEN it is flown closed loop THEN it completes within 0.2 m of the goal's depth, stopped within 3 m
    m = fly(run).row
    assert m["success"], m
    assert abs(m["final_depth_error_m"]) <= 0.2, m
    assert m["glide_after_end_m"] <= 3.0, m
    assert m["max_depth_after_end_m"] <= 10.0, m
