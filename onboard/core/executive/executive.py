"""The executive: what the vehicle is doing now, and the plans that needs (DUNE's maneuver supervisor).

It picks the maneuver the mission state asks for (:meth:`Executive.active`: RUNNING -> :class:`Goto`,
COMPLETE -> the end action, :class:`Loiter` or :class:`Surface`; nothing otherwise) and steps it once a tick.
It owns the path flown and guidance's memory on it, and schedules the plans off the control thread: the
core never plans inside its step; it puts a :class:`~onboard.core.plans.PlanRequest` out
(:meth:`take_plan_request`), the loop's worker computes it and hands the answer back (:meth:`plan_done`)
before a later step; a plan that misses ``[mission] plan_deadline_s`` is the maneuver's failure. No clock,
no I/O: the vehicle's time is ``Vehicle.now_s``.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

from onboard.core import guidance
from onboard.core.commands import Severity
from onboard.core.executive.goto import Goto
from onboard.core.executive.loiter import Loiter
from onboard.core.executive.maneuver import Leg, Maneuver, Vehicle
from onboard.core.executive.surface import Stop, Surface, arrival_speed_mps
from onboard.core.mission.model import goal_radius_m
from onboard.core.mission.state import MissionEvent, MissionState
from onboard.core.nav.current import CURRENT_BELIEVED_STD_MPS, CURRENT_NOISE_MPS
from onboard.core.nav.types import NavState
from onboard.core.planner.errors import PlannerError
from onboard.core.planner.path import Path
from onboard.core.plans import PlanRequest, last_goal_run_in_m

log = logging.getLogger(__name__)


@dataclass
class Executive:
    """The maneuvers, the path flown (``path_kind`` "goal" to goal ``path_goal_index``, "loiter", or
    "surface" once a loiter fell back to surfacing) and the plan requests in flight."""

    goto: Goto = field(default_factory=Goto)
    loiter: Loiter = field(default_factory=Loiter)
    surface: Surface = field(default_factory=Surface)
    stop: Stop = field(default_factory=Stop)  # the brake after COMPLETE (surface) and in HOLD
    path: Path | None = None
    path_goal_index: int = -1
    path_kind: str = ""
    planner_error: str = ""
    guidance_state: guidance.GuidanceState = field(default_factory=guidance.GuidanceState)
    path_current_mps: float = 0.0  # the current (m/s) the flown path was planned for
    path_t_s: float = -math.inf  # when the flown path was asked for (the core's time, s)
    #: the largest |cross-track| (m, the estimate's) on the goal paths since the mission (re)started: the
    #: planner's obstacle margin grows to it (``PlannerConfig.grown_margin_m``)
    cross_track_bound_m: float = 0.0
    _plan_out: PlanRequest | None = None  # asked for, not yet taken by the loop
    _plan_wait: PlanRequest | None = None  # taken (or asked for): the result is awaited
    _plan_ids: int = 0

    # --- which maneuver ----------------------------------------------------------------------------
    def loitering(self, v: Vehicle) -> bool:
        """The end action is a loiter that has not fallen back to surfacing."""
        return v.config.mission.end_action == "loiter" and self.path_kind != "surface"

    def active(self, v: Vehicle) -> Maneuver | None:
        """The maneuver the mission state asks for now (None: nothing is flown, the vehicle holds still)."""
        state = v.status.state
        if state is MissionState.RUNNING:
            return self.goto
        if state is MissionState.COMPLETE:
            return self.loiter if self.loitering(v) else self.surface
        return None

    def step(self, v: Vehicle, nav: NavState, dt_s: float) -> Leg | None:
        """One tick: a plan past its deadline fails its maneuver, then the active maneuver steps."""
        req = self._plan_wait
        deadline_s = v.config.mission.plan_deadline_s
        if req is not None and v.now_s - req.t_s > deadline_s:
            self._plan_wait = self._plan_out = None
            why = f"planning {req.kind} {req.goal_index} missed its deadline ({deadline_s:g} s)"
            self.planner_error = why
            maneuver = self.active(v)
            if maneuver is not None and maneuver.kind == req.kind:
                maneuver.plan_failed(self, v, why, late=True)
        maneuver = self.active(v)
        return None if maneuver is None else maneuver.step(self, v, nav, dt_s)

    def follow(self, v: Vehicle, nav: NavState, dt_s: float) -> Leg:
        """Guidance on the path flown, one step (the maneuvers call it; ``path`` is not None). The path to
        the mission's last goal ends in the run-in: its speed falls to ``[mission] arrival_speed_mps`` (more
        in a current) at the goal, so the end can stop (:mod:`~onboard.core.executive.surface`)."""
        assert self.path is not None
        mission = v.config.mission
        goals = v.mission.goals
        to_goal = self.path_kind == "goal" and 0 <= self.path_goal_index < len(goals)
        last = to_goal and self.path_goal_index == len(goals) - 1
        # the goal's own acceptance radius (else the default) ends its path
        radius_m = goal_radius_m(goals[self.path_goal_index], mission.arrival_radius_m) if to_goal else None
        reference, self.guidance_state, debug = guidance.step(
            nav,
            self.path,
            self.guidance_state,
            v.config.guidance,
            dt_s,
            arrival_speed_mps=arrival_speed_mps(v.config, nav) if last else 0.0,
            run_in_decel_mps2=mission.run_in_decel_mps2,
            run_in_depth_slope=v.config.planner.max_depth_slope,
            arrival_radius_m=radius_m,
        )
        if self.path_kind == "goal" and abs(reference.cross_track_m) > self.cross_track_bound_m:
            self.cross_track_bound_m = abs(reference.cross_track_m)  # (NaN compares False: kept)
        return Leg(reference, debug)

    # --- what the state machine's transitions mean here ---------------------------------------------
    def on_transition(self, v: Vehicle, event: MissionEvent, after: MissionState) -> None:
        """After an accepted transition: a START or RESUME homes afresh from where the vehicle is; a state
        that flies nothing drops the path. COMPLETE (surface) and HOLD begin the stop (it brakes where
        nothing is flown: :class:`~onboard.core.executive.surface.Stop`); every other state ends it."""
        if event in (MissionEvent.START, MissionEvent.RESUME):
            self.cross_track_bound_m = 0.0  # measured afresh from where the vehicle is
            self.goto.start(self, v)
        if after is MissionState.HOLD or (after is MissionState.COMPLETE and not self.loitering(v)):
            self.begin_stop(v)
        else:
            self.stop.end()
        if after is not MissionState.RUNNING and after is not MissionState.COMPLETE:
            self.drop_path()

    def begin_stop(self, v: Vehicle) -> None:
        """Brake to a stop from now on, never deeper than the vehicle is now (a loiter that falls back to
        surfacing calls it too)."""
        n = v.last_nav
        obstacles = tuple((o.x_m, o.y_m, o.radius_m) for o in v.mission.obstacles) if v.mission else ()
        self.stop.begin(n.depth_m if n is not None else math.nan, obstacles)

    def mission_replaced(self) -> None:
        """New goals: nothing reached, no path."""
        self.goto.reset()
        self.drop_path()

    def fence_replaced(self, v: Vehicle) -> None:
        """A plan in flight or in use was made round the old obstacles: ask again (the old path is flown
        until the new one arrives; the answer to the old request is dropped)."""
        state = v.status.state
        if state is MissionState.RUNNING:
            self.ask_plan(v, "goal")
        elif state is MissionState.COMPLETE and self.path_kind == "loiter":
            self.ask_plan(v, "loiter")

    # --- plans off the control thread ----------------------------------------------------------------
    @property
    def braking(self) -> bool:
        """The stop is braking (after COMPLETE or in HOLD)."""
        return self.stop.braking

    @property
    def plan_waiting(self) -> PlanRequest | None:
        """The request whose answer is awaited, if any."""
        return self._plan_wait

    def drop_path(self) -> None:
        self.path, self.path_goal_index, self.path_kind = None, -1, ""
        self._plan_out = self._plan_wait = None

    @staticmethod
    def current_mps(nav: NavState) -> float:
        """The estimated water current's speed (m/s) for planning, 0 while the estimate is vaguer than
        :data:`~onboard.core.nav.current.CURRENT_BELIEVED_STD_MPS` or the current slower than
        :data:`~onboard.core.nav.current.CURRENT_NOISE_MPS`."""
        if not nav.current_std_mps < CURRENT_BELIEVED_STD_MPS:
            return 0.0
        speed = math.hypot(nav.current_north_mps, nav.current_east_mps)
        return speed if speed >= CURRENT_NOISE_MPS else 0.0

    def ask_plan(self, v: Vehicle, kind: str, replan: bool = False) -> None:
        """Put a plan request out: ``goal`` to the current goal, ``loiter`` round the last goal.

        A re-plan for the current (``replan``) starts where the vehicle is on the path flown (its
        projection, the path's heading), not where a drift has put it: the path is held (guidance brings
        the vehicle back onto it) and only what lies ahead changes (issue 23 item 4: a new path from the
        drifted pose moved the whole path, 4-6 m of cross-track against the first one at 0.5 m/s)."""
        n = v.last_nav
        if n is None:
            return
        cfg = v.config
        start = (n.x_m, n.y_m, n.yaw_rad)
        start_depth_m = max(n.depth_m, 0.0)
        s_proj = self.guidance_state.s_proj_m
        if replan and self.path is not None and s_proj is not None:
            on_path = self.path.sample(s_proj)
            start = (on_path.x_m, on_path.y_m, on_path.yaw_rad)
            start_depth_m = max(on_path.depth_m, 0.0)
        index = v.status.goal_index if kind == "goal" else len(v.mission.goals) - 1
        radius = cfg.mission.loiter_radius_m or 2.0 * cfg.planner.turning_radius_m
        self._plan_ids += 1
        self._plan_out = self._plan_wait = PlanRequest(
            self._plan_ids,
            kind,
            index,
            start,
            start_depth_m,
            v.mission.goals[index],
            v.mission.obstacles,
            cfg.planner,
            radius,
            v.now_s,
            cfg.mission.plan_deadline_s,
            current_mps=self.current_mps(n),
            speed_mps=cfg.guidance.speed_mps,
            replan=replan,
            planned_current_mps=self.path_current_mps,
            cross_track_bound_m=self.cross_track_bound_m,
            held_path=self.path if replan else None,
            goal_run_in_m=self.goal_run_in_m(v, index) if kind == "goal" else 0.0,
        )

    @staticmethod
    def goal_run_in_m(v: Vehicle, index: int) -> float:
        """The straight (m) goal ``index`` is approached along: the last goal's long enough for the run-in
        to slow on it (:func:`~onboard.core.plans.last_goal_run_in_m`), the others' the planner's."""
        cfg = v.config
        if index != len(v.mission.goals) - 1:
            return cfg.planner.goal_run_in_m
        mission = cfg.mission
        return last_goal_run_in_m(
            cfg.planner.goal_run_in_m,
            cfg.guidance.speed_mps,
            mission.arrival_speed_mps,
            mission.run_in_decel_mps2,
        )

    def take_plan_request(self) -> PlanRequest | None:
        """The plan asked for (once): the loop computes it with :func:`~onboard.core.plans.compute_plan`."""
        req, self._plan_out = self._plan_out, None
        return req

    def plan_done(self, v: Vehicle, request_id: int, result: Path | PlannerError) -> bool:
        """The worker's answer to request ``request_id`` (a stale one, e.g. after a HOLD, is dropped).
        True when a new path is flown from now on (the PD starts afresh on it)."""
        req = self._plan_wait
        if req is None or req.request_id != request_id:
            return False
        self._plan_wait = self._plan_out = None
        maneuver = self.active(v)
        if maneuver is None or maneuver.kind != req.kind:
            return False
        if req.kind == "goal" and req.goal_index != v.status.goal_index:
            return False
        if isinstance(result, PlannerError) and req.replan and self.path is not None:
            # the path flown now stays: it was planned for another current, not made impossible by it
            log.warning("re-plan for the current failed, the path flown stays: %s: %s", result.reason, result)
            self.path_current_mps, self.path_t_s = req.current_mps, req.t_s
            return False
        if isinstance(result, PlannerError):
            self.planner_error = f"{result.reason}: {result}"
            log.error("cannot plan %s %d: %s", req.kind, req.goal_index, self.planner_error)
            maneuver.plan_failed(self, v, self.planner_error, late=False)
            return False
        self.planner_error = ""
        self.path_current_mps, self.path_t_s = req.current_mps, req.t_s
        if req.replan:
            text = (
                f"goal {req.goal_index}: re-planned for the current now estimated, {req.current_mps:.2f} m/s "
                f"(the path flown was planned for {req.planned_current_mps:.2f} m/s)"
            )
            log.info("%s", text)
            v.note(Severity.INFO, text)
        if result.note:
            text = f"{req.kind} {req.goal_index}: {result.note}"
            log.warning("%s", text)
            v.note(Severity.WARNING, text)
        self.path, self.path_goal_index, self.path_kind = result, req.goal_index, req.kind
        # A new path starts its reference at the vehicle's speed (a re-plan or the next goal under way),
        # not from rest: the ramp then would ask a moving vehicle to brake.
        n, top = v.last_nav, v.config.guidance.speed_mps
        moving = min(max(n.u_mps, 0.0), top) if n is not None and math.isfinite(n.u_mps) else 0.0
        self.guidance_state = guidance.GuidanceState(ref_speed_mps=moving)
        log.info(
            "planned %s %d: %s, %.2f m, %d virtual goals",
            req.kind,
            req.goal_index,
            result.word,
            result.length_m,
            len(result.virtual_goals),
        )
        return True
