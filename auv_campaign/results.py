"""What one run yields: the columns of ``runs.csv`` and the cost that ranks runs (report) and trials (tune).

Every figure comes from the simulator's truth, never from the onboard's own view (see
:mod:`auv_campaign.metrics`). A row is a plain dict (JSON- and CSV-ready); ``None`` means "not defined for
this run" (e.g. no obstacle: no clearance; never arrived: no time to goal) and is an empty CSV cell.
"""

from __future__ import annotations

import math
from typing import Any

#: The identity of a run: which mission, which sweep values.
ID_COLUMNS = (
    "run_id",
    "mission",
    "seed",
    "current_speed_mps",
    "current_dir_deg",
    "profile",
    "onboard",  # label of the onboard override set ("default" or "o1", ...)
    "vehicle",  # label of the vehicle variant ("nominal" or "v1", ...)
    "faults",  # the bench's faults of the run ("none"; "" when the spec sweeps no faults)
)
#: What the run gave.
RESULT_COLUMNS = (
    "planned",  # the onboard accepted the mission and started it (its validator and planner agreed)
    "completed",  # the vehicle said COMPLETE (its own word; judged against the truth by the columns below)
    "arrived",  # the truth crossed the last goal's line near the end of the nominal path
    "success",  # every goal reached, COMPLETE kept, within the spec's bounds, never inside an obstacle
    "false_complete",  # COMPLETE declared while the truth was farther than the arrival radius from the goal
    "time_limit_reached",  # the time limit came before COMPLETE, HOLD or ABORT (the vehicle still RUNNING)
    "goals",  # the mission's goals
    "goals_reached",  # goals whose line the truth crossed within the position and course bounds
    "max_goal_closest_m",  # the largest of the goals' closest approaches (the worst-missed goal)
    "final_position_error_m",
    "final_course_error_deg",  # course over ground against the goal's yaw
    "final_heading_error_deg",  # heading against the goal's yaw (crab in a current is expected)
    "final_depth_error_m",
    "max_pitch_deg",  # the largest |pitch| of the truth over the run
    "max_cross_track_m",
    "rms_cross_track_m",
    "min_clearance_m",  # over the whole run incl. after the end; negative: inside an obstacle; None: none
    "time_to_goal_s",  # None: never arrived
    "control_effort_rad",  # RMS of the rudder and stern commands over the run
    "fin_saturation_fraction",  # ticks with a fin command at its limit / ticks
    "propeller_saturation_fraction",  # ticks with the propeller command at its maximum / ticks
    "nees_mean",  # the horizontal position's NEES (truth vs the onboard's estimate and covariance), mean
    "nees_in_band_fraction",  # samples whose NEES lies in the 2-dof 95 % band [0.051, 7.38] (ideal 0.95)
    "nees_above_fraction",  # samples above it: the filter claims more than it knows (ideal 0.025)
    "end_state",  # the first of COMPLETE, HOLD, ABORT (None: the run ended before any)
    "end_time_s",  # when the vehicle first reported it (simulated s)
    "glide_after_end_m",  # horizontal distance travelled from the end to the end of the run
    "max_depth_after_end_m",  # the deepest point from the end to the end of the run
    "final_state",  # at the end of the run (after the observation window)
    "final_reason",
    "time_limit_s",
    "sim_time_s",
    "ticks",
    "wall_time_s",
    "error",  # "" or the exception that ended the run (a bug, not a miss)
)
COLUMNS = ID_COLUMNS + RESULT_COLUMNS

#: Weights of :func:`run_cost`: a failure weighs most, then the final error, cross-track, control effort.
FAILURE_COST = 10.0
ERROR_CAP_M = 5.0


def run_cost(row: dict[str, Any], cap_m: float = ERROR_CAP_M) -> float:
    """The cost of one run (lower is better): ``10 * (not success) + min(final position error, 5 m)
    + RMS cross-track (m, capped at 5) + 0.1 * control effort (rad)``; a run that did not plan or raised
    costs ``10 + 5 + 5``. The tuner's objective keeps the caps (one wild run does not drown a trial);
    :func:`severity` ranks the worst runs without them."""
    if row.get("error") or not row.get("planned"):
        return FAILURE_COST + 2.0 * ERROR_CAP_M
    fail = 0.0 if row.get("success") else FAILURE_COST
    err = _capped(row.get("final_position_error_m"), cap_m)
    xte = _capped(row.get("rms_cross_track_m"), cap_m)
    effort = row.get("control_effort_rad") or 0.0
    return fail + err + xte + 0.1 * float(effort)


def severity(row: dict[str, Any]) -> float:
    """How bad a run was, uncapped (the report's worst-run ranking: a 55 m miss ranks above a 14 m one):
    :func:`run_cost` without the caps, plus the depth of a penetration (m) and the worst goal's closest
    approach (m) when it failed; a run that raised or did not plan costs ``10 + 5 + 5`` as in
    :func:`run_cost`. Finite (JSON-safe): an undefined figure counts 0."""
    if row.get("error") or not row.get("planned"):
        return FAILURE_COST + 2.0 * ERROR_CAP_M
    cost = run_cost(row, cap_m=math.inf)
    clearance = row.get("min_clearance_m")
    if clearance is not None and math.isfinite(float(clearance)) and float(clearance) < 0.0:
        cost += -float(clearance)
    closest = row.get("max_goal_closest_m")
    if not row.get("success") and closest is not None and math.isfinite(float(closest)):
        cost += float(closest)
    return cost


def _capped(value: Any, cap_m: float = ERROR_CAP_M) -> float:
    if value is None or not math.isfinite(float(value)):
        return 0.0 if math.isinf(cap_m) else cap_m
    return min(float(value), cap_m)
