"""Leg monitors and the feasibility check: no mission stays RUNNING without progress (DUNE's PathController).

Every goal (all its tries) is watched while :class:`~onboard.core.executive.goto.Goto` flies it, with the
``[mission]`` thresholds (:class:`~onboard.core.mission.params.MissionParams`):

- **progress**: the vehicle's projection on the path flown (guidance's ``s_proj_m``) must advance, or its
  distance off the path shrink, by at least ``progress_min_mps`` x ``monitor_window_s`` over every window
  (behind the path's start the way back onto it is the way to its start; a setback there in a goal's first
  :data:`START_ALLOWANCE_S`, getting under way, is not counted as lost: a vehicle that starts drifting
  with the water is set back first)
  (what is left to fly is the path beyond the projection plus the way back onto it: a vehicle swept wide
  in a turn that comes back onto the path's end makes progress, one swept away loses it; a new path for
  the same goal, a re-plan on current or the next try after a miss, continues the sum: a vehicle that
  misses and loops back again and again is judged on the whole);
- **cross-track**: off the path flown by more than ``cross_track_max_m`` + ``cross_track_sigmas`` x the
  position estimate's 1-sigma for ``cross_track_time_s`` (the bound widens with the navigation's
  uncertainty);
- **ETA**: each goal's expected time comes from its first plan and the current estimate then (the path's
  length at the speed over ground the vehicle can make good towards the goal, the guidance speed at most,
  plus the start from rest); a goal that takes ``eta_factor`` times that, over all its tries, has failed;
- **feasibility**: a goal the vehicle cannot make good against the estimated current at
  ``min_made_good_mps`` (its top speed through the water is its speed map at the propeller's limit,
  ``LIM_RPS_MAX``) is refused at START (by the commander, :func:`feasibility`) and, while RUNNING, ends the
  leg once it has lasted ``feasibility_time_s``. The current is judged only when the estimate is good to
  :data:`~onboard.core.nav.current.CURRENT_BELIEVED_STD_MPS`, and with the benefit of the doubt (its speed
  less its 1-sigma).

A monitor that fires ends the leg with ``monitor_action`` (HOLD, or ABORT) and a reason that names the
figure; the reason reaches the operator as the state's reason and a STATUSTEXT, as every HOLD's does.
Pure: the vehicle's time is the caller's ``now_s``; the figures are the navigation estimate's.

Why these times (measured over the repo's campaign specs, issue 23): the progress window stays 60 s because
missions that complete make less than 0.1 m/s over shorter windows (head_current.yaml 1.6 m/s: 0.09 m/s over
the first 30 s from rest; strong_current.yaml 1.5 m/s towards 0: -0.06 m/s over 45 s, swept wide in its
turn); no completing run was ever beyond the cross-track bound, nor judged unable to make its goal good, so
those two have times of their own, 20 s (DUNE: 15 m for 10 s); the ETA stays 4 x (head_current completes
in up to 3.4 x the time its vehicle expects: along a straight the estimate cannot see a head current).
:func:`latest_end_s` is the bound all this sets; the campaign's time limit is never shorter.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, field

from onboard.core.config import CoreConfig
from onboard.core.control.pd import ControlParams
from onboard.core.mission.model import Goal
from onboard.core.nav.current import CURRENT_BELIEVED_STD_MPS
from onboard.core.nav.types import NavState
from onboard.core.planner.path import Path

#: Closer than this to the goal (m) the bearing to it means little: no feasibility verdict.
FEASIBILITY_MIN_DISTANCE_M = 2.0
#: The start from rest added to a leg's expected time (s; the campaign's allowance too).
START_ALLOWANCE_S = 10.0
#: Progress samples are kept this far apart (s), a window's worth.
SAMPLE_PERIOD_S = 1.0


def water_speed_max_mps(control: ControlParams) -> float:
    """The vehicle's top speed through the water (m/s): its speed map (``[control] speed_map_*``) at the
    propeller's limit (``[control.limits] propeller_max_rps``), extrapolated along the last row as the
    feed-forward is."""
    mps, rps = control.speed_map_mps, control.speed_map_rps
    top = control.limits.propeller_max_rps
    best = 0.0
    for i in range(len(mps) - 1):
        m0, m1, r0, r1 = mps[i], mps[i + 1], rps[i], rps[i + 1]
        if top >= max(r0, r1):
            best = max(best, m1)
        elif r1 > r0 and top > r0:
            best = max(best, m0 + (top - r0) * (m1 - m0) / (r1 - r0))
    m0, m1, r0, r1 = mps[-2], mps[-1], rps[-2], rps[-1]
    if top > r1 > r0:
        best = max(best, m1 + (top - r1) * (m1 - m0) / (r1 - r0))
    return best


def made_good_mps(current_n_mps: float, current_e_mps: float, bearing_rad: float, water_mps: float) -> float:
    """The fastest speed over ground (m/s) along ``bearing_rad`` (NED, from north) holding that line, with
    ``water_mps`` through the water in the current (c_n, c_e): c.d + sqrt(U^2 - (c x d)^2). Negative when the
    vehicle loses ground; when the current across the line is faster than U the line cannot be held at
    all: U - |c x d| (< 0) + min(c.d, 0)."""
    d_n, d_e = math.cos(bearing_rad), math.sin(bearing_rad)
    along = current_n_mps * d_n + current_e_mps * d_e
    across = abs(current_e_mps * d_n - current_n_mps * d_e)
    if across > water_mps:
        return water_mps - across + min(along, 0.0)
    return along + math.sqrt(water_mps * water_mps - across * across)


def believed_current(nav: NavState) -> tuple[float, float] | None:
    """The current estimate (c_n, c_e) in m/s shrunk by its 1-sigma (the benefit of the doubt), or None
    while it is vaguer than :data:`~onboard.core.nav.current.CURRENT_BELIEVED_STD_MPS`."""
    std = nav.current_std_mps
    if not std < CURRENT_BELIEVED_STD_MPS:
        return None
    c_n, c_e = nav.current_north_mps, nav.current_east_mps
    speed = math.hypot(c_n, c_e)
    if not math.isfinite(speed):
        return None
    if speed <= std:
        return 0.0, 0.0
    k = (speed - std) / speed
    return c_n * k, c_e * k


def feasibility(config: CoreConfig, nav: NavState, goal: Goal, goal_index: int) -> str:
    """ "" when goal ``goal_index`` can be made good from ``nav`` against the estimated current, else why,
    with the figures ("current 1.73 m/s towards 180 deg; the vehicle makes good at most 0.00 m/s towards
    goal 0 ...")."""
    need = config.mission.min_made_good_mps
    if need <= 0.0:
        return ""
    current = believed_current(nav)
    dx, dy = goal.x_m - nav.x_m, goal.y_m - nav.y_m
    if current is None or not math.hypot(dx, dy) > FEASIBILITY_MIN_DISTANCE_M:
        return ""
    top = water_speed_max_mps(config.control)
    made_good = made_good_mps(current[0], current[1], math.atan2(dy, dx), top)
    if made_good >= need:
        return ""
    c_n, c_e = nav.current_north_mps, nav.current_east_mps
    towards_deg = math.degrees(math.atan2(c_e, c_n)) % 360.0
    return (
        f"current {math.hypot(c_n, c_e):.2f} m/s towards {towards_deg:.0f} deg; the vehicle makes good at "
        f"most {max(made_good, 0.0):.2f} m/s towards goal {goal_index} (MIS_MG_MIN_MPS {need:g}; "
        f"{top:.2f} m/s through the water at {config.control.limits.propeller_max_rps:g} rps)"
    )


def expected_speed_mps(config: CoreConfig, current: tuple[float, float] | None, bearing_rad: float) -> float:
    """The speed over ground (m/s) a leg towards ``bearing_rad`` is expected to be flown at: the guidance
    speed, or the speed the vehicle can make good along the bearing against ``current`` (c_n, c_e; m/s) at
    its top speed through the water if that is slower (<= 0: it cannot). ``current`` None: not known, the
    guidance speed."""
    speed = config.guidance.speed_mps
    if current is not None:
        top = water_speed_max_mps(config.control)
        speed = min(speed, made_good_mps(current[0], current[1], bearing_rad, top))
    return speed


def expected_time_s(config: CoreConfig, nav: NavState, goal: Goal, length_m: float) -> float:
    """A leg's expected time (s): ``length_m`` of path at the speed over ground the vehicle can make good
    towards ``goal`` in the estimated current (:func:`expected_speed_mps`; the guidance speed while the
    current is not known), plus :data:`START_ALLOWANCE_S`. Infinite when it cannot make the goal good."""
    current = believed_current(nav)
    dx, dy = goal.x_m - nav.x_m, goal.y_m - nav.y_m
    if not math.hypot(dx, dy) > FEASIBILITY_MIN_DISTANCE_M:
        current = None
    speed = expected_speed_mps(config, current, math.atan2(dy, dx))
    if not speed > 0.0:
        return math.inf
    return length_m / speed + START_ALLOWANCE_S


def latest_end_s(
    config: CoreConfig, legs: Sequence[tuple[float, float]], current_ne: tuple[float, float]
) -> float:
    """The latest time (s after START) by which the leg monitors end a mission whose legs ``(length_m,
    bearing_rad)`` are flown in the water current ``current_ne`` (c_n, c_e; m/s), had the vehicle estimated
    it right: per goal its ETA, ``eta_factor`` x :func:`expected_time_s` (the speed made good taken no
    slower than ``min_made_good_mps``: a goal made good slower is the feasibility monitor's, which ends the
    leg within its window), plus one monitor window for an estimate that is not the truth. A goal still
    RUNNING after it has outlived every monitor. Infinite when the ETA monitor is off (``eta_factor`` 0),
    or the feasibility monitor is (``min_made_good_mps`` 0) and a goal cannot be made good at all.

    The campaign's time limit is never shorter (:func:`auv_campaign.runner.time_limit_s`): a run RUNNING at
    it is one the vehicle's own supervision failed to end."""
    p = config.mission
    if not p.eta_factor > 0.0:
        return math.inf
    total_s = 0.0
    for length_m, bearing_rad in legs:
        speed = max(expected_speed_mps(config, current_ne, bearing_rad), p.min_made_good_mps)
        if not speed > 0.0:
            return math.inf
        total_s += p.eta_factor * (length_m / speed + START_ALLOWANCE_S)
    return total_s + max(p.monitor_window_s, p.cross_track_time_s, p.feasibility_time_s)


@dataclass
class LegMonitor:
    """The monitors' memory for the goal flown (``key``: goal index and try). Progress, the ETA and the
    feasibility verdict run per goal, over all its tries (``eta_goal``, ``start_s``): a vehicle that misses
    the goal and loops back to try again, again and again, is judged on the progress of the whole, not
    afresh after every miss. :meth:`check` once a tick."""

    key: tuple[int, int] | None = None
    eta_goal: int | None = None
    start_s: float = 0.0
    expected_s: float = math.inf
    expected_text: str = ""
    progress_m: float = 0.0  # progress on the leg (along the path, back onto it), summed over its paths (m)
    _path: Path | None = None  # the path the last projection was on
    _s_prev_m: float | None = None
    _off_prev_m: float = 0.0
    _samples: deque[tuple[float, float]] = field(default_factory=deque)  # (t_s, progress_m)
    _under_way_s: float = 0.0  # a setback before then is not lost progress (the goal's start + allowance)
    _off_since_s: float | None = None  # off the path beyond the bound since
    _infeasible_since_s: float | None = None

    def reset(self) -> None:
        """Forget the leg (a START or RESUME flies afresh from where the vehicle is)."""
        self.key = self.eta_goal = None

    def _begin(self, now_s: float) -> None:
        """A new goal (or the same flown afresh after START / RESUME): its progress from 0; a setback
        behind the path's start in its first :data:`START_ALLOWANCE_S` (getting under way, the start the
        ETA allows for too) is not counted as lost: a vehicle that starts drifting with the water is set
        back 9.4 m by a 1.5 m/s head current before it stems it, then makes good 0.35 m/s; its way back to
        the path's start was not counted at all, and over its first 60 s it made only 5.1 m."""
        self.progress_m, self._path, self._s_prev_m = 0.0, None, None
        self._samples = deque([(now_s, 0.0)])
        self._under_way_s = now_s + START_ALLOWANCE_S
        self._off_since_s = self._infeasible_since_s = None

    def check(
        self,
        config: CoreConfig,
        nav: NavState,
        goal: Goal,
        key: tuple[int, int],
        path: Path,
        s_proj_m: float | None,
        cross_track_m: float,
        now_s: float,
    ) -> str:
        """One tick on the leg ``key`` = (goal index, try): "" while it is flown well, else why it has
        failed (the figure named). ``path``: the path flown (a new one for the leg starts its projection
        afresh); ``s_proj_m`` / ``cross_track_m``: the vehicle on the path flown (guidance)."""
        p = config.mission
        index = key[0]
        self.key = key  # a new try at the goal continues its progress (a new path for it continues the sum)
        if index != self.eta_goal:  # a new goal: its expected time from its first plan and the current now
            self._begin(now_s)
            self.eta_goal, self.start_s = index, now_s
            self.expected_s = expected_time_s(config, nav, goal, path.length_m)
            self.expected_text = f"{path.length_m:.1f} m of path"
        # progress: along the path and back onto it, summed over the leg's paths; behind the path's start
        # (the projection held at 0) the way back onto it is the way to its start
        off_m = abs(cross_track_m)
        behind = s_proj_m is not None and s_proj_m <= 0.0
        if behind:
            start = path.sample(0.0)
            off_m = max(off_m, math.hypot(nav.x_m - start.x_m, nav.y_m - start.y_m))
        if s_proj_m is not None and math.isfinite(s_proj_m) and math.isfinite(off_m):
            if path is self._path and self._s_prev_m is not None:
                self.progress_m += (s_proj_m - self._s_prev_m) - (off_m - self._off_prev_m)
            self._path, self._s_prev_m, self._off_prev_m = path, s_proj_m, off_m
        window = p.monitor_window_s
        if behind and now_s < self._under_way_s:  # set back before it reached its path: getting under way
            self.progress_m = max(self.progress_m, 0.0)
        if now_s - self._samples[-1][0] >= SAMPLE_PERIOD_S:
            self._samples.append((now_s, self.progress_m))
        while len(self._samples) > 1 and now_s - self._samples[1][0] >= window:
            self._samples.popleft()
        t0, prog0 = self._samples[0]
        if p.progress_min_mps > 0.0 and now_s - t0 >= window:
            made_m = self.progress_m - prog0
            if made_m < p.progress_min_mps * (now_s - t0):
                return (
                    f"goal {index}: no progress, {made_m:.1f} m along the path or back onto it in "
                    f"{now_s - t0:.0f} s "
                    f"(MIS_PROG_MPS {p.progress_min_mps:g} m/s: at least "
                    f"{p.progress_min_mps * (now_s - t0):.1f} m)"
                )
        # cross-track, the bound widened by the navigation's uncertainty, for its own time
        if p.cross_track_max_m > 0.0:
            std = nav.position_std_m if math.isfinite(nav.position_std_m) else 0.0
            bound = p.cross_track_max_m + p.cross_track_sigmas * std
            if abs(cross_track_m) > bound:
                if self._off_since_s is None:
                    self._off_since_s = now_s
                if now_s - self._off_since_s >= p.cross_track_time_s:
                    return (
                        f"goal {index}: {abs(cross_track_m):.1f} m off the path for "
                        f"{p.cross_track_time_s:g} s (MIS_XTRACK_S; MIS_XTRACK_M {p.cross_track_max_m:g} m + "
                        f"{p.cross_track_sigmas:g} x the position's 1 sigma {std:.1f} m = {bound:.1f} m)"
                    )
            else:
                self._off_since_s = None
        # ETA
        elapsed = now_s - self.start_s
        if p.eta_factor > 0.0 and elapsed > p.eta_factor * self.expected_s:
            return (
                f"goal {index}: {elapsed:.0f} s on it, over MIS_ETA_FACTOR {p.eta_factor:g} x its "
                f"expected {self.expected_s:.0f} s ({self.expected_text})"
            )
        # feasibility against the current estimated now
        why = feasibility(config, nav, goal, index)
        if why:
            if self._infeasible_since_s is None:
                self._infeasible_since_s = now_s
            if now_s - self._infeasible_since_s >= p.feasibility_time_s:
                return f"{why}, for {p.feasibility_time_s:g} s (MIS_MG_S)"
        else:
            self._infeasible_since_s = None
        return ""


__all__ = [
    "LegMonitor",
    "expected_speed_mps",
    "expected_time_s",
    "feasibility",
    "latest_end_s",
    "made_good_mps",
    "water_speed_max_mps",
]
