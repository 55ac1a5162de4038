"""The autopilot core: the pure pieces composed into one step per control tick.

Per tick, in this order: sensor cache -> navigation (Kalman filter) -> failsafes -> mission (events,
planning when a goal becomes active) -> guidance -> revised PD -> saturation (inside the controller) ->
state-dependent output (neutral, abort, hold). No clock, no bus: the loop (:mod:`onboard.app.loop`) gives the
latest-value cache of bus messages, ``now_s`` and ``dt_s`` and sends what comes back.

The composition keeps the explicit states of the pure steps (filter, guidance, controller, failsafe,
mission status, the active path); transitions are logged once, never per tick.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field, replace
from typing import Any

from onboard.core import control, guidance, nav
from onboard.core.config import CoreConfig
from onboard.core.control.actuators import NEUTRAL, ActuatorCommand, ActuatorFlag, saturate
from onboard.core.guidance.guidance import GuidanceReference
from onboard.core.mission.model import Goal, Mission
from onboard.core.mission.state import MissionEvent, MissionState, MissionStatus, Transition, transition
from onboard.core.planner.errors import PlannerError
from onboard.core.planner.path import Path
from onboard.core.planner.planner import plan
from onboard.core.safety import failsafe
from onboard.core.safety.failsafe import FailsafeFlag
from onboard.protocol import messages as m

log = logging.getLogger(__name__)

_STATE_CODE = {s: m.MissionStateCode[s.name] for s in MissionState}
_NO_FAILSAFE = FailsafeFlag(0)
# The states the step tests every tick, read once: in CPython 3.11 ``MissionState.RUNNING`` (an attribute of
# an Enum class) costs ~0.3 us, a module global ~0.02 us.
_RUNNING = MissionState.RUNNING
_COMPLETE = MissionState.COMPLETE
_ABORT = MissionState.ABORT


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
    mission: Mission = field(default_factory=lambda: Mission(()))
    status: MissionStatus = field(default_factory=MissionStatus)
    nav_state: nav.NavFilterState = field(default_factory=nav.NavFilterState.initial)
    guidance_state: guidance.GuidanceState = field(default_factory=guidance.GuidanceState)
    controller_state: control.ControllerState = field(default_factory=control.ControllerState)
    failsafe_state: failsafe.FailsafeState = field(default_factory=failsafe.FailsafeState)
    path: Path | None = None
    path_goal_index: int = -1
    planner_error: str = ""
    consecutive_overruns: int = 0
    last_nav: nav.NavState | None = None
    goals_reached: int = 0
    events: list[str] = field(default_factory=list)  # transitions since the last take_events()
    autostart_pending: bool = False
    actuator_failsafe: bool = False  # the latest PROP_STATUS / FIN_STATUS failsafe flag

    # --- commands from outside (mission file, MAVLink) ------------------------------------------
    def apply(self, event: MissionEvent, detail: str = "") -> Transition:
        """Apply a mission event; log accepted transitions once, rejected ones with the reason.

        START (and RESUME) need a valid navigation solution (the vehicle does not run blind) and an actuator
        node that is not in its latched failsafe (ARMED sends SAFE, which clears it). An accepted START
        plans afresh from the current pose; leaving ARMED cancels a pending autostart.
        """
        if event in (MissionEvent.START, MissionEvent.RESUME):
            why = ""
            if not (self.last_nav and self.last_nav.valid):
                why = "navigation not valid yet"
            elif self.actuator_failsafe:
                why = "the actuator node reports its failsafe (the SAFE command sent while ARMED clears it)"
            if why:
                reason = f"{event.value} rejected: {why}"
                log.warning("mission event %s", reason)
                return Transition(self.status, False, reason)
        goal_count = len(self.mission.goals) if event is MissionEvent.MISSION_REPLACED else None
        result = transition(self.status, event, goal_count=goal_count, detail=detail)
        if result.accepted:
            if result.status.state != self.status.state or event is not MissionEvent.GOAL_REACHED:
                log.info(
                    "mission %s -> %s (%s)", self.status.state.name, result.status.state.name, result.reason
                )
                self.events.append(f"{self.status.state.name}->{result.status.state.name}: {result.reason}")
            self.status = result.status
            if event is MissionEvent.START:
                self.path = None
                self.path_goal_index = -1
            if self.status.state is not MissionState.ARMED:
                self.autostart_pending = False
        else:
            log.warning("mission event %s rejected: %s", event.value, result.reason)
        return result

    def replace_mission(self, mission: Mission) -> Transition:
        """Replace the mission atomically (already validated); re-plan from the current pose if running."""
        mission.validate()
        old_mission, old_status = self.mission, self.status
        self.mission = mission
        result = self.apply(MissionEvent.MISSION_REPLACED)
        if not result.accepted:
            self.mission, self.status = old_mission, old_status
            return result
        self.path = None
        self.path_goal_index = -1
        return result

    def request_autostart(self) -> None:
        """Arm now and start as soon as the navigation solution is valid (``--autostart``)."""
        self.autostart_pending = self.apply(MissionEvent.ARM, "autostart").accepted

    def set_current(self, index: int) -> bool:
        """Make goal ``index`` the active goal (re-planned at the next tick when running)."""
        if not 0 <= index < len(self.mission.goals):
            log.warning(
                "set current goal %d rejected: the mission has %d goals", index, len(self.mission.goals)
            )
            return False
        self.status = replace(self.status, goal_index=index)
        self.path_goal_index = -1
        return True

    def note_overruns(self, consecutive: int) -> None:
        self.consecutive_overruns = consecutive

    def take_events(self) -> list[str]:
        out, self.events = self.events, []
        return out

    # --- one tick -------------------------------------------------------------------------------
    def step(self, cache: dict[type, Any], now_s: float, dt_s: float) -> StepOutput:
        """One tick at ``now_s`` (s) of period ``dt_s`` (s) from the latest-value cache of bus messages."""
        cfg = self.config
        nav_state, self.nav_state, _ = nav.step(nav_inputs(cache), self.nav_state, cfg.nav, now_s)
        self.last_nav = nav_state
        prop_status = cache.get(m.PropStatus)
        fin_status = cache.get(m.FinStatus)
        self.actuator_failsafe = bool(
            (prop_status is not None and prop_status.failsafe)
            or (fin_status is not None and fin_status.failsafe)
        )
        if (
            self.autostart_pending
            and nav_state.valid
            and not self.actuator_failsafe
            and self.status.state is MissionState.ARMED
        ):
            self.autostart_pending = False
            self.apply(MissionEvent.START, "autostart: navigation valid")

        fs_flags = _NO_FAILSAFE
        if self.status.active:
            result, self.failsafe_state = failsafe.check(
                nav_state, self.consecutive_overruns > 0, self.failsafe_state, cfg.failsafe
            )
            fs_flags = result.flags
            if result.abort:
                self.apply(MissionEvent.FAILSAFE, detail=result.reason)
            elif self.actuator_failsafe:
                self.apply(MissionEvent.FAILSAFE, detail="the actuator node is in its failsafe")

        reference: GuidanceReference | None = None
        command = NEUTRAL
        state = self.status.state
        if state is _RUNNING or state is _COMPLETE:
            if state is _RUNNING and (self.path is None or self.path_goal_index != self.status.goal_index):
                self._plan_active_goal(nav_state)
            state = self.status.state  # planning may HOLD
            if self.path is not None and (state is _RUNNING or state is _COMPLETE):
                complete = state is _COMPLETE
                reference, self.guidance_state, _ = guidance.step(
                    nav_state, self.path, self.guidance_state, cfg.guidance, dt_s, complete=complete
                )
                if reference.arrived and not complete:
                    self.goals_reached += 1
                    self.apply(MissionEvent.GOAL_REACHED)
                command, self.controller_state, _ = control.step(
                    nav_state, reference, self.controller_state, cfg.control, dt_s
                )
        state = self.status.state  # GOAL_REACHED may have completed the mission
        if state is _ABORT:
            command = saturate(
                failsafe.abort_command(cfg.failsafe), self.controller_state.command, cfg.control.limits, dt_s
            )
            self.controller_state = control.ControllerState(command=command)
        elif not (state is _RUNNING or state is _COMPLETE) or reference is None:
            # IDLE, ARMED, HOLD (or no path yet): propeller off, fins neutral, rate-limited.
            command = saturate(NEUTRAL, self.controller_state.command, cfg.control.limits, dt_s)
            self.controller_state = control.ControllerState(command=command)
        return StepOutput(
            command=command,
            mode=_ACTUATOR_MODE[state],
            mission_state=_STATE_CODE[state],
            status=self.status,
            nav=nav_state,
            reference=reference,
            failsafe_flags=fs_flags,
            planner_error=self.planner_error,
        )

    def _plan_active_goal(self, nav_state: nav.NavState) -> None:
        """Plan from the current pose to the active goal; on a planner error, HOLD with the reason."""
        if not 0 <= self.status.goal_index < len(self.mission.goals):
            # e.g. a mission cleared while held, then resumed: nothing to fly, keep still.
            self.path = None
            self.path_goal_index = self.status.goal_index
            self.apply(MissionEvent.HOLD, detail=f"no goal {self.status.goal_index} in the mission")
            return
        goal: Goal = self.mission.goals[self.status.goal_index]
        self.guidance_state = guidance.GuidanceState()
        self.controller_state = control.ControllerState(command=self.controller_state.command)
        try:
            self.path = plan(
                (nav_state.x_m, nav_state.y_m, nav_state.yaw_rad),
                (goal.x_m, goal.y_m, goal.yaw_rad),
                self.config.planner,
                self.mission.obstacles,
                start_depth_m=max(nav_state.depth_m, 0.0),
                goal_depth_m=goal.depth_m,
            )
            self.planner_error = ""
            self.path_goal_index = self.status.goal_index
            log.info(
                "planned goal %d: %s, %.2f m, %d virtual goals",
                self.status.goal_index,
                self.path.word,
                self.path.length_m,
                len(self.path.virtual_goals),
            )
        except PlannerError as exc:
            self.path = None
            self.planner_error = f"{exc.reason}: {exc}"
            log.error("cannot plan goal %d: %s", self.status.goal_index, self.planner_error)
            self.apply(MissionEvent.HOLD, detail=f"planner: {self.planner_error}")


def _actuator_mode(state: MissionState) -> m.ActuatorMode:
    if state is MissionState.ABORT:
        return m.ActuatorMode.ABORT
    if state is MissionState.IDLE or state is MissionState.ARMED:
        # Propeller off and fins neutral either way; SAFE also clears a latched actuator failsafe.
        return m.ActuatorMode.SAFE
    return m.ActuatorMode.ARMED


_ACTUATOR_MODE = {s: _actuator_mode(s) for s in MissionState}


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
        position=nav.PositionFix(fix.x_m, fix.y_m, fix.t_sample_s) if fix is not None else None,
        dvl=nav.DvlVelocity(dvl.u_mps, dvl.v_mps, dvl.w_mps, dvl.t_sample_s)
        if dvl is not None and dvl.valid
        else None,
        ahrs=ahrs,
        depth=nav.Depth(depth.depth_m, depth.t_sample_s) if depth is not None else None,
    )


__all__ = ["ActuatorFlag", "Autopilot", "StepOutput", "nav_inputs"]
