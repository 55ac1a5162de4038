"""The figures of one run, from the simulator's truth rows (``hil_sim.bench_program.TRUTH_COLUMNS``).

The last goal's arrival, final errors and cross-track are :func:`hil_sim.metrics.compute_metrics` (the
judge of ``auv-hil scenario`` too) against the nominal path to the last goal, at the goal-line crossing the
vehicle claimed when it declared COMPLETE (the last one up to a second after; after a miss and a re-plan the
truth crosses twice), else at the first crossing. Every goal is judged (:func:`judge_goals`, the run JSON's
``row.goals``): its closest approach, whether the truth crossed its line and the position and course there.
Added here:

- ``success``: every goal reached (its line crossed within ``success.position_m`` and ``success.course_deg``
  of its yaw; a free yaw: the path's final heading), the last at the crossing the vehicle claimed; the
  onboard said COMPLETE and was still COMPLETE at the end of the run (after ``observe_after_end_s``), no
  false COMPLETE, the time limit not reached, the track never inside an obstacle (the whole run, the
  observation after the end included), when the spec gives ``success.cross_track_m``, the max
  cross-track within it and, when it gives ``success.depth_m``, the truth's depth where the vehicle first
  said COMPLETE within it of the last goal's;
- ``completed``: the vehicle said COMPLETE; ``arrived``: the truth crossed the last goal's line;
- ``false_complete``: when the onboard first reported COMPLETE, the truth was farther from the last goal than
  its acceptance radius: the goal's own (the spec's ``radius_m``), else the onboard's ``[mission]
  arrival_radius_m``; a goal with its own radius is reached (``success``) within it (:func:`judge_goals`);
  with ``success.depth_m``, also a truth deeper or shallower than that from the last goal's depth there (a
  false COMPLETE in depth: a stuck depth sensor's);
- the end (the first COMPLETE, HOLD or ABORT): ``end_state``, ``end_time_s``, ``glide_after_end_m`` (the
  horizontal distance travelled from then to the end of the run) and ``max_depth_after_end_m``;
- ``nees_mean``, ``nees_in_band_fraction``, ``nees_above_fraction``: how honest the onboard's position
  covariance was against the truth's error (:func:`nees_figures`; the one exception to "never the onboard's
  view": its estimate is what is judged);
- ``min_clearance_m``: the least distance from the truth to an obstacle's edge (negative: inside);
- ``control_effort_rad``: the RMS of the rudder and both stern commands over the run;
- saturation: the fraction of ticks with a fin command at the onboard's ``[control.limits]`` angle, or the
  propeller at its maximum.
"""

from __future__ import annotations

import itertools
import math
from typing import Any

from auv_campaign.results import COLUMNS
from auv_campaign.spec import RunSpec
from hil_sim.bench_program import TRUTH_COLUMNS
from hil_sim.metrics import compute_metrics, goal_crossings
from onboard.core.control.actuators import ActuatorLimits
from onboard.core.nav.confidence import NEES_BAND, nees

_COL = {name: i for i, name in enumerate(TRUTH_COLUMNS)}
_T, _X, _Y, _D, _YAW = (_COL[k] for k in ("t_s", "x_m", "y_m", "depth_m", "yaw_deg"))
_RUD, _SP, _SS, _PROP = (
    _COL[k] for k in ("rudder_cmd_rad", "stern_port_cmd_rad", "stern_starboard_cmd_rad", "propeller_cmd_rps")
)
_STATE, _PITCH = _COL["onboard_state"], _COL["pitch_deg"]
#: The onboard states that end a mission (the first one is the run's end; it is observed on after it).
END_STATES = ("COMPLETE", "HOLD", "ABORT")
COMPLETE_MARGIN_ROWS = 20  # truth rows (1 s at 20 Hz) after the first COMPLETE searched for the crossing
SATURATION_TOLERANCE = 1e-4  # rad or rev/s below the limit that still counts as "at the limit"


def _finite(value: float) -> float | None:
    return value if math.isfinite(value) else None


def base_row(spec: RunSpec) -> dict[str, Any]:
    """A row that knows only the run: its identity, nothing planned, completed or succeeded, every figure
    None (a run that raised is this row with its ``error``). ``goals`` (not a CSV column: the run JSON's
    list of per-goal figures) is empty."""
    row: dict[str, Any] = dict.fromkeys(COLUMNS)
    row.update(spec.identity())
    row.update(
        planned=False, completed=False, arrived=False, success=False, false_complete=False,
        time_limit_reached=False, goals_reached=0, goals=len(spec.mission.goals), error="",
    )  # fmt: skip
    row["goal_figures"] = []
    return row


def _closest(rows: list[dict[str, float]], lo: int, hi: int, gx: float, gy: float) -> tuple[float, float]:
    """The least horizontal distance (m) from rows lo..hi-1 to (gx, gy), and when (s)."""
    best = min(rows[lo:hi] or rows[-1:], key=lambda r: math.hypot(r["x_m"] - gx, r["y_m"] - gy))
    return math.hypot(best["x_m"] - gx, best["y_m"] - gy), best["t_s"]


def judge_goals(
    spec: RunSpec,
    rows: list[dict[str, float]],
    legs: list[list[list[float]]],
    last: dict[str, Any],
    complete_row: int | None = None,
) -> list[dict[str, Any]]:
    """Every goal judged on the truth, in order (one dict each: ``index``, ``closest_m`` and
    ``closest_t_s`` (the closest approach, horizontal, from the previous goal's crossing to this one's, or
    to the end), ``arrived`` (its line crossed), ``arrival_t_s``, ``position_error_m``,
    ``course_error_deg``, ``reached`` (arrived within the spec's position and course bounds)).

    ``legs`` are the planned legs' polylines (``[[x_m, y_m, yaw_deg], ...]``, one per goal). An
    intermediate goal is judged at its first crossing within the bounds, else its closest crossing (a miss
    and a second approach cross twice); the next goal is searched from there. The last goal is ``last``
    (:func:`hil_sim.metrics.compute_metrics` at the crossing the vehicle claimed).

    A goal with its own acceptance radius (the spec's ``radius_m``) is judged as the vehicle judges it:
    within that radius, by position (its heading is guidance's arrival tolerance): an intermediate one at
    its closest approach, the last where the vehicle said COMPLETE (``complete_row``; it need not cross the
    goal line: arriving within the radius is the arrival)."""
    out: list[dict[str, Any]] = []
    start = 0
    goals = spec.mission.goals
    for i, (gx, gy, _depth, gyaw) in enumerate(goals):
        radius_m = spec.mission.goal_radius_m(i)
        if radius_m > 0.0:
            last_goal = i == len(goals) - 1
            out.append(_judge_by_radius(rows, start, i, (gx, gy), radius_m, last_goal, complete_row))
            start = out[-1].pop("row")
            continue
        if i == len(goals) - 1:
            arrived = bool(last["completed"])
            hit: dict[str, Any] | None = (
                {"row": last["arrival_row"], "t_s": last["arrival_time_s"],
                 "position_error_m": last["final_position_error_m"],
                 "course_error_deg": last["final_course_error_deg"]} if arrived else None
            )  # fmt: skip
        else:
            crossings = goal_crossings(rows[start:], legs[i] if i < len(legs) else [], (gx, gy, gyaw))
            within = [c for c in crossings if _within(spec, c["position_error_m"], c["course_error_deg"])]
            best = within or sorted(crossings, key=lambda c: c["position_error_m"])
            hit = {**best[0], "row": best[0]["row"] + start} if best else None
            arrived = hit is not None
        end = hit["row"] + 1 if hit is not None else len(rows)
        closest_m, closest_t = _closest(rows, start, end, gx, gy)
        error = None if hit is None else hit["position_error_m"]
        course = None if hit is None else _finite(hit["course_error_deg"])
        out.append({
            "index": i, "closest_m": closest_m, "closest_t_s": closest_t, "arrived": arrived,
            "arrival_t_s": None if hit is None else hit["t_s"], "position_error_m": error,
            "course_error_deg": course,
            "reached": bool(arrived and error is not None and _within(spec, error, course)),
        })  # fmt: skip
        if hit is not None:
            start = hit["row"]
    return out


def _judge_by_radius(
    rows: list[dict[str, float]],
    start: int,
    index: int,
    goal_xy: tuple[float, float],
    radius_m: float,
    last: bool,
    complete_row: int | None,
) -> dict[str, Any]:
    """:func:`judge_goals`' figures of a goal with its own acceptance radius (and ``row``, where the next
    goal is searched from)."""
    gx, gy = goal_xy
    closest_m, closest_t = _closest(rows, start, len(rows), gx, gy)
    k: int | None
    if last:
        k = complete_row
    else:
        span = range(start, len(rows)) if start < len(rows) else range(len(rows) - 1, len(rows))
        k = min(span, key=lambda j: math.hypot(rows[j]["x_m"] - gx, rows[j]["y_m"] - gy))
    at = None if k is None else rows[k]
    error = None if at is None else math.hypot(at["x_m"] - gx, at["y_m"] - gy)
    reached = error is not None and error <= radius_m
    row = k if k is not None and not last else start
    return {
        "index": index, "closest_m": closest_m, "closest_t_s": closest_t, "arrived": reached,
        "arrival_t_s": None if at is None else at["t_s"], "position_error_m": error,
        "course_error_deg": None, "radius_m": radius_m, "reached": reached, "row": row,
    }  # fmt: skip


def _within(spec: RunSpec, error_m: float, course_deg: float | None) -> bool:
    """Within the spec's success bounds of position (m) and course (deg; nan or None: not judged, fails)."""
    return (
        error_m <= spec.success_position_m
        and course_deg is not None
        and math.isfinite(course_deg)
        and abs(course_deg) <= spec.success_course_deg
    )


def nees_figures(samples: list[tuple[float, float, float, float]]) -> dict[str, Any]:
    """How honest the onboard's position sigma was over the run: per sample (one a tick while the clock runs
    and the position is valid: the truth's error from the estimate ``(ex_m, ey_m)`` and the estimate's
    variances ``(var_x_m2, var_y_m2)``) the NEES (:func:`onboard.core.nav.confidence.nees`); ``nees_mean``
    (a consistent filter: 2), ``nees_in_band_fraction`` (within the 2-dof 95 % band: 0.95) and
    ``nees_above_fraction`` (above it, the filter overconfident: 0.025). None without a sample."""
    values = [nees(ex, ey, vx, vy) for ex, ey, vx, vy in samples if vx > 0.0 and vy > 0.0]
    if not values:
        return dict.fromkeys(("nees_mean", "nees_in_band_fraction", "nees_above_fraction"))
    lo, hi = NEES_BAND
    n = len(values)
    return {
        "nees_mean": math.fsum(values) / n,
        "nees_in_band_fraction": sum(1 for v in values if lo <= v <= hi) / n,
        "nees_above_fraction": sum(1 for v in values if v > hi) / n,
    }


def end_figures(truth: list[list[Any]]) -> dict[str, Any]:
    """The end of the mission (the first row in COMPLETE, HOLD or ABORT) and what followed up to the end of
    the run: ``end_state``, ``end_time_s``, ``glide_after_end_m`` (horizontal path length, m) and
    ``max_depth_after_end_m``; all None when the run ended before any (e.g. at the time limit)."""
    at = next((k for k, r in enumerate(truth) if r[_STATE] in END_STATES), None)
    if at is None:
        return dict.fromkeys(("end_state", "end_time_s", "glide_after_end_m", "max_depth_after_end_m"))
    after = truth[at:]
    glide = sum(math.hypot(b[_X] - a[_X], b[_Y] - a[_Y]) for a, b in itertools.pairwise(after))
    return {
        "end_state": truth[at][_STATE],
        "end_time_s": truth[at][_T],
        "glide_after_end_m": glide,
        "max_depth_after_end_m": max(r[_D] for r in after),
    }


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
    time_limit_reached: bool = False,
    legs: list[list[list[float]]] | None = None,
    nav_errors: list[tuple[float, float, float, float]] | None = None,
) -> dict[str, Any]:
    """One row of ``runs.csv`` (``results.COLUMNS`` without the timing of the run itself) and, under
    ``goal_figures``, the list of :func:`judge_goals` (the run JSON keeps it; the CSV does not).

    ``samples`` is the planned path through every goal; ``legs`` the same per goal (default: one leg, the
    whole path, for a one-goal mission). ``time_limit_reached``: the run was stopped at its time limit
    before the vehicle reached an end state. ``nav_errors``: the navigation's samples of
    :func:`nees_figures` (the NEES columns; None: not measured)."""
    row = base_row(spec)
    if nav_errors is not None:
        row.update(nees_figures(nav_errors))
    row.update(
        planned=planned, final_state=final_state, final_reason=final_reason, time_limit_s=time_limit_s,
        time_limit_reached=time_limit_reached,
    )  # fmt: skip
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
        completed=complete_at is not None,
        arrived=met["completed"],
        final_position_error_m=met["final_position_error_m"],
        final_course_error_deg=course,
        final_heading_error_deg=met["final_yaw_error_deg"],
        final_depth_error_m=met["final_depth_error_m"],
        max_cross_track_m=_finite(met["max_cross_track_m"]),
        rms_cross_track_m=_finite(met["rms_cross_track_m"]),
        time_to_goal_s=met["arrival_time_s"] if met["completed"] else None,
    )
    goal_figures = judge_goals(spec, rows, legs if legs is not None else [samples], met, complete_at)
    row["goal_figures"] = goal_figures
    row["goals_reached"] = sum(1 for g in goal_figures if g["reached"])
    row["max_goal_closest_m"] = max(g["closest_m"] for g in goal_figures)
    row.update(end_figures(truth))
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
    last_radius_m = spec.mission.goal_radius_m(len(spec.mission.goals) - 1)
    if first_complete is not None:
        miss_m = math.hypot(first_complete[_X] - gx, first_complete[_Y] - gy)
        # the radius the vehicle judged by: the goal's own, else its [mission] arrival_radius_m
        row["false_complete"] = miss_m > (last_radius_m if last_radius_m > 0.0 else arrival_radius_m)
    depth_ok = spec.success_depth_m is None  # the truth's depth where the vehicle said COMPLETE
    if first_complete is not None and spec.success_depth_m is not None:
        depth_ok = abs(first_complete[_D] - gdepth) <= spec.success_depth_m
        row["false_complete"] = row["false_complete"] or not depth_ok
    clear = row["min_clearance_m"] is None or row["min_clearance_m"] >= 0.0
    bound = spec.success_cross_track_m
    on_path = bound is None or (row["max_cross_track_m"] is not None and row["max_cross_track_m"] <= bound)
    # the last goal at its line crossing within the spec's bounds; one with its own radius by that radius
    last_ok = (
        goal_figures[-1]["reached"]
        if last_radius_m > 0.0
        else met["completed"]
        and met["final_position_error_m"] <= spec.success_position_m
        and course is not None
        and abs(course) <= spec.success_course_deg
    )
    row["success"] = bool(
        last_ok
        and row["completed"]
        and final_state == "COMPLETE"
        and not time_limit_reached
        and not row["false_complete"]
        and row["goals_reached"] == len(goal_figures)
        and on_path
        and clear
        and depth_ok
    )
    return row
