"""The path holds in a current (issue 23, item 4), flown on the bench as a campaign run is.

The paper's turn (current.yaml's 'turn' mission) in 0.5 m/s: with the bench's old start, held at rest over
ground, the start's estimate was still water, so the path was planned again once the current was learnt (wider
turns); the vehicle now starts drifting with the water and its first plan knows the current. From the drifted
pose, with a run-in grown with the turns, the new path lay 3.5-6.4 m off the first one; from the vehicle's
projection on the path flown, with the 5 m run-in, the vehicle keeps within 2 m of the first plan where the
drift from rest does not set it farther (the current across the start heading, 90 / 270 deg, sets it 4.5 m
before its fins bite).
"""

from __future__ import annotations

import math

import pytest

from auv_campaign.runner import fly
from auv_campaign.spec import parse_spec

pytestmark = pytest.mark.slow


def _turn_in_current(direction_deg: float) -> dict[str, object]:
    spec = parse_spec(
        {
            "name": "turn",
            "missions": [{
                "name": "turn",
                "start": {"x_m": -15, "y_m": 5, "depth_m": 1, "yaw_deg": 0},
                "goals": [{"x_m": 10, "y_m": -2, "depth_m": 1, "yaw_deg": 270}],
            }],
            "sweep": {"current": [[0.5, direction_deg]]},
            "time_limit_factor": 2.0,
        },
        "turn.yaml",
    )  # fmt: skip
    out = fly(spec.runs[0], keep_truth=True)
    row = dict(out.row)
    # off the first plan once under way (the bench's truth rows: t, x, y, ...; onboard state in column 22)
    under_way = [r for r in out.truth if r[0] >= UNDER_WAY_S and r[22] == "RUNNING"]
    row["under_way_cross_track_m"] = max(
        min(math.hypot(r[1] - p[0], r[2] - p[1]) for p in out.path) for r in under_way
    )
    return row


#: The vehicle starts drifting with the water (the bench's start, as at sea): before its propeller has
#: brought it to about 0.3 m/s through the water (6-7 s at full rps) its fins do not bite and the current
#: sets it off the path. The old bench held it at rest over ground, so it had steerage from t = 0.
UNDER_WAY_S = 8.0


@pytest.mark.parametrize("direction_deg", [135.0, 225.0])
def test_the_turn_in_half_a_metre_per_second_keeps_within_two_metres_of_its_first_plan(
    direction_deg: float,
) -> None:
    # GIVEN the paper's turn in a 0.5 m/s current towards 135 / 225 deg (3.5 / 3.6 m off before)
    row = _turn_in_current(direction_deg)
    # THEN it arrives within the campaign's bounds and, once under way, never strays 2 m from the path it
    # planned first (while it gets under way, drifting with the water, 2.06 m at most)
    assert row["success"] is True, row["final_reason"]
    assert row["under_way_cross_track_m"] <= 2.0, row["under_way_cross_track_m"]
    assert row["max_cross_track_m"] <= 2.2, row["max_cross_track_m"]
