"""The figures of one run, from the simulator's truth rows (``hil_sim.bench_program.TRUTH_COLUMNS``).

Arrival, final errors and cross-track are :func:`hil_sim.metrics.compute_metrics` (the judge of
``auv-hil scenario`` too) against the nominal path to the last goal, at the goal-line crossing the vehicle
claimed when it declared COMPLETE (the last one up to a second after; after a miss and a re-plan the truth
crosses twice), else at the first crossing. Added here:

- ``success``: the truth arrived (crossed the last goal's line), the onboard declared COMPLETE, and at the
  crossing the position error is within ``success.position_m`` and the course over ground within
  ``success.course_deg`` of the goal's yaw (a free yaw: the path's final heading), and the track never
  entered an obstacle, and the COMPLETE was no false one;
- ``false_complete``: when the onboard first reported COMPLETE, the truth was farther from the last goal than
  the onboard's own ``[mission] arrival_radius_m``;
- ``min_clearance_m``: the least distance from the truth to an obstacle's edge (negative: inside);
- ``control_effort_rad``: the RMS of the rudder and both stern commands over the run;
- saturation: the fraction of ticks with a fin command at the onboard's ``[control.limits]`` angle, or the
  propeller at its maximum.
"""

from __future__ import annotations

import math
from typing import Any

from auv_campaign.results import COLUMNS
from auv_campaign.spec import RunSpec
from hil_sim.bench_program import TRUTH_COLUMNS
from hil_sim.metrics import compute_metrics
from onboard.core.control.actuators import ActuatorLimits

_COL = {name: i for i, name in enumerate(TRUTH_COLUMNS)}
_T, _X, _Y, _D, _YAW = (_COL[k] for k in ("t_s", "x_m", "y_m", "depth_m", "yaw_deg"))
_RUD, _SP, _SS, _PROP = (
    _COL[k] for k in ("rudder_cmd_rad", "stern_port_cmd_rad", "stern_starboard_cmd_rad", "propeller_cmd_rps")
)
_STATE, _PITCH = _COL["onboard_state"], _COL["pitch_deg"]
COMPLETE_MARGIN_ROWS = 20  # truth rows (1 s at 20 Hz) after the first COMPLETE searched for the crossing
SATURATION_TOLERANCE = 1e-4  # rad or rev/s below the limit that still counts as "at the limit"


def _finite(value: float) -> float | None:
    return value if math.isfinite(value) else None


def base_row(spec: RunSpec) -> dict[str, Any]:
    """A row that knows only the run: its identity, nothing planned, completed or succeeded, every figure
    None (a run that raised is this row with its ``error``)."""
    row: dict[str, Any] = dict.fromkeys(COLUMNS)
    row.update(spec.identity())
    row.update(planned=False, completed=False, success=False, false_complete=False, error="")
    return row


def run_row(
    spec: RunSpec,
    truth: list[list[Any]],
    samples: list[list[float]],
    *,
    planned: bool,
    final_state: str,
    final_reason: str,
    time_limit_s: float,
    arrival_radius_m: float,
    limits: ActuatorLimits,
) -> dict[str, Any]:
    """One row of ``runs.csv`` (``results.COLUMNS`` without the timing of the run itself)."""
    row = base_row(spec)
    row.update(planned=planned, final_state=final_state, final_reason=final_reason, time_limit_s=time_limit_s)
    if not truth or not samples:
        return row
    gx, gy, gdepth, gyaw = spec.mission.goals[-1]
    rows = [{"t_s": r[_T], "x_m": r[_X], "y_m": r[_Y], "depth_m": r[_D], "yaw_deg": r[_YAW]} for r in truth]
    complete_at = next((k for k, r in enumerate(truth) if r[_STATE] == "COMPLETE"), None)
    # Judged at the crossing the vehicle claimed (after a miss it crosses again): the last one up to a
    # second after it first said COMPLETE (its estimate may cross a tick before the truth does).
    until = None if complete_at is None else complete_at + COMPLETE_MARGIN_ROWS
    met = compute_metrics(rows, samples, (gx, gy, gyaw), gdepth, until_row=until)
    course = _finite(met["final_course_error_deg"])
    row.update(
        completed=met["completed"],
        final_position_error_m=met["final_position_error_m"],
        final_course_error_deg=course,
        final_heading_error_deg=met["final_yaw_error_deg"],
        final_depth_error_m=met["final_depth_error_m"],
        max_cross_track_m=_finite(met["max_cross_track_m"]),
        rms_cross_track_m=_finite(met["rms_cross_track_m"]),
        time_to_goal_s=met["arrival_time_s"] if met["completed"] else None,
    )
    if spec.mission.obstacles:
        row["min_clearance_m"] = min(
            math.hypot(r[_X] - ox, r[_Y] - oy) - rad for r in truth for ox, oy, rad in spec.mission.obstacles
        )
    n = len(truth)
    row["max_pitch_deg"] = max(abs(r[_PITCH]) for r in truth)
    fin_sq = sum(r[_RUD] ** 2 + r[_SP] ** 2 + r[_SS] ** 2 for r in truth)
    row["control_effort_rad"] = math.sqrt(fin_sq / (3 * n))
    rud_lim = limits.rudder_limit_rad - SATURATION_TOLERANCE
    st_lim = limits.stern_limit_rad - SATURATION_TOLERANCE
    row["fin_saturation_fraction"] = (
        sum(1 for r in truth if abs(r[_RUD]) >= rud_lim or max(abs(r[_SP]), abs(r[_SS])) >= st_lim) / n
    )
    row["propeller_saturation_fraction"] = (
        sum(1 for r in truth if r[_PROP] >= limits.propeller_max_rps - SATURATION_TOLERANCE) / n
    )
    first_complete = truth[complete_at] if complete_at is not None else None
    if first_complete is not None:
        miss_m = math.hypot(first_complete[_X] - gx, first_complete[_Y] - gy)
        row["false_complete"] = miss_m > arrival_radius_m
    clear = row["min_clearance_m"] is None or row["min_clearance_m"] >= 0.0
    row["success"] = bool(
        met["completed"]
        and final_state == "COMPLETE"
        and not row["false_complete"]
        and met["final_position_error_m"] <= spec.success_position_m
        and course is not None
        and abs(course) <= spec.success_course_deg
        and clear
    )
    return row
