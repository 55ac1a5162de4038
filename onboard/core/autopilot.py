"""The autopilot core: the pure pieces composed into one step per control tick, and the one judge.

Per tick, in this order: sensor cache -> navigation (Kalman filter) -> failsafes -> mission (arrival, misses,
the end of the mission) -> guidance -> revised PD -> saturation (inside the controller) -> state-dependent
output (still, abort, hold, surface). No clock, no bus, no threads: the loop (:mod:`onboard.app.loop`) gives
the latest-value cache of bus messages, ``now_s`` and ``dt_s``, sends what comes back, runs the plans the
core asks for in a worker (:meth:`Autopilot.take_plan_request` / :meth:`Autopilot.plan_done`) and carries
commands from the links to :meth:`Autopilot.handle`.

:meth:`Autopilot.handle` is the only judge of every command from every source (see
:mod:`onboard.core.commands`): it answers a :class:`~onboard.core.commands.Verdict` with a reason. What the
operator must be told (transitions, misses, planning failures) is queued as
:class:`~onboard.core.commands.Note` (:meth:`Autopilot.take_notes`).

Truth rules kept here, in one place:

- :attr:`Autopilot.actuators_live` is True exactly when the actuators may move under the vehicle's own
  command (ARMED, RUNNING, HOLD, and COMPLETE with the ``loiter`` end action). Whenever it is False the
  propeller command is 0 rps in the same tick (no ramp-down).
- A goal is reached only when the vehicle's estimate crosses the goal line within ``[mission]
  arrival_radius_m`` of the goal, and the estimate is itself that good (its position 1-sigma no coarser
  than the radius; else HOLD: the arrival cannot be confirmed); farther off it is a miss: re-planned from
  where the vehicle is to the same goal pose (the paper's homing), up to ``max_tries`` attempts, then HOLD
  with the reason.
- A goal path planned for one water current (``[planner] current_aware``) is planned again, from where the
  vehicle is, when the estimate has moved by ``REPLAN_CURRENT_CHANGE_MPS`` (the start's estimate is a guess
  until the vehicle turns), with a note to the operator; if that plan fails the path flown stays.
- After the last goal the end action runs: ``surface`` (propeller 0 and fins neutral at once) or ``loiter``
  (circle the last goal at its depth). Nothing drives on past the goal.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field, replace
from typing import Any

from onboard.core import commands as c
from onboard.core import control, guidance, nav
from onboard.core.config import CoreConfig
from onboard.core.control.actuators import NEUTRAL, ActuatorCommand, ActuatorFlag, saturate
from onboard.core.guidance.guidance import GuidanceReference
from onboard.core.mission.model import Mission, MissionError
from onboard.core.mission.state import MissionEvent, MissionState, MissionStatus, Transition, transition
from onboard.core.mission.validate import check_limits
from onboard.core.params import BusLimits
from onboard.core.planner.errors import PlannerError
from onboard.core.planner.path import Path
from onboard.core.plans import PlanRequest, current_radius_m
from onboard.core.safety import failsafe
from onboard.core.safety.failsafe import FailsafeFlag
from onboard.protocol import messages as m

log = logging.getLogger(__name__)

_NO_FAILSAFE = FailsafeFlag(0)
# The states the step tests every tick, read once: in CPython 3.11 ``MissionState.RUNNING`` (an attribute of
# an Enum class) costs ~0.3 us, a module global ~0.02 us.
_IDLE = MissionState.IDLE
_ARMED = MissionState.ARMED
_RUNNING = MissionState.RUNNING
_HOLD = MissionState.HOLD
_COMPLETE = MissionState.COMPLETE
_ABORT = MissionState.ABORT
Severity = c.Severity


@dataclass(frozen=True)
class StepOutput:
    """One tick's result: the command the loop sends and the telemetry it records."""

    command: ActuatorCommand
    mode: m.ActuatorMode
    mission_state: m.MissionStateCode
    status: MissionStatus
    nav: nav.NavState
    reference: GuidanceReference | None
    failsafe_flags: FailsafeFlag
    planner_error: str

    @property
    def rudder_rad(self) -> float:
        return self.command.rudder_rad

    @property
    def stern_port_rad(self) -> float:
        return self.command.stern_port_rad

    @property
    def stern_starboard_rad(self) -> float:
        return self.command.stern_starboard_rad

    @property
    def propeller_rps(self) -> float:
        return self.command.propeller_rps

    def telemetry_row(self) -> dict[str, float | int | str]:
        """The tick's telemetry as one flat row (built on demand: the loop keeps the StepOutput)."""
        n, r, c = self.nav, self.reference, self.command
        row: dict[str, float | int | str] = {
            "state": self.status.state.name,
            "goal_index": self.status.goal_index,
            "x_m": n.x_m,
            "y_m": n.y_m,
            "depth_m": n.depth_m,
            "roll_rad": n.roll_rad,
            "pitch_rad": n.pitch_rad,
            "yaw_rad": n.yaw_rad,
            "u_mps": n.u_mps,
            "nav_conditions": int(n.conditions),
            "rudder_rad": c.rudder_rad,
            "stern_port_rad": c.stern_port_rad,
            "stern_starboard_rad": c.stern_starboard_rad,
            "propeller_rps": c.propeller_rps,
            "actuator_flags": int(c.flags),
            "failsafe_flags": int(self.failsafe_flags),
        }
        if r is None:
            row.update(_NO_REFERENCE_ROW)
        else:
            row["ref_x_m"] = r.x_m
            row["ref_y_m"] = r.y_m
            row["ref_depth_m"] = r.depth_m
            row["ref_yaw_rad"] = r.yaw_rad
            row["along_track_m"] = r.along_track_m
            row["cross_track_m"] = r.cross_track_m
            row["e_along_m"] = r.e_along_m
            row["e_cross_m"] = r.e_cross_m
            row["e_depth_m"] = r.e_depth_m
            row["e_yaw_rad"] = r.e_yaw_rad
        return row


#: The reference columns of a tick without a guidance reference (same keys and order as with one).
_NO_REFERENCE_ROW: dict[str, float | int | str] = dict.fromkeys(
    (
        "ref_x_m",
        "ref_y_m",
        "ref_depth_m",
        "ref_yaw_rad",
        "along_track_m",
        "cross_track_m",
        "e_along_m",
        "e_cross_m",
        "e_depth_m",
        "e_yaw_rad",
    ),
    math.nan,
)


@dataclass
class Autopilot:
    """The onboard core driven by :class:`onboard.app.loop.ControlLoop` (one :meth:`step` per tick)."""

    config: CoreConfig
    bus_limits: BusLimits | None = None  # the DBC's command ranges (the app reads them); None: no SetParam
    mission: Mission = field(default_factory=lambda: Mission(()))
    status: MissionStatus = field(default_factory=MissionStatus)
    nav_state: nav.NavFilterState = field(default_factory=nav.NavFilterState.initial)
    guidance_state: guidance.GuidanceState = field(default_factory=guidance.GuidanceState)
    controller_state: control.ControllerState = field(default_factory=control.ControllerState)
    failsafe_state: failsafe.FailsafeState = field(default_factory=failsafe.FailsafeState)
    path: Path | None = None
    path_goal_index: int = -1
    path_kind: str = ""  # "goal" or "loiter": what ``path`` flies
    planner_error: str = ""
    loop_late_s: float = 0.0  # how long the loop has been behind its schedule (s), from note_loop_late
    last_nav: nav.NavState | None = None
    goals_reached: int = 0
    attempt: int = 1  # attempts at the current goal (1 = the first)
    notes: list[c.Note] = field(default_factory=list)  # for the operator, since the last take_notes()
    autostart_pending: bool = False
    actuator_failsafe: bool = False  # the latest PROP_STATUS / FIN_STATUS failsafe flag
    encode_fault: str = ""  # a command frame that could not be encoded (set by the loop)
    bus_lost: str = ""  # why the CAN bus is lost ("" while it is up): BusLost / BusBack
    _bus_abort: MissionStatus | None = None  # the status the bus loss aborted into (BusBack undoes only it)
    _plan_out: PlanRequest | None = None  # asked for, not yet taken by the loop
    _plan_wait: PlanRequest | None = None  # taken (or asked for): the result is awaited
    _plan_ids: int = 0
    _now_s: float = 0.0
    _path_current_mps: float = 0.0  # the current (m/s) the flown path was planned for
    _path_t_s: float = -math.inf  # when the flown path was asked for (the core's time, s)

    # --- what the links read --------------------------------------------------------------------
    @property
    def actuators_live(self) -> bool:
        """True exactly when the actuators may move under the vehicle's own command."""
        state = self.status.state
        if state is _COMPLETE:  # loitering, unless the loiter fell back to surfacing
            return self.config.mission.end_action == "loiter" and self.path_kind != "surface"
        return state is _ARMED or state is _RUNNING or state is _HOLD

    @property
    def ready(self) -> tuple[bool, str]:
        """(True, "") when a START would pass the vehicle's own checks, else (False, why)."""
        if self.bus_lost:
            return False, f"CAN bus lost ({self.bus_lost})"
        if not (self.last_nav and self.last_nav.valid):
            return False, "navigation not valid yet"
        if self.actuator_failsafe:
            return (
                False,
                "the actuator node reports its failsafe (the SAFE command sent while ARMED clears it)",
            )
        return True, ""

    def take_notes(self) -> list[c.Note]:
        out, self.notes = self.notes, []
        return out

    def _note(self, severity: c.Severity, text: str) -> None:
        self.notes.append(c.Note(severity, text))

    # --- the one judge ----------------------------------------------------------------------------
    def handle(self, command: c.Command) -> c.Verdict:
        """Judge and carry out one command; log it; return the verdict with its reason."""
        verdict = self._judge(command)
        src = getattr(command, "source", "") or "onboard"
        name = type(command).__name__
        if verdict.accepted:
            log.info("%s from %s: %s", name, src, verdict.reason)
        else:
            log.warning("%s from %s %s: %s", name, src, verdict.outcome.value, verdict.reason)
        return verdict

    def _judge(self, command: c.Command) -> c.Verdict:
        state = self.status.state
        src = getattr(command, "source", "")
        if isinstance(command, c.Arm):
            if state in (_ARMED, _RUNNING, _HOLD):
                return c.accepted(f"already armed ({state.name})")
            if state is _ABORT:
                return c.denied("in ABORT: disarm first to acknowledge the abort")
            if self.bus_lost:
                return c.not_now(f"CAN bus lost ({self.bus_lost}): the actuators cannot be reached")
            return self._event(MissionEvent.ARM, src)
        if isinstance(command, c.Disarm):
            if state is _IDLE:
                return c.accepted("already disarmed")
            if state is _RUNNING and not command.forced:
                return c.denied("RUNNING: hold (or force the disarm) first")
            event = MissionEvent.DISARM_FORCED if command.forced else MissionEvent.DISARM
            return self._event(event, src)
        if isinstance(command, c.Start):
            return self._start(command.first_goal, src)
        if isinstance(command, c.Hold):
            if state is _HOLD:
                return c.accepted("already holding")
            if state is not _RUNNING:
                return c.denied(f"hold: not running ({state.name})")
            return self._event(MissionEvent.HOLD, src)
        if isinstance(command, c.Resume):
            if state is _RUNNING:
                return c.accepted("already running")
            if state is not _HOLD:
                return c.denied(f"resume: not holding ({state.name})")
            return self._start(None, src)
        if isinstance(command, c.Abort):
            if state is _ABORT:
                return c.accepted("already in ABORT")
            return self._event(MissionEvent.ABORT, f"{command.reason} ({src})" if src else command.reason)
        if isinstance(command, c.SetCurrent):
            return self._set_current(command.index)
        if isinstance(command, c.SetMode):
            if command.mode == "mission":
                return self._start(None, src)
            if command.mode == "loiter":
                return self._judge(c.Hold(src))
            if command.mode == "surface":
                return self._judge(c.Abort("mode surface", src))
            if state in (_RUNNING, _HOLD):
                return c.denied(f"{state.name}: hold or abort to leave the mission")
            if state is _ABORT:
                return c.denied("ABORT: disarm to acknowledge it")
            if self.actuators_live:  # COMPLETE, loitering: the propeller turns, "ready" would be a lie
                return c.denied(f"{state.name} (loitering): disarm to stop")
            return c.accepted(f"ready ({state.name}): nothing to change")
        if isinstance(command, c.ReplaceMission):
            return self._replace(command.mission, command.goals_changed, src)
        if isinstance(command, c.SetParam):
            return self._set_param(command.name, command.value)
        if isinstance(command, c.LinkLost):
            if command.action == "hold" and state is _RUNNING:
                return self._event(MissionEvent.HOLD, "ground-station link lost", severity=c.Severity.WARNING)
            if command.action == "surface" and self.status.active:
                return self._event(MissionEvent.ABORT, "ground-station link lost: surface")
            return c.accepted(f"ground-station link lost: {command.action} ({state.name})")
        if isinstance(command, c.BusLost):
            return self._bus_lost(command.reason)
        if isinstance(command, c.BusBack):
            return self._bus_back()
        return c.Verdict(c.Outcome.UNSUPPORTED, f"unknown command {type(command).__name__}")

    def _event(
        self,
        event: MissionEvent,
        detail: str = "",
        goal_index: int | None = None,
        severity: c.Severity | None = None,
    ) -> c.Verdict:
        result = self.apply(event, detail, goal_index=goal_index, severity=severity)
        return c.accepted(result.reason) if result.accepted else c.denied(result.reason)

    def _bus_lost(self, reason: str) -> c.Verdict:
        self.bus_lost = reason or "no reason given"
        what = f"CAN bus lost ({self.bus_lost})"
        state = self.status.state
        if state is _ABORT or not (self.actuators_live or self.status.active):
            self._note(c.Severity.CRITICAL, f"{what}: {state.name}, reconnecting")
            return c.accepted(f"{what} ({state.name})")
        verdict = self._event(MissionEvent.FAILSAFE, f"{what}, reconnecting")
        if verdict.accepted:
            self._bus_abort = self.status
        return verdict

    def _bus_back(self) -> c.Verdict:
        if not self.bus_lost:
            return c.accepted("CAN bus up")
        was, self.bus_lost = self.bus_lost, ""
        aborted, self._bus_abort = self._bus_abort, None
        if aborted is not None and self.status is aborted:  # nothing happened since the loss's ABORT
            return self._event(
                MissionEvent.DISARM,
                "CAN bus back: disarmed, the mission kept (arm and start to fly it again)",
                severity=c.Severity.NOTICE,
            )
        self._note(c.Severity.NOTICE, f"CAN bus back (it was lost: {was})")
        return c.accepted(f"CAN bus back ({self.status.state.name})")

    def note_bus(self, lost_reason: str) -> None:
        """The loop's word on the CAN bus ("": up, else why it is lost), judged like every other command."""
        if lost_reason != self.bus_lost:
            self.handle(c.BusLost(lost_reason) if lost_reason else c.BusBack())

    def _start(self, first_goal: int | None, src: str) -> c.Verdict:
        state = self.status.state
        n = len(self.mission.goals)
        if n == 0:
            return c.denied("the mission has no goals: upload one first")
        if first_goal is not None and not 0 <= first_goal < n:
            return c.denied(f"no goal {first_goal}: the mission has {n} goals")
        if state is _RUNNING:
            if first_goal is not None and first_goal != self.status.goal_index:
                return self._set_current(first_goal)
            return c.accepted("already running")
        if state is _IDLE:
            return c.denied("disarmed: arm first")
        if state is _COMPLETE:
            return c.denied("the mission is complete: arm to fly it again")
        if state is _ABORT:
            return c.denied("in ABORT: disarm first to acknowledge the abort")
        index = self.status.goal_index if first_goal is None else first_goal
        if not 0 <= index < n:
            return c.denied(f"no goal {index} to fly: the mission has {n} goals (set the current goal)")
        ok, why = self.ready
        if not ok:
            return c.not_now(why)
        event = MissionEvent.RESUME if state is _HOLD and first_goal is None else MissionEvent.START
        return self._event(event, src, goal_index=index)

    def _set_current(self, index: int) -> c.Verdict:
        n = len(self.mission.goals)
        if not 0 <= index < n:
            return c.denied(f"no goal {index}: the mission has {n} goals")
        if self.status.state in (_COMPLETE, _ABORT):
            return c.denied(f"{self.status.state.name}: the current goal cannot change now")
        self.status = replace(self.status, goal_index=index)
        self.attempt = 1
        self._drop_path()
        return c.accepted(f"current goal {index}")

    def _replace(self, mission: Mission, goals_changed: bool, src: str) -> c.Verdict:
        try:
            mission.validate()
        except MissionError as exc:
            return c.denied(f"mission refused: {exc}")
        broken = check_limits(mission, self.config).first  # the configuration may have changed since
        if broken is not None:
            return c.denied(f"mission refused: {broken}")
        if not goals_changed:
            self.mission = mission
            # a plan in flight or in use was made round the old obstacles: ask again (the old path is flown
            # until the new one arrives; the answer to the old request is dropped)
            if self.status.state is _RUNNING:
                self._ask_plan("goal")
            elif self.status.state is _COMPLETE and self.path_kind == "loiter":
                self._ask_plan("loiter")
            return c.accepted(f"fence replaced ({len(mission.obstacles)} obstacles)")
        old = self.mission
        self.mission = mission
        result = self.apply(
            MissionEvent.MISSION_REPLACED,
            src,
            goal_count=len(mission.goals),
        )
        if not result.accepted:
            self.mission = old
            return c.denied(result.reason)
        self.goals_reached = 0
        self.attempt = 1
        self._drop_path()
        return c.accepted(result.reason)

    def _set_param(self, name: str, value: float) -> c.Verdict:
        from onboard.core import params

        try:
            in_force = params.param_value(self.config, name)
        except params.ParamError as exc:
            return c.denied(exc.reason)
        if self.bus_limits is None:
            return c.denied(f"{name}: parameters cannot be set (the bus limits are unknown)", value=in_force)
        try:
            config = params.apply_param(self.config, name, value, self.bus_limits)
        except params.ParamError as exc:
            return c.denied(exc.reason, value=in_force)
        broken = check_limits(self.mission, config).first
        if broken is not None:  # e.g. a failsafe depth above a goal of the mission in force
            return c.denied(
                f"{name} = {value:g} refused: the mission would break it ({broken})", value=in_force
            )
        self.config = config
        return c.accepted(f"{name} = {value:g}", value=params.param_value(self.config, name))

    # --- mission events (the state machine applied; kept for the tests and the step) ---------------
    def apply(
        self,
        event: MissionEvent,
        detail: str = "",
        *,
        goal_count: int | None = None,
        goal_index: int | None = None,
        severity: c.Severity | None = None,
    ) -> Transition:
        """Apply a mission event to the state machine; note accepted transitions once (``severity``: of
        the note; default CRITICAL for ABORT, else INFO)."""
        if event in (MissionEvent.START, MissionEvent.RESUME):
            ok, why = self.ready
            if not ok:
                return Transition(self.status, False, f"{event.value} rejected: {why}")
        if event is MissionEvent.MISSION_REPLACED and goal_count is None:
            goal_count = len(self.mission.goals)
        result = transition(
            self.status,
            event,
            goal_count=goal_count,
            goal_index=goal_index,
            detail=detail,
            complete_armed=self.config.mission.end_action == "loiter",
        )
        if not result.accepted:
            log.debug("mission event %s rejected: %s", event.value, result.reason)
            return result
        before = self.status.state
        self.status = result.status
        after = result.status.state
        if after is not before or event is not MissionEvent.GOAL_REACHED:
            log.info("mission %s -> %s (%s)", before.name, after.name, result.reason)
        if severity is None:
            severity = c.Severity.CRITICAL if after is _ABORT else c.Severity.INFO
        self._note(severity, result.reason)
        if event in (MissionEvent.START, MissionEvent.RESUME):
            self.attempt = 1
            self._drop_path()
            self._ask_plan("goal")  # afresh, from where the vehicle is
        if after is not _RUNNING and after is not _COMPLETE:
            self._drop_path()
        if after is not _ARMED:
            self.autostart_pending = False
        return result

    def replace_mission(self, mission: Mission) -> c.Verdict:
        """A new mission (goals and fence) from a trusted door (tests, start-up): :meth:`handle`."""
        return self.handle(c.ReplaceMission(mission, True, "start-up"))

    def restore_progress(self, goal_index: int) -> bool:
        """At boot: make the persisted progress the current goal (IDLE only; START continues from it)."""
        if self.status.state is not _IDLE or not 0 <= goal_index < len(self.mission.goals):
            return False
        self.status = replace(
            self.status, goal_index=goal_index, reason=f"progress restored: goal {goal_index}"
        )
        return True

    def request_autostart(self) -> None:
        """Arm now and start as soon as the navigation solution is valid (``--autostart``)."""
        self.autostart_pending = self.handle(c.Arm("autostart")).accepted

    def before_step(self) -> None:
        """The core's own command sources, judged like every other, before the step (and before the loop
        hands out the plans, so a START's plan is flown by this step in lock-step): ``--autostart`` sends
        its START once the navigation solution (of the last step) is valid."""
        if self.autostart_pending and self.status.state is _ARMED and self.ready[0]:
            self.autostart_pending = False
            self.handle(c.Start(None, "autostart: navigation valid"))

    def note_loop_late(self, late_s: float) -> None:
        """How long the loop has been behind its schedule (s, 0 = on time): the next step's failsafe input."""
        self.loop_late_s = late_s

    def note_encode_fault(self, message: str, reason: str) -> None:
        """The loop could not encode a command frame: a fault (an ABORT at the next tick when moving)."""
        self.encode_fault = f"command not encodable: {message}: {reason}"

    # --- planning off the control thread ------------------------------------------------------------
    def take_plan_request(self) -> PlanRequest | None:
        """The plan the core asks for (once): the loop computes it with :func:`compute_plan`."""
        req, self._plan_out = self._plan_out, None
        return req

    @property
    def plan_pending(self) -> bool:
        return self._plan_wait is not None

    def plan_done(self, request_id: int, result: Path | PlannerError) -> None:
        """The worker's answer to request ``request_id`` (a stale one, e.g. after a HOLD, is dropped)."""
        req = self._plan_wait
        if req is None or req.request_id != request_id:
            return
        self._plan_wait = None
        self._plan_out = None
        state = self.status.state
        wanted = (req.kind == "goal" and state is _RUNNING and req.goal_index == self.status.goal_index) or (
            req.kind == "loiter" and state is _COMPLETE
        )
        if not wanted:
            return
        if isinstance(result, PlannerError) and req.replan and self.path is not None:
            # the path flown now stays: it was planned for another current, not made impossible by it
            log.warning("re-plan for the current failed, the path flown stays: %s: %s", result.reason, result)
            self._path_current_mps, self._path_t_s = req.current_mps, req.t_s
            return
        if isinstance(result, PlannerError):
            self.planner_error = f"{result.reason}: {result}"
            log.error("cannot plan %s %d: %s", req.kind, req.goal_index, self.planner_error)
            if req.kind == "loiter":
                text = f"loiter not possible ({self.planner_error}): surfacing"
                log.warning("%s", text)
                self._note(c.Severity.WARNING, text)
                self.path, self.path_kind = None, "surface"
            else:
                self.apply(
                    MissionEvent.HOLD,
                    f"cannot plan goal {req.goal_index}: {self.planner_error}",
                    severity=c.Severity.WARNING,
                )
            return
        self.planner_error = ""
        self._path_current_mps, self._path_t_s = req.current_mps, req.t_s
        if req.replan:
            text = (
                f"goal {req.goal_index}: re-planned for the current now estimated, {req.current_mps:.2f} m/s "
                f"(the path flown was planned for {req.planned_current_mps:.2f} m/s)"
            )
            log.info("%s", text)
            self._note(c.Severity.INFO, text)
        if result.note:
            text = f"{req.kind} {req.goal_index}: {result.note}"
            log.warning("%s", text)
            self._note(c.Severity.WARNING, text)
        self.path, self.path_goal_index, self.path_kind = result, req.goal_index, req.kind
        # A new path starts its reference at the vehicle's speed (a re-plan or the next goal under way),
        # not from rest: the ramp then would ask a moving vehicle to brake.
        n, top = self.last_nav, self.config.guidance.speed_mps
        moving = min(max(n.u_mps, 0.0), top) if n is not None and math.isfinite(n.u_mps) else 0.0
        self.guidance_state = guidance.GuidanceState(ref_speed_mps=moving)
        self.controller_state = control.ControllerState(command=self.controller_state.command)
        log.info(
            "planned %s %d: %s, %.2f m, %d virtual goals",
            req.kind,
            req.goal_index,
            result.word,
            result.length_m,
            len(result.virtual_goals),
        )

    def _drop_path(self) -> None:
        self.path, self.path_goal_index, self.path_kind = None, -1, ""
        self._plan_out = self._plan_wait = None

    def _ask_plan(self, kind: str, replan: bool = False) -> None:
        n = self.last_nav
        if n is None:
            return
        index = self.status.goal_index if kind == "goal" else len(self.mission.goals) - 1
        radius = self.config.mission.loiter_radius_m or 2.0 * self.config.planner.turning_radius_m
        self._plan_ids += 1
        req = PlanRequest(
            self._plan_ids,
            kind,
            index,
            (n.x_m, n.y_m, n.yaw_rad),
            max(n.depth_m, 0.0),
            self.mission.goals[index],
            self.mission.obstacles,
            self.config.planner,
            radius,
            self._now_s,
            self.config.mission.plan_deadline_s,
            current_mps=_current_mps(n),
            speed_mps=self.config.guidance.speed_mps,
            replan=replan,
            planned_current_mps=self._path_current_mps,
        )
        self._plan_out = self._plan_wait = req

    # --- one tick ---------------------------------------------------------------------------------
    def step(self, cache: dict[type, Any], now_s: float, dt_s: float) -> StepOutput:
        """One tick at ``now_s`` (s) of period ``dt_s`` (s) from the latest-value cache of bus messages."""
        cfg = self.config
        self._now_s = now_s
        nav_state, self.nav_state, _ = nav.step(nav_inputs(cache), self.nav_state, cfg.nav, now_s)
        self.last_nav = nav_state
        prop_status = cache.get(m.PropStatus)
        fin_status = cache.get(m.FinStatus)
        self.actuator_failsafe = bool(
            (prop_status is not None and prop_status.failsafe)
            or (fin_status is not None and fin_status.failsafe)
        )

        fs_flags = _NO_FAILSAFE
        if self.encode_fault:
            fault, self.encode_fault = self.encode_fault, ""
            if self.status.active or self.status.state is _ARMED:
                self.apply(MissionEvent.FAILSAFE, detail=fault)
            else:
                self._note(c.Severity.ERROR, fault)
        if self.status.active:
            result, self.failsafe_state = failsafe.check(
                nav_state, self.loop_late_s, self.failsafe_state, cfg.failsafe
            )
            fs_flags = result.flags
            if result.abort:
                self.apply(MissionEvent.FAILSAFE, detail=result.reason)
            elif self.actuator_failsafe:
                self.apply(MissionEvent.FAILSAFE, detail="the actuator node is in its failsafe")

        req = self._plan_wait
        if req is not None and now_s - req.t_s > cfg.mission.plan_deadline_s:
            self._plan_wait = self._plan_out = None
            deadline = cfg.mission.plan_deadline_s
            why = f"planning {req.kind} {req.goal_index} missed its deadline ({deadline:g} s)"
            self.planner_error = why
            if req.kind == "goal" and self.status.state is _RUNNING:
                self.apply(MissionEvent.HOLD, why, severity=c.Severity.WARNING)
            elif req.kind == "loiter" and self.status.state is _COMPLETE:
                log.warning("%s: surfacing", why)
                self._note(c.Severity.WARNING, f"{why}: surfacing")
                self.path, self.path_kind = None, "surface"

        reference: GuidanceReference | None = None
        command = NEUTRAL
        state = self.status.state
        if state is _RUNNING:
            if (
                self.path is None
                or self.path_goal_index != self.status.goal_index
                or self.path_kind != "goal"
            ):
                if self._plan_wait is None or self._plan_wait.goal_index != self.status.goal_index:
                    self._ask_plan("goal")
            elif self.path is not None:
                reference, self.guidance_state, _ = guidance.step(
                    nav_state, self.path, self.guidance_state, cfg.guidance, dt_s
                )
                if reference.arrived:
                    self._arrived(nav_state)
                if self.status.state is _RUNNING and self.path is not None:
                    command, self.controller_state, _ = control.step(
                        nav_state, reference, self.controller_state, cfg.control, dt_s
                    )
                    if self._current_changed(nav_state):
                        self._ask_plan("goal", replan=True)
                else:
                    reference = None
        elif state is _COMPLETE and cfg.mission.end_action == "loiter" and self.path_kind != "surface":
            if self.path is None or self.path_kind != "loiter":
                if self._plan_wait is None:
                    self._ask_plan("loiter")
            else:
                reference, self.guidance_state, _ = guidance.step(
                    nav_state, self.path, self.guidance_state, cfg.guidance, dt_s
                )
                if reference.arrived:  # after all the laps of the loiter path: round again
                    self._ask_plan("loiter")
                command, self.controller_state, _ = control.step(
                    nav_state, reference, self.controller_state, cfg.control, dt_s
                )
        state = self.status.state  # arrival may have completed the mission or held it
        live = self.actuators_live
        if state is _ABORT:
            command = saturate(
                failsafe.abort_command(cfg.failsafe), self.controller_state.command, cfg.control.limits, dt_s
            )
            command = _propeller_off(command)
            self.controller_state = control.ControllerState(command=command)
        elif state is _COMPLETE and not (live and reference is not None):
            command = NEUTRAL  # surface: propeller 0 and fins neutral at once
            self.controller_state = control.ControllerState(command=command)
        elif reference is None:
            # IDLE, ARMED, HOLD, or RUNNING while the plan is computed: fins neutral, propeller off
            command = saturate(NEUTRAL, self.controller_state.command, cfg.control.limits, dt_s)
            if not live:
                command = _propeller_off(command)
            self.controller_state = control.ControllerState(command=command)
        mode = (
            m.ActuatorMode.ABORT
            if state is _ABORT
            else (m.ActuatorMode.ARMED if live and state is not _ARMED else m.ActuatorMode.SAFE)
        )
        return StepOutput(
            command=command,
            mode=mode,
            mission_state=state,
            status=self.status,
            nav=nav_state,
            reference=reference,
            failsafe_flags=fs_flags,
            planner_error=self.planner_error,
        )

    def _current_changed(self, nav_state: nav.NavState) -> bool:
        """True when the flown goal path should be planned again for the current now estimated: the
        planner widens turns for a current (``current_aware``), the estimate has moved by
        :data:`REPLAN_CURRENT_CHANGE_MPS` since the path was asked for (at least :data:`REPLAN_MIN_INTERVAL_S`
        ago), and the goal is far enough for a new path to differ (twice the widest turn plus the run-in)."""
        planner = self.config.planner
        if not planner.current_aware or self._plan_wait is not None:
            return False
        if self._now_s - self._path_t_s < REPLAN_MIN_INTERVAL_S:
            return False
        now_mps = _current_mps(nav_state)
        if abs(now_mps - self._path_current_mps) < REPLAN_CURRENT_CHANGE_MPS:
            return False
        goal = self.mission.goals[self.status.goal_index]
        radius_m = current_radius_m(planner.turning_radius_m, self.config.guidance.speed_mps, now_mps)
        far_m = 2.0 * radius_m + planner.goal_run_in_m
        return math.hypot(goal.x_m - nav_state.x_m, goal.y_m - nav_state.y_m) > far_m

    def _arrived(self, nav_state: nav.NavState) -> None:
        """The estimate crossed the goal line: reached within the arrival radius, else a miss."""
        index = self.status.goal_index
        goal = self.mission.goals[index]
        miss_m = math.hypot(goal.x_m - nav_state.x_m, goal.y_m - nav_state.y_m)
        radius = self.config.mission.arrival_radius_m
        std_m = nav_state.position_std_m
        if not std_m <= radius:  # the estimate itself is less certain than the precision to claim
            self.apply(
                MissionEvent.HOLD,
                f"goal {index} cannot be confirmed: the position is known to {std_m:.1f} m (1 sigma), "
                f"coarser than the arrival radius {radius:g} m",
                severity=c.Severity.WARNING,
            )
            return
        if miss_m <= radius:
            self.goals_reached += 1
            self.attempt = 1
            self.apply(MissionEvent.GOAL_REACHED, f"{miss_m:.2f} m from it")
            if self.status.state is _RUNNING:
                self._drop_path()
                self._ask_plan("goal")  # the next goal, from here
            else:  # COMPLETE: the end action starts now
                self.path, self.path_goal_index, self.path_kind = None, -1, ""
            return
        tries = self.config.mission.max_tries
        if self.attempt < tries:
            self.attempt += 1
            text = (
                f"goal {index} missed by {miss_m:.2f} m (arrival radius {radius:g} m): "
                f"re-planning, try {self.attempt} of {tries}"
            )
            log.warning("%s", text)
            self._note(c.Severity.WARNING, text)
            self._drop_path()
            self._ask_plan("goal")
            return
        self.apply(
            MissionEvent.HOLD,
            f"goal {index} missed by {miss_m:.2f} m after {tries} tries",
            severity=c.Severity.WARNING,
        )


def _propeller_off(command: ActuatorCommand) -> ActuatorCommand:
    """The same fin command with the propeller at 0 rps at once (the actuators are not live)."""
    if command.propeller_rps == 0.0:
        return command
    return ActuatorCommand(
        command.rudder_rad, command.stern_port_rad, command.stern_starboard_rad, 0.0, command.flags
    )


def nav_inputs(cache: dict[type, Any]) -> nav.NavInputs:
    """Convert the latest bus messages into navigation inputs (the unit conventions are the same)."""
    att: m.AhrsAttitude | None = cache.get(m.AhrsAttitude)
    rates: m.AhrsRates | None = cache.get(m.AhrsRates)
    depth: m.DepthMeas | None = cache.get(m.DepthMeas)
    dvl: m.DvlVelocity | None = cache.get(m.DvlVelocity)
    fix: m.PositionFix | None = cache.get(m.PositionFix)
    ahrs = None
    if att is not None and rates is not None:
        ahrs = nav.Ahrs(
            att.roll_rad,
            att.pitch_rad,
            att.yaw_rad,
            rates.p_radps,
            rates.q_radps,
            rates.r_radps,
            min(att.t_sample_s, rates.t_sample_s),
        )
    return nav.NavInputs(
        position=nav.PositionFix(fix.x_m, fix.y_m, fix.t_sample_s, fix.std_m) if fix is not None else None,
        dvl=nav.DvlVelocity(dvl.u_mps, dvl.v_mps, dvl.w_mps, dvl.t_sample_s)
        if dvl is not None and dvl.valid
        else None,
        ahrs=ahrs,
        depth=nav.Depth(depth.depth_m, depth.t_sample_s) if depth is not None else None,
    )


#: The current estimate's 1-sigma (m/s) below which planning counts it (``[planner] current_aware``).
PLAN_CURRENT_STD_MPS = 0.2
#: A goal path is planned again when the current estimate has moved this much (m/s) since it was asked for
#: (the start's estimate is a guess until the vehicle has turned: along its heading only current + water
#: speed is seen), and not more often than every REPLAN_MIN_INTERVAL_S (s).
REPLAN_CURRENT_CHANGE_MPS = 0.1
REPLAN_MIN_INTERVAL_S = 5.0

#: Currents slower than this (m/s) are planned as still water (the estimate's noise is not a current).
PLAN_CURRENT_MIN_MPS = 0.05


def _current_mps(nav_state: nav.NavState) -> float:
    """The estimated water current's speed (m/s) for planning, 0 while the estimate is vaguer than
    :data:`PLAN_CURRENT_STD_MPS` or the current slower than :data:`PLAN_CURRENT_MIN_MPS`."""
    if not nav_state.current_std_mps < PLAN_CURRENT_STD_MPS:
        return 0.0
    speed = math.hypot(nav_state.current_north_mps, nav_state.current_east_mps)
    return speed if speed >= PLAN_CURRENT_MIN_MPS else 0.0


__all__ = ["ActuatorFlag", "Autopilot", "StepOutput", "nav_inputs"]
