"""3-D legs are flown (issue 23, item 5): a depth change too steep for the planned path, closed loop.

Before: a quarter turn diving 1 -> 10 m (hil_sim/campaigns/legs_3d.yaml, turn_right_dive10) was refused at
START, "cannot plan goal 0: depth_slope: depth change +9.00 m needs 35.99 m of path at slope 0.25, but the
path is 17.02 m", and held without moving. Now the planner adds two full circles of its turning radius after
the run-up and the vehicle dives on that helix: COMPLETE, pitched within the depth loop's limit
(``[control] pitch_limit_deg``, 20 deg), at the goal's depth.

Flown with the packaged settings, the run-in to the last goal on (issue 23 item 3, the end that stops):
its slow-down costs depth authority (the stern planes' lift goes with the speed squared, the hull is
buoyant), so the run-in finishes the path's depth change while it is still fast
(``onboard.core.guidance.guidance.run_in_depth``) on a straight long enough to slow on
(``onboard.core.plans.last_goal_run_in_m``). Before that (the run-in on the last turn and the depth
change flown on to the goal) these ended 0.35 and 0.82 m short of the goal's depth; where the helix
already takes the whole leg at the slope limit (the quarter turn) the run-in still costs ~0.4 m.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from auv_campaign.runner import fly
from auv_campaign.spec import load_spec

pytestmark = pytest.mark.slow

SPEC = Path(__file__).resolve().parents[2] / "hil_sim" / "campaigns" / "legs_3d.yaml"
#: ``[control] pitch_limit_deg`` of the packaged configuration, deg.
PITCH_LIMIT_DEG = 20.0


@pytest.mark.parametrize(
    ("mission", "depth_error_m"), [("turn_right_dive10", 0.5), ("leg1_steep7_over12", 0.2)]
)
def test_a_steep_leg_is_flown_on_a_helix(mission: str, depth_error_m: float) -> None:
    # GIVEN the spec's run of the mission, seed 0 (the second is the steep leg between two goals, which
    # the upload refused before), the packaged settings (the run-in on)
    run = next(r for r in load_spec(SPEC).runs if r.mission.name == mission and r.seed == 0)
    # WHEN it is flown closed loop (the bench and the onboard in one process)
    m = fly(run).row
    # THEN it completes at the goal, at its depth, never pitched beyond the depth loop's limit
    assert m["final_state"] == "COMPLETE", m["final_reason"]
    assert m["success"], m
    assert abs(m["final_depth_error_m"]) <= depth_error_m, m
    assert m["max_pitch_deg"] <= PITCH_LIMIT_DEG, m
