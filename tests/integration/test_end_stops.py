"""The end of a mission stops the vehicle (issue 23, item 3).

Before: the ``surface`` end action was propeller 0 and fins neutral at once; the vehicle arrived at
1.24-1.30 m/s and glided 15.7-19.9 m past the goal in 20-30 s (into whatever lay there). Now it slows on
the run-in to the last goal (``[mission] arrival_speed_mps``) and brakes after COMPLETE (the propeller in
reverse, at most ``[mission] brake_rps``, until the speed over ground is about 0) with the stern planes
holding the last goal's depth, so it stops within ``[mission] stop_distance_m`` and never goes deeper.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import pytest

from hil_sim.scenario import DEPTH_M
from tests.integration.closed_loop import fly

pytestmark = pytest.mark.slow

#: Simulated seconds watched after COMPLETE (the old glide lasted 20-30 s).
WATCH_S = 30.0
#: The stopping distance the packaged configuration promises (``[mission] stop_distance_m``), m.
STOP_M = 3.0


def after_end(truth_log: str) -> dict[str, float]:
    """From the truth log: how far the vehicle went after the onboard first said COMPLETE (the largest
    distance from where it was then, m), its deepest depth then (m) and how long it was watched (s)."""
    with open(truth_log, newline="") as f:
        rows = list(csv.DictReader(f))
    end = next(i for i, r in enumerate(rows) if r["onboard_state"] == "COMPLETE")
    x0, y0, t0 = float(rows[end]["x_m"]), float(rows[end]["y_m"]), float(rows[end]["t_s"])
    after = rows[end:]
    return {
        "glide_m": max(math.hypot(float(r["x_m"]) - x0, float(r["y_m"]) - y0) for r in after),
        "max_depth_m": max(float(r["depth_m"]) for r in after),
        "watched_s": float(after[-1]["t_s"]) - t0,
    }


@pytest.mark.parametrize("name", ["paper-straight", "paper-turn"])
def test_after_complete_the_vehicle_stops_within_the_stop_distance(name: str, tmp_path: Path) -> None:
    # GIVEN a paper scenario flown to COMPLETE with the packaged configuration (end action surface)
    # WHEN the bench goes on 30 simulated seconds after COMPLETE
    metrics = fly(name, tmp_path, stop_delay_s=WATCH_S)
    assert metrics["final_state"] == "COMPLETE", metrics["final_reason"]
    seen = after_end(metrics["truth_log"])
    assert seen["watched_s"] >= WATCH_S - 1.0, seen
    # THEN it stops within the stop distance of where it said COMPLETE, and never goes deeper than the goal
    assert seen["glide_m"] <= STOP_M, seen
    assert seen["max_depth_m"] <= DEPTH_M + 0.1, seen
