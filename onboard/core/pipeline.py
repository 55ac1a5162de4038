"""The tick pipeline: one control tick, stage by stage, into one :class:`~onboard.core.record.TickRecord`.

nav -> failsafes (and the fault detectors, :mod:`onboard.core.safety.diagnosis`) -> executive (the active
maneuver, with guidance on its path) -> PD -> saturation and the state's output. :meth:`Pipeline.tick`
runs them in that order; each stage is a pure step (``step(inputs,
state, params, dt_s) -> (output, new_state, debug)``) whose memory this object keeps, and whose output and
debug go into the tick's record. No clock, no bus, no threads: the caller gives the latest-value cache of bus
messages, ``now_s`` and ``dt_s`` (:meth:`onboard.core.autopilot.Autopilot.step`). Events a stage raises (a
failsafe, an arrival) go to the one place transitions happen, :func:`onboard.core.commander.apply`.

Truth rule kept here: whenever the actuators are not live (:func:`onboard.core.mission.state.actuators_live`)
the propeller command is 0 rps in the same tick (no ramp-down); after the last goal the end action runs
(``surface``: the stop brakes, propeller in reverse and stern planes nose up, until the vehicle is still,
then propeller 0 and fins neutral; ``loiter``: the circle), nothing drives on past the goal; HOLD brakes
the same way (:mod:`onboard.core.executive.surface`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from onboard.core import commands as c
from onboard.core import control, nav
from onboard.core.bus_inputs import actuator_failsafe, actuator_feedback, nav_inputs
from onboard.core.control.actuators import NEUTRAL, ActuatorCommand, saturate
from onboard.core.control.pd import ControlDebug
from onboard.core.executive.surface import run_in_rps
from onboard.core.guidance.guidance import GuidanceDebug, GuidanceReference
from onboard.core.mission.state import MissionEvent, MissionState
from onboard.core.record import TickRecord
from onboard.core.safety import diagnosis, failsafe
from onboard.core.safety.failsafe import FailsafeFlag
from onboard.core.vehicle import Core
from onboard.protocol import messages as m


@dataclass
class Pipeline:
    """The stages' memories between ticks: the navigation filter, the failsafes, the PD."""

    nav_state: nav.NavFilterState = field(default_factory=nav.NavFilterState.initial)
    failsafe_state: failsafe.FailsafeState = field(default_factory=failsafe.FailsafeState)
    controller_state: control.ControllerState = field(default_factory=control.ControllerState)
    diagnosis_state: diagnosis.DiagnosisState = field(default_factory=diagnosis.DiagnosisState)
    _state_before: MissionState = MissionState.IDLE  # the state at the previous tick (a START restarts
    # the mission's faults)

    def new_path(self) -> None:
        """A new path is flown: the PD's error memory starts afresh (the command it is at stays)."""
        self.controller_state = control.ControllerState(command=self.controller_state.command)

    def tick(self, ap: Core, cache: Mapping[type, Any], now_s: float, dt_s: float) -> TickRecord:
        """One tick at ``now_s`` (s) of period ``dt_s`` (s) from the latest-value cache of bus messages."""
        cfg = ap.config
        ap.now_s = now_s
        # 1. navigation
        inputs = nav_inputs(cache)
        nav_state, self.nav_state, nav_debug = nav.step(inputs, self.nav_state, cfg.nav, now_s)
        ap.last_nav = nav_state
        ap.actuator_failsafe = actuator_failsafe(cache)
        # 2. failsafes, then the faults the vehicle names (each with its reaction)
        fs_flags = self._failsafes(ap, nav_state)
        faults, measured = self._diagnose(ap, cache, inputs.position, nav_debug, now_s, dt_s)
        # 3. the executive: the active maneuver, guidance on its path
        leg = ap.executive.step(ap, nav_state, dt_s)
        # 4. PD (saturated inside)
        reference: GuidanceReference | None = None
        guidance_debug: GuidanceDebug | None = None
        control_debug: ControlDebug | None = None
        command = NEUTRAL
        if leg is not None:
            reference, guidance_debug = leg.reference, leg.debug
            previous_rps = self.controller_state.command.propeller_rps
            command, self.controller_state, control_debug = control.step(
                nav_state, reference, self.controller_state, cfg.control, dt_s
            )
            # the run-in to the last goal (its speed limit binding): faster than that, the propeller reverses
            braking_rps = (
                run_in_rps(nav_state, reference, cfg, previous_rps, dt_s) if leg.debug.run_in else None
            )
            if braking_rps is not None:
                command = dataclasses.replace(command, propeller_rps=braking_rps)
                self.controller_state = dataclasses.replace(self.controller_state, command=command)
        # 5. the state's output
        state = ap.status.state  # arrival may have completed the mission or held it
        stop = None  # COMPLETE (surface) and HOLD: the stop brakes first (the executive's Stop)
        if reference is None and state in (MissionState.COMPLETE, MissionState.HOLD):
            stop = ap.executive.stop.command(nav_state, cfg, self.controller_state.command, dt_s)
        live = ap.actuators_live
        if state is MissionState.ABORT:
            command = saturate(
                failsafe.abort_command(cfg.failsafe, nav_state.pitch_rad),
                self.controller_state.command,
                cfg.control.limits,
                dt_s,
            )
            command = _propeller_off(command)
            self.controller_state = control.ControllerState(command=command)
        elif stop is not None:
            command = stop
            self.controller_state = control.ControllerState(command=command)
        elif state is MissionState.COMPLETE and not (live and reference is not None):
            command = NEUTRAL  # surface: propeller 0 and fins neutral at once
            self.controller_state = control.ControllerState(command=command)
        elif reference is None:
            # IDLE, ARMED, HOLD, or RUNNING while the plan is computed: fins neutral, propeller off
            command = saturate(NEUTRAL, self.controller_state.command, cfg.control.limits, dt_s)
            if not live:
                command = _propeller_off(command)
            self.controller_state = control.ControllerState(command=command)
        if state is MissionState.ABORT:
            mode = m.ActuatorMode.ABORT
        elif live and state is not MissionState.ARMED:
            mode = m.ActuatorMode.ARMED
        else:
            mode = m.ActuatorMode.SAFE
        return TickRecord(
            command=command,
            mode=mode,
            mission_state=state,
            status=ap.status,
            nav=nav_state,
            reference=reference,
            failsafe_flags=fs_flags,
            planner_error=ap.executive.planner_error,
            nav_debug=nav_debug,
            guidance_debug=guidance_debug,
            control_debug=control_debug,
            fault_flags=faults,
            fault_measured=measured,
        )

    def _failsafes(self, ap: Core, nav_state: nav.NavState) -> FailsafeFlag:
        """A command that could not be encoded, the failsafe checks, the actuator node's failsafe: each an
        ABORT (a FAILSAFE event) while the vehicle may move; the flags failing this tick."""
        if ap.encode_fault:
            fault, ap.encode_fault = ap.encode_fault, ""
            if ap.status.live:  # moving, or armed to move
                ap.apply(MissionEvent.FAILSAFE, detail=fault)
            else:
                ap.note(c.Severity.ERROR, fault)
        if not ap.status.active:
            return _NO_FAILSAFE
        result, self.failsafe_state = failsafe.check(
            nav_state, ap.loop_late_s, self.failsafe_state, ap.config.failsafe
        )
        if result.abort:
            ap.apply(MissionEvent.FAILSAFE, detail=result.reason)
        elif ap.actuator_failsafe:
            ap.apply(MissionEvent.FAILSAFE, detail="the actuator node is in its failsafe")
        return result.flags

    def _diagnose(
        self,
        ap: Core,
        cache: Mapping[type, Any],
        fix: nav.PositionFix | None,
        nav_debug: nav.NavDebug,
        now_s: float,
        dt_s: float,
    ) -> tuple[diagnosis.FaultFlag, diagnosis.Measured]:
        """The fault detectors (:mod:`onboard.core.safety.diagnosis`) on this tick; each fault named is said
        (a note: one STATUSTEXT, a flight-log event) and answered by its reaction through the one place
        transitions happen: ABORT (a FAILSAFE event) while the vehicle may move, HOLD while RUNNING."""
        cfg, state = ap.config, ap.status.state
        if state is MissionState.RUNNING and self._state_before not in (
            MissionState.RUNNING,
            MissionState.HOLD,
        ):
            self.diagnosis_state = diagnosis.start_mission(self.diagnosis_state, now_s)
        self._state_before = state
        assert ap.last_nav is not None  # set by this tick's navigation
        inputs = diagnosis.DiagnosisInputs(
            nav=ap.last_nav,
            filter=self.nav_state,
            nav_debug=nav_debug,
            fix=fix,
            feedback=actuator_feedback(cache),
            command=self.controller_state.command,
            speed_to_rps=(cfg.control.speed_map_mps, cfg.control.speed_map_rps),
            fix_sigma_m=cfg.nav.fix_sigma_m,
            actuators_follow=state in (MissionState.RUNNING, MissionState.HOLD),
            fix_timeout_s=cfg.nav.fix_timeout_s,
            dvl_timeout_s=cfg.nav.dvl_timeout_s,
        )
        result, self.diagnosis_state = diagnosis.step(
            inputs, self.diagnosis_state, cfg.diagnosis, now_s, dt_s
        )
        ap.faults_named = self.diagnosis_state.named_text()
        for found in result.found:
            if (
                found.reaction is diagnosis.Reaction.ABORT
                and ap.status.active
                and state is not MissionState.ABORT
            ):
                ap.apply(MissionEvent.FAILSAFE, detail=found.text)
            elif found.reaction is diagnosis.Reaction.HOLD and ap.status.state is MissionState.RUNNING:
                ap.apply(MissionEvent.HOLD, detail=found.text, severity=c.Severity.WARNING)
            else:
                ap.note(c.Severity.WARNING, found.text)
        for text in result.cleared:
            ap.note(c.Severity.NOTICE, text)
        return result.flags, result.measured


_NO_FAILSAFE = FailsafeFlag(0)


def _propeller_off(command: ActuatorCommand) -> ActuatorCommand:
    """The same fin command with the propeller at 0 rps at once (the actuators are not live)."""
    if command.propeller_rps == 0.0:
        return command
    return ActuatorCommand(
        command.rudder_rad, command.stern_port_rad, command.stern_starboard_rad, 0.0, command.flags
    )


__all__ = ["Pipeline"]
