"""Closed loop (onboard + bench, lock-step): a mission that cannot be flown is never left RUNNING, and the
reason names the figure (issue 23: in 2.0 m/s from the goal the vehicle swept back behind its start at full
propeller, RUNNING until the time limit; the vehicle's top speed through the water is about 1.85 m/s).

The bench's vehicle starts drifting with the water, so the onboard knows the current at START and refuses it
(the commander's feasibility check). With the bench's old start, held at rest over ground, its estimate read
still water at START, the mission ran and a monitor ended it in HOLD 60 s later."""

from __future__ import annotations

import pytest

from auv_campaign.runner import fly
from auv_campaign.spec import parse_spec

pytestmark = pytest.mark.slow


def test_a_head_current_faster_than_the_vehicle_is_refused_at_start_with_the_figure() -> None:
    # GIVEN the paper's straight line (north) in a 2.0 m/s current flowing south, from the goal to the start
    spec = parse_spec(
        {
            "name": "faster",
            "missions": [{
                "name": "straight",
                "start": {"x_m": -13, "y_m": 0, "depth_m": 1, "yaw_deg": 0},
                "goals": [{"x_m": 15, "y_m": 0, "depth_m": 1, "yaw_deg": 0}],
            }],
            "sweep": {"current": [[2.0, 180]]},
        },
        "faster.yaml",
    )  # fmt: skip
    # WHEN it is flown on the bench as a campaign run is
    row = fly(spec.runs[0]).row
    # THEN it is never RUNNING: START is refused, the figure named in the reason the run reports
    assert row["final_state"] == "ARMED", (row["final_state"], row["final_reason"])
    reason = str(row["final_reason"])
    assert "never under way" in reason and "start refused" in reason, reason
    assert "makes good at most 0.00 m/s towards goal 0" in reason, reason
    assert row["time_limit_reached"] is False
