"""Closed loop in one process (onboard loop + bench on a `virtual` bus, lock-step): the paper's scenarios.

The limits are regression limits: about 1.5-2x what the improved controller achieved when they were set
(recorded next to each), so a change that degrades tracking fails here. The issue's goals (paper-turn
<= 0.1 m at the goal, <= 0.3 m cross-track, yaw within 5 deg) are reported by ``auv-hil scenario`` and
the demo, not asserted beyond these limits.
"""

from __future__ import annotations

import csv

import pytest

from tests.integration.closed_loop import fly

# scenario: (max final error m, max cross-track m, max |final yaw error| deg); achieved in brackets
IMPROVED_LIMITS = {
    "paper-straight": (0.03, 0.08, 2.0),  # achieved 0.008 m, 0.038 m, 0.5 deg
    "paper-turn": (0.10, 0.30, 6.0),  # achieved 0.042 m, 0.204 m, 3.4 deg
    "paper-plan": (0.20, 0.80, 5.0),  # achieved 0.104 m, 0.629 m (the turn from rest at the start), 2.1 deg
}


@pytest.mark.parametrize("name", sorted(IMPROVED_LIMITS))
def test_improved_controller_flies_the_paper_scenarios(name: str, tmp_path) -> None:
    # GIVEN the default onboard configuration (improved profile, track guidance) and the basin sensors
    m = fly(name, tmp_path)
    # THEN the vehicle arrives and completes, within the regression limits, with no frame rejected
    final_max, cross_max, yaw_max = IMPROVED_LIMITS[name]
    assert m["completed"], m
    assert m["final_state"] == "COMPLETE"
    assert m["final_position_error_m"] <= final_max, m
    assert m["max_cross_track_m"] <= cross_max, m
    assert abs(m["final_yaw_error_deg"]) <= yaw_max, m
    assert m["rejected"] == {}


def test_paper_profile_completes_the_straight_line(tmp_path) -> None:
    # The paper's gains (|Kp| = 2, |Kd| = 4) and its uniform-speed reference: the straight line completes
    # (achieved 0.31 m at the goal); on the turn it does not (it circles: see the closing note).
    m = fly("paper-straight", tmp_path, controller="paper")
    assert m["completed"], m
    assert m["final_position_error_m"] <= 0.6, m


def test_same_seed_same_truth_bit_for_bit(tmp_path) -> None:
    # GIVEN two runs of the same scenario with the same seed, each with its own bus channel
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    a = fly("paper-straight", tmp_path / "a", seed=7)
    b = fly("paper-straight", tmp_path / "b", seed=7)
    # THEN the truth logs are identical (no state shared between runs, no wall clock in lock-step)
    with open(a["truth_log"]) as fa, open(b["truth_log"]) as fb:
        assert list(csv.reader(fa)) == list(csv.reader(fb))


def test_complete_is_declared_only_within_the_arrival_radius_in_a_strong_current(tmp_path) -> None:
    # GIVEN the paper's turn in a 0.5 m/s current flowing north (it used to be declared COMPLETE 1.7-2 m
    # from the goal, as soon as the projection passed the end of the path)
    from tests.integration.closed_loop import SCENARIOS

    m = fly("paper-turn", tmp_path, current=(0.5, 0.0))
    gx, gy, _ = SCENARIOS["paper-turn"].goal
    with open(m["truth_log"]) as f:
        rows = list(csv.DictReader(f))
    complete = [r for r in rows if r["onboard_state"] == "COMPLETE"]
    # THEN COMPLETE, if it comes, comes within the arrival radius (0.5 m) of the truth plus the basin's
    # navigation error; otherwise the vehicle is still trying (a miss re-plans), never COMPLETE far off
    if complete:
        first = complete[0]
        miss = ((float(first["x_m"]) - gx) ** 2 + (float(first["y_m"]) - gy) ** 2) ** 0.5
        assert miss <= 0.6, (miss, m["final_state"])
        # and from that tick on the propeller never drives forward: nothing drives on past the goal (it
        # reverses to stop, issue 23; before, 0 at once)
        start = rows.index(first)
        assert all(float(r["propeller_cmd_rps"]) <= 0.0 for r in rows[start + 1 :])
    else:
        assert m["final_state"] in ("RUNNING", "HOLD"), m


def test_with_sea_grade_fixes_an_arrival_the_estimate_cannot_confirm_is_not_called_complete(tmp_path) -> None:
    # GIVEN the paper's turn with the `sea` sensor profile (2 m position fixes), seed 0: before, COMPLETE was
    # declared 8.4 m from the goal (the estimate had drifted; the filter knew its position only to ~1-4 m)
    m = fly("paper-turn", tmp_path, profile="sea", seed=0)
    with open(m["truth_log"]) as f:
        states = {r["onboard_state"] for r in csv.DictReader(f)}
    # THEN the vehicle does not claim the goal: it holds and says why
    assert "COMPLETE" not in states and m["final_state"] == "HOLD", m
    assert "cannot be confirmed" in m["final_reason"]
