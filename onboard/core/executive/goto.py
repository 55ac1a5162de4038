"""Goto: homing to the mission's goals, one after the other (the paper's homing; DUNE's Goto).

It owns, for the goal in force (``status.goal_index``):

- the plan: asked for at START (afresh, from where the vehicle is), after each goal reached (the next goal,
  from here), after a miss (the same goal pose) and when the water current turns out other than planned for;
- arrival, judged at 95 %: once guidance says ``arrived``, a goal is reached only when the estimate's 95 %
  confidence region lies within the goal's acceptance radius (its own ``radius_m``, else ``[mission]
  arrival_radius_m``: :func:`~onboard.core.mission.model.goal_radius_m`): the distance from the goal plus
  the region's major semi-axis (2.448 sigma_max, :mod:`onboard.core.nav.confidence`) <= the radius. Short
  of it the vehicle keeps homing until it passes the goal line (the region fits as it closes), then it is
  a miss; a region wider than the radius on its own (the navigation cannot confirm any arrival) is HOLD
  with the figures;
- misses: farther off it is a miss, re-planned from where the vehicle is to the same goal pose, up to
  ``max_tries`` attempts, then HOLD with the reason;
- re-plans on current: a path planned for one current (``[planner] current_aware``) is planned again when
  the estimate has moved by :data:`REPLAN_CURRENT_CHANGE_MPS` (the start's estimate is a guess until the
  vehicle turns), with a note; if that plan fails the path flown stays;
- progress: ``goals_reached`` since the mission (re)started (MISSION_ITEM_REACHED) and ``attempt``;
- the leg monitors (:mod:`~onboard.core.executive.monitors`): along-track progress, cross-track, ETA and
  feasibility against the current; one that fires ends the leg with ``[mission] monitor_action`` (HOLD or
  ABORT) and the figure in the reason.

After the last goal the state table makes the mission COMPLETE and the executive hands over to the end
action (:mod:`~onboard.core.executive.loiter` or :mod:`~onboard.core.executive.surface`).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

from onboard.core.commands import Severity
from onboard.core.executive.maneuver import Leg, Plans, Progress, Vehicle
from onboard.core.executive.monitors import LegMonitor
from onboard.core.mission.model import goal_radius_m
from onboard.core.mission.state import MissionEvent, MissionState
from onboard.core.nav.confidence import CONFIDENCE_SCALE, confidence_radius_m
from onboard.core.nav.types import NavState
from onboard.core.plans import current_radius_m

log = logging.getLogger(__name__)

#: A goal path is planned again when the current estimate has moved this much (m/s) since it was asked for
#: (the start's estimate is a guess until the vehicle has turned: along its heading only current + water
#: speed is seen), and not more often than every REPLAN_MIN_INTERVAL_S (s).
REPLAN_CURRENT_CHANGE_MPS = 0.1
REPLAN_MIN_INTERVAL_S = 5.0


@dataclass
class Goto:
    """Homing to goal ``status.goal_index``; ``attempt`` counts the tries at it (1 = the first)."""

    kind = "goal"
    goals_reached: int = 0
    attempt: int = 1
    monitor: LegMonitor = field(default_factory=LegMonitor)

    def reset(self) -> None:
        """A new mission: nothing reached yet."""
        self.goals_reached = 0
        self.attempt = 1
        self.monitor.reset()

    def start(self, ex: Plans, v: Vehicle) -> None:
        self.attempt = 1
        self.monitor.reset()  # the legs are watched afresh from where the vehicle is
        ex.drop_path()
        ex.ask_plan(v, "goal")  # afresh, from where the vehicle is

    def goal_set(self, ex: Plans) -> None:
        """The operator made another goal the current one: a first try at it, planned when next flown."""
        self.attempt = 1
        self.monitor.reset()
        ex.drop_path()

    def step(self, ex: Plans, v: Vehicle, nav: NavState, dt_s: float) -> Leg | None:
        index = v.status.goal_index
        if ex.path is None or ex.path_goal_index != index or ex.path_kind != "goal":
            wait = ex.plan_waiting
            if wait is None or wait.goal_index != index:
                ex.ask_plan(v, "goal")
            return None
        leg = ex.follow(v, nav, dt_s)
        if leg.reference.arrived:
            self.arrived(ex, v, nav)
        if v.status.state is not MissionState.RUNNING or ex.path is None:
            return None  # reached (COMPLETE, or the next goal's plan is asked for), missed, or held
        why = self.monitor.check(
            v.config,
            nav,
            v.mission.goals[index],
            (index, self.attempt),
            ex.path,
            ex.guidance_state.s_proj_m,
            leg.reference.cross_track_m,
            v.now_s,
        )
        if why:  # the leg cannot be flown: the configured action, the figure named
            log.warning("%s", why)
            if v.config.mission.monitor_action == "abort":
                v.apply(MissionEvent.ABORT, why)
            else:
                v.apply(MissionEvent.HOLD, why, severity=Severity.WARNING)
            return None
        if self._current_changed(ex, v, nav):
            ex.ask_plan(v, "goal", replan=True)
        return leg

    def plan_failed(self, ex: Plans, v: Vehicle, why: str, late: bool) -> None:
        text = why if late else f"cannot plan goal {v.status.goal_index}: {why}"
        v.apply(MissionEvent.HOLD, text, severity=Severity.WARNING)

    def done(self, v: Vehicle) -> bool:
        return v.status.state is MissionState.COMPLETE

    def progress(self, ex: Plans, v: Vehicle) -> Progress:
        n = len(v.mission.goals)
        text = f"goal {v.status.goal_index} of {n}, try {self.attempt}, {self.goals_reached} reached"
        return Progress(text, self.goals_reached / n if n else math.nan)

    def arrived(self, ex: Plans, v: Vehicle, nav: NavState) -> None:
        """Guidance says arrived: reached when the estimate's 95 % region lies within the goal's radius;
        short of it, homing goes on until the goal line is passed; past it, a miss. A region wider than the
        radius on its own: HOLD, the arrival cannot be confirmed (the figures in the reason)."""
        index = v.status.goal_index
        goal = v.mission.goals[index]
        miss_m = math.hypot(goal.x_m - nav.x_m, goal.y_m - nav.y_m)
        radius = goal_radius_m(goal, v.config.mission.arrival_radius_m)
        sigma_m = nav.position_std_max_m
        region_m = confidence_radius_m(sigma_m)
        if not region_m <= radius:  # the estimate itself is less certain than the precision to claim
            v.apply(
                MissionEvent.HOLD,
                f"goal {index} cannot be confirmed: the position's 95 % region is {region_m:.1f} m "
                f"({CONFIDENCE_SCALE:.2f} x {sigma_m:.2f} m, 1 sigma), wider than the arrival radius "
                f"{radius:g} m",
                severity=Severity.WARNING,
            )
            return
        if miss_m + region_m > radius and not self._past_goal(ex, nav, goal.x_m, goal.y_m):
            return  # not confirmed yet: keep homing, the region fits as the vehicle closes
        if miss_m + region_m <= radius:
            self.goals_reached += 1
            self.attempt = 1
            v.apply(MissionEvent.GOAL_REACHED, f"{miss_m:.2f} m from it")
            if v.status.state is MissionState.RUNNING:
                ex.drop_path()
                ex.ask_plan(v, "goal")  # the next goal, from here
            else:  # COMPLETE: the end action starts now
                ex.path, ex.path_goal_index, ex.path_kind = None, -1, ""
            return
        tries = v.config.mission.max_tries
        if self.attempt < tries:
            self.attempt += 1
            text = (
                f"goal {index} missed by {miss_m:.2f} m (+ {region_m:.2f} m at 95 %; arrival radius "
                f"{radius:g} m): re-planning, try {self.attempt} of {tries}"
            )
            log.warning("%s", text)
            v.note(Severity.WARNING, text)
            ex.drop_path()
            ex.ask_plan(v, "goal")
            return
        v.apply(
            MissionEvent.HOLD,
            f"goal {index} missed by {miss_m:.2f} m after {tries} tries",
            severity=Severity.WARNING,
        )

    @staticmethod
    def _past_goal(ex: Plans, nav: NavState, gx_m: float, gy_m: float) -> bool:
        """The estimate is on or past the goal line (through the goal, across the path's final heading)."""
        if ex.path is None:
            return True
        yaw = ex.path.sample(ex.path.length_m).yaw_rad
        return (nav.x_m - gx_m) * math.cos(yaw) + (nav.y_m - gy_m) * math.sin(yaw) >= 0.0

    @staticmethod
    def _current_changed(ex: Plans, v: Vehicle, nav: NavState) -> bool:
        """True when the flown goal path should be planned again for the current now estimated: the
        planner widens turns for a current (``current_aware``), the estimate has moved by
        :data:`REPLAN_CURRENT_CHANGE_MPS` since the path was asked for (at least :data:`REPLAN_MIN_INTERVAL_S`
        ago), and the goal is far enough for a new path to differ (twice the widest turn plus the run-in)."""
        planner = v.config.planner
        if not planner.current_aware or ex.plan_waiting is not None:
            return False
        if v.now_s - ex.path_t_s < REPLAN_MIN_INTERVAL_S:
            return False
        now_mps = ex.current_mps(nav)
        if abs(now_mps - ex.path_current_mps) < REPLAN_CURRENT_CHANGE_MPS:
            return False
        goal = v.mission.goals[v.status.goal_index]
        radius_m = current_radius_m(planner.turning_radius_m, v.config.guidance.speed_mps, now_mps)
        far_m = 2.0 * radius_m + ex.goal_run_in_m(v, v.status.goal_index)
        return math.hypot(goal.x_m - nav.x_m, goal.y_m - nav.y_m) > far_m
