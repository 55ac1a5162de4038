"""The autopilot: the onboard core's one face to the loop and the links, composed of three parts.

- the *commander* (:mod:`onboard.core.commander`): :meth:`Autopilot.handle` is the only judge of every
  command from every source (see :mod:`onboard.core.commands`); it answers a
  :class:`~onboard.core.commands.Verdict` with a reason, asking the state table
  (:mod:`onboard.core.mission.state`) for every precondition of the state;
- the *executive* (:mod:`onboard.core.executive`): what the vehicle is doing now, one maneuver per file
  (homing to the goals, the loiter, surfacing), and the plans they need, computed off the control thread
  (:meth:`Autopilot.take_plan_request` / :meth:`Autopilot.plan_done`);
- the *pipeline* (:mod:`onboard.core.pipeline`): one :meth:`Autopilot.step` per tick, nav -> failsafes ->
  executive -> guidance -> PD -> saturation, into one :class:`~onboard.core.record.TickRecord`.

No clock, no bus, no threads: the loop (:mod:`onboard.app.loop`) gives the latest-value cache of bus
messages, ``now_s`` and ``dt_s``, sends what comes back, runs the plans and carries commands from the links
to :meth:`Autopilot.handle`. What the operator must be told (transitions, misses, planning failures) is
queued as :class:`~onboard.core.commands.Note` (:meth:`Autopilot.take_notes`).

This class holds the vehicle's state the three parts share (the configuration, the mission, the mission
status, the latest navigation solution, what the loop reported) and nothing of their logic.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field, replace
from typing import Any

from onboard.core import commander, control, guidance, nav
from onboard.core import commands as c
from onboard.core.config import CoreConfig
from onboard.core.executive import Executive
from onboard.core.mission.model import Mission
from onboard.core.mission.state import (
    MissionEvent,
    MissionState,
    MissionStatus,
    Transition,
    actuators_live,
    goal_problem,
)
from onboard.core.params import BusLimits
from onboard.core.pipeline import Pipeline
from onboard.core.planner.errors import PlannerError
from onboard.core.planner.path import Path
from onboard.core.plans import PlanRequest
from onboard.core.record import TickRecord

log = logging.getLogger(__name__)


@dataclass
class Autopilot:
    """The onboard core driven by :class:`onboard.app.loop.ControlLoop` (one :meth:`step` per tick)."""

    config: CoreConfig
    bus_limits: BusLimits | None = None  # the DBC's command ranges (the app reads them); None: no SetParam
    mission: Mission = field(default_factory=lambda: Mission(()))
    status: MissionStatus = field(default_factory=MissionStatus)
    executive: Executive = field(default_factory=Executive)
    pipeline: Pipeline = field(default_factory=Pipeline)
    loop_late_s: float = 0.0  # how long the loop has been behind its schedule (s), from note_loop_late
    last_nav: nav.NavState | None = None
    notes: list[c.Note] = field(default_factory=list)  # for the operator, since the last take_notes()
    autostart_pending: bool = False
    actuator_failsafe: bool = False  # the latest PROP_STATUS / FIN_STATUS failsafe flag
    encode_fault: str = ""  # a command frame that could not be encoded (set by the loop)
    bus_lost: str = ""  # why the CAN bus is lost ("" while it is up): BusLost / BusBack
    bus_abort: MissionStatus | None = None  # the status the bus loss aborted into (BusBack undoes only it)
    now_s: float = 0.0  # the time of the latest step (s, the loop's time base)
    faults_named: str = ""  # the faults named on this mission (diagnosis.DiagnosisState.named_text)

    # --- what the links read --------------------------------------------------------------------
    @property
    def actuators_live(self) -> bool:
        """True exactly when the actuators may move under the vehicle's own command (the state table's
        rule, :func:`~onboard.core.mission.state.actuators_live`; COMPLETE counts as loitering while the
        stop still brakes: the vehicle commands its propeller)."""
        ex = self.executive
        return actuators_live(self.status.state, ex.loitering(self) or ex.stop.braking)

    @property
    def ready(self) -> tuple[bool, str]:
        """(True, "") when a START would pass the vehicle's own checks, else (False, why)."""
        return commander.readiness(self)

    def take_notes(self) -> list[c.Note]:
        out, self.notes = self.notes, []
        return out

    def note(self, severity: c.Severity, text: str) -> None:
        """Something the operator must be told (one STATUSTEXT on MAVLink)."""
        self.notes.append(c.Note(severity, text))

    # the executive's and the pipeline's state, read by the links, the runtime and the tests
    @property
    def path(self) -> Path | None:
        return self.executive.path

    @property
    def path_kind(self) -> str:
        return self.executive.path_kind

    @property
    def path_goal_index(self) -> int:
        return self.executive.path_goal_index

    @property
    def planner_error(self) -> str:
        return self.executive.planner_error

    @property
    def goals_reached(self) -> int:
        return self.executive.goto.goals_reached

    @property
    def attempt(self) -> int:
        return self.executive.goto.attempt

    @property
    def guidance_state(self) -> guidance.GuidanceState:
        return self.executive.guidance_state

    @guidance_state.setter
    def guidance_state(self, value: guidance.GuidanceState) -> None:
        self.executive.guidance_state = value

    @property
    def nav_state(self) -> nav.NavFilterState:
        return self.pipeline.nav_state

    @nav_state.setter
    def nav_state(self, value: nav.NavFilterState) -> None:
        self.pipeline.nav_state = value

    @property
    def controller_state(self) -> control.ControllerState:
        return self.pipeline.controller_state

    # --- the one judge ----------------------------------------------------------------------------
    def handle(self, command: c.Command) -> c.Verdict:
        """Judge and carry out one command (:func:`onboard.core.commander.judge`); log it; return the
        verdict with its reason."""
        verdict = commander.judge(self, command)
        src = getattr(command, "source", "") or "onboard"
        name = type(command).__name__
        if verdict.accepted:
            log.info("%s from %s: %s", name, src, verdict.reason)
        else:
            log.warning("%s from %s %s: %s", name, src, verdict.outcome.value, verdict.reason)
        return verdict

    def apply(
        self,
        event: MissionEvent,
        detail: str = "",
        *,
        goal_count: int | None = None,
        goal_index: int | None = None,
        severity: c.Severity | None = None,
    ) -> Transition:
        """Carry out a mission event (:func:`onboard.core.commander.apply`): the maneuvers' and the
        failsafes' events, and the judge's once it has judged. Not a door for commands: :meth:`handle`."""
        return commander.apply(
            self, event, detail, goal_count=goal_count, goal_index=goal_index, severity=severity
        )

    def note_bus(self, lost_reason: str) -> None:
        """The loop's word on the CAN bus ("": up, else why it is lost), judged like every other command."""
        if lost_reason != self.bus_lost:
            self.handle(c.BusLost(lost_reason) if lost_reason else c.BusBack())

    def replace_mission(self, mission: Mission) -> c.Verdict:
        """A new mission (goals and fence) from a trusted door (tests, start-up): :meth:`handle`."""
        return self.handle(c.ReplaceMission(mission, True, "start-up"))

    def restore_progress(self, goal_index: int) -> bool:
        """At boot: make the persisted progress the current goal (IDLE only; START continues from it)."""
        if self.status.state is not MissionState.IDLE or goal_problem(self.status, goal_index):
            return False
        self.status = replace(
            self.status, goal_index=goal_index, reason=f"progress restored: goal {goal_index}"
        )
        return True

    def request_autostart(self) -> None:
        """Arm now and start as soon as the navigation solution is valid (``--autostart``)."""
        verdict = self.handle(c.Arm("autostart"))
        self.autostart_pending = verdict.accepted
        if not verdict.accepted:  # no ground station asked: the operator hears the refusal here
            self.note(c.Severity.WARNING, f"autostart: arm refused: {verdict.reason}")

    def before_step(self) -> None:
        """The core's own command sources, judged like every other, before the step (and before the loop
        hands out the plans, so a START's plan is flown by this step in lock-step): ``--autostart`` sends
        its START once the navigation solution (of the last step) is valid."""
        if self.autostart_pending and self.status.state is MissionState.ARMED and self.ready[0]:
            self.autostart_pending = False
            verdict = self.handle(c.Start(None, "autostart: navigation valid"))
            if not verdict.accepted:  # e.g. a goal it cannot make good against the current: said, not silent
                self.note(c.Severity.WARNING, f"autostart: start refused: {verdict.reason}")

    def note_loop_late(self, late_s: float) -> None:
        """How long the loop has been behind its schedule (s, 0 = on time): the next step's failsafe input."""
        self.loop_late_s = late_s

    def note_encode_fault(self, message: str, reason: str) -> None:
        """The loop could not encode a command frame: a fault (an ABORT at the next tick when moving)."""
        self.encode_fault = f"command not encodable: {message}: {reason}"

    # --- planning off the control thread ------------------------------------------------------------
    def take_plan_request(self) -> PlanRequest | None:
        """The plan the core asks for (once): the loop computes it with :func:`compute_plan`."""
        return self.executive.take_plan_request()

    @property
    def plan_pending(self) -> bool:
        return self.executive.plan_waiting is not None

    def plan_done(self, request_id: int, result: Path | PlannerError) -> None:
        """The worker's answer to request ``request_id`` (a stale one, e.g. after a HOLD, is dropped)."""
        if self.executive.plan_done(self, request_id, result):
            self.pipeline.new_path()

    # --- one tick ---------------------------------------------------------------------------------
    def step(self, cache: dict[type, Any], now_s: float, dt_s: float) -> TickRecord:
        """One tick at ``now_s`` (s) of period ``dt_s`` (s) from the latest-value cache of bus messages."""
        return self.pipeline.tick(self, cache, now_s, dt_s)


__all__ = ["Autopilot", "TickRecord"]
