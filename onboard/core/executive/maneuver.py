"""The one small interface every maneuver implements (DUNE's maneuvers, MOOS-IvP's behaviours).

A maneuver is what the vehicle is doing now: :class:`~onboard.core.executive.goto.Goto` (homing to the
mission's goals), :class:`~onboard.core.executive.loiter.Loiter` (circling the last goal),
:class:`~onboard.core.executive.surface.Surface` (propeller 0, fins neutral). Each owns its own arrival,
progress and end logic; the :class:`~onboard.core.executive.executive.Executive` picks the one the mission
state asks for, schedules the plans it needs and hands it each tick. A maneuver never decides a transition
itself: it asks the vehicle (:meth:`Vehicle.apply`, the state table) like every other source.

Later issues extend this interface (monitors, braking, docking): a new maneuver is a new file with these four
methods and one line in :meth:`Executive.active`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

from onboard.core.commands import Severity
from onboard.core.config import CoreConfig
from onboard.core.guidance.guidance import GuidanceDebug, GuidanceReference, GuidanceState
from onboard.core.mission.model import Mission
from onboard.core.mission.state import MissionEvent, MissionStatus, Transition
from onboard.core.nav.types import NavState
from onboard.core.planner.path import Path
from onboard.core.plans import PlanRequest


class Vehicle(Protocol):
    """What a maneuver may read of the vehicle and ask of it (:class:`onboard.core.autopilot.Autopilot`)."""

    config: CoreConfig
    mission: Mission
    status: MissionStatus
    last_nav: NavState | None

    @property
    def now_s(self) -> float: ...

    def apply(
        self, event: MissionEvent, detail: str = "", *, severity: Severity | None = None
    ) -> Transition: ...

    def note(self, severity: Severity, text: str) -> None: ...


@dataclass(frozen=True)
class Leg:
    """What a maneuver flies this tick: guidance's reference on its path and guidance's debug numbers."""

    reference: GuidanceReference
    debug: GuidanceDebug


@dataclass(frozen=True)
class Progress:
    """How far a maneuver is: ``text`` for the operator, ``fraction`` in 0..1 (NaN when it has no end)."""

    text: str
    fraction: float


class Plans(Protocol):
    """What a maneuver may use of the executive (:class:`~onboard.core.executive.executive.Executive`): the
    path flown and where it came from, guidance's state on it, the plans asked for off the control thread
    and the stop. A protocol, so the maneuvers depend on this file only and the executive on them."""

    path: Path | None
    path_goal_index: int
    path_kind: str
    path_t_s: float
    path_current_mps: float
    guidance_state: GuidanceState

    @property
    def plan_waiting(self) -> PlanRequest | None: ...

    @property
    def braking(self) -> bool: ...

    def ask_plan(self, v: Vehicle, kind: str, replan: bool = False) -> None: ...

    def drop_path(self) -> None: ...

    def follow(self, v: Vehicle, nav: NavState, dt_s: float) -> Leg: ...

    def begin_stop(self, v: Vehicle) -> None: ...

    def current_mps(self, nav: NavState) -> float: ...

    def goal_run_in_m(self, v: Vehicle, index: int) -> float: ...


class Maneuver(Protocol):
    """One maneuver. ``kind`` names the plans it asks for and the path it flies (``goal``, ``loiter``,
    ``surface``)."""

    kind: str

    def start(self, ex: Plans, v: Vehicle) -> None:
        """Begin (afresh, from where the vehicle is): ask for the plan it needs, if any."""

    def step(self, ex: Plans, v: Vehicle, nav: NavState, dt_s: float) -> Leg | None:
        """One tick: the leg to fly (None: nothing to fly, the pipeline holds the fins neutral)."""

    def plan_failed(self, ex: Plans, v: Vehicle, why: str, late: bool) -> None:
        """Its plan could not be made: the planner's error ``why``, or (``late``) why it missed its
        deadline. What it does instead is its own business (hold, surface)."""

    def done(self, v: Vehicle) -> bool:
        """True when it has ended (nothing more to fly)."""

    def progress(self, ex: Plans, v: Vehicle) -> Progress:
        """How far it is."""
