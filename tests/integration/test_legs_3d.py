"""3-D legs are flown (issue 23, item 5): a depth change too steep for the planned path, closed loop.

Before: a quarter turn diving 1 -> 10 m (hil_sim/campaigns/legs_3d.yaml, turn_right_dive10) was refused at
START, "cannot plan goal 0: depth_slope: depth change +9.00 m needs 35.99 m of path at slope 0.25, but the
path is 17.02 m", and held without moving. Now the planner adds two full circles of its turning radius after
the run-up and the vehicle dives on that helix: COMPLETE, pitched within the depth loop's limit
(``[control] pitch_limit_deg``, 20 deg), at the goal's depth.

The helix is flown here with the run-in to the last goal off (``[mission] arrival_speed_mps`` 0): the
run-in's slow-down (issue 23 item 3, the end that stops) costs depth authority (the stern planes' lift goes
with the speed squared), which is the run-in's open problem, measured by ``legs_3d.yaml`` and
``depth.yaml``, not the helix's.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from auv_campaign.runner import fly
from auv_campaign.spec import load_spec

pytestmark = pytest.mark.slow

SPEC = Path(__file__).resolve().parents[2] / "hil_sim" / "campaigns" / "legs_3d.yaml"
#: ``[control] pitch_limit_deg`` of the packaged configuration, deg.
PITCH_LIMIT_DEG = 20.0


@pytest.mark.parametrize("mission", ["turn_right_dive10", "leg1_steep7_over12"])
def test_a_steep_leg_is_flown_on_a_helix(mission: str) -> None:
    # GIVEN the spec's run of the mission, seed 0 (the second is the steep leg between two goals, which
    # the upload refused before)
    run = next(r for r in load_spec(SPEC).runs if r.mission.name == mission and r.seed == 0)
    run = dataclasses.replace(run, onboard=(*run.onboard, ("mission.arrival_speed_mps", 0.0)))
    # WHEN it is flown closed loop (the bench and the onboard in one process)
    m = fly(run).row
    # THEN it completes at the goal, at its depth, never pitched beyond the depth loop's limit
    assert m["final_state"] == "COMPLETE", m["final_reason"]
    assert m["success"], m
    assert abs(m["final_depth_error_m"]) <= 0.3, m
    assert m["max_pitch_deg"] <= PITCH_LIMIT_DEG, m
