"""Issue 24, items 2 and 3, as the campaign sees them: hil_sim/campaigns/nav_honesty.yaml's hardest runs flown
in lock-step (the real onboard against the simulator): the filter's sigma honest against the truth (NEES in
its band, none above it), never a false COMPLETE, and the ends a user would recognise (a slow DVL in the basin
COMPLETEs; a DVL lost at sea ends once the position's 1-sigma passes [nav] max_position_std_m)."""

from __future__ import annotations

from pathlib import Path

import pytest

from auv_campaign.runner import fly
from auv_campaign.spec import RunSpec, load_spec

SPEC = Path(__file__).parents[2] / "hil_sim" / "campaigns" / "nav_honesty.yaml"


def _run(run_id: str) -> RunSpec:
    runs = {r.run_id: r for r in load_spec(SPEC).runs}
    return runs[run_id]


@pytest.mark.parametrize(
    ("run_id", "end", "min_in_band"),
    [
        # 0.5 Hz DVL at sea: before, NEES 6.4 with 35 % of the samples above the band
        ("turn_s0_c0d0_sea_default_v3_none", "HOLD", 0.9),
        # the DVL silent 10-30 s in the basin: before, 1 false COMPLETE
        ("straight_s0_c0d0_basin_default_nominal_dvl_dropout", "COMPLETE", 0.9),
        # ... and at sea: before, NEES 49 (the estimate stopped while the vehicle ran on)
        ("straight_s0_c0d0_sea_default_nominal_dvl_dropout", "ABORT", 0.9),
        # fixes every 100 s in the basin: before, ABORT "POSITION_INVALID" at a fixed 60 s; then cautious
        # (8 % in the band: room for a real DVL's bias, which the bench's had not); the bench's DVL now has
        # one (0.3 % of speed, seeded): in the band, and the HOLD an honest one
        ("straight_s0_c0d0_basin_default_v2_none", "HOLD", 0.9),
        # fixes every 20 s in the basin: 43 % in the band against an unbiased bench DVL
        ("straight_s0_c0d0_basin_default_v1_none", "COMPLETE", 0.75),
    ],
)
def test_the_filter_is_honest_and_never_claims_a_goal_it_has_not_reached(
    run_id: str, end: str, min_in_band: float
) -> None:
    row = fly(_run(run_id)).row
    assert row["nees_above_fraction"] is not None and row["nees_above_fraction"] < 0.05, row["nees_mean"]
    assert row["nees_in_band_fraction"] >= min_in_band, row["nees_mean"]
    assert not row["false_complete"]
    assert row["end_state"] == end, row["final_reason"]
    if end == "HOLD":
        assert "cannot be confirmed: the position's 95 % region" in row["final_reason"]
    if end == "ABORT":
        assert "POSITION_INVALID" in row["final_reason"]
