"""Commands to the vehicle and the core's verdict on each: the one vocabulary every source speaks.

Every command, from every source (MAVLink, ``--autostart``, the failsafes, the scenario runner, tests), is
judged by exactly one judge: :meth:`onboard.core.autopilot.Autopilot.handle` (the commander,
:func:`onboard.core.commander.judge`, asking the state table for the state's preconditions), which returns a
:class:`Verdict` (an :class:`Outcome` like MAVLink's MAV_RESULT and a human reason). The links only carry
commands in and verdicts out; they never judge vehicle state themselves.

``source`` names who sent a command (``"MAVLink 255/190"``, ``"autostart"``, ...); it appears in the log and
in the reason, never in the judgement.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import Literal

from onboard.core.mission.model import Mission


class Outcome(enum.Enum):
    """The result of one command (mapped to MAV_RESULT in one place, the MAVLink adapter)."""

    ACCEPTED = "accepted"
    TEMPORARILY_REJECTED = "temporarily rejected"  # valid, but not now (e.g. navigation not valid yet)
    DENIED = "denied"  # not allowed in this state, or a bad argument
    FAILED = "failed"  # allowed, but it could not be carried out
    UNSUPPORTED = "unsupported"  # a command this vehicle does not know


@dataclass(frozen=True)
class Verdict:
    """The core's answer to one command: the outcome and why (always a sentence a human can act on).

    ``value`` carries the value in force after a :class:`SetParam` (accepted or not), else NaN.
    """

    outcome: Outcome
    reason: str
    value: float = float("nan")

    @property
    def accepted(self) -> bool:
        return self.outcome is Outcome.ACCEPTED


def accepted(reason: str, value: float = float("nan")) -> Verdict:
    return Verdict(Outcome.ACCEPTED, reason, value)


def denied(reason: str, value: float = float("nan")) -> Verdict:
    return Verdict(Outcome.DENIED, reason, value)


def not_now(reason: str) -> Verdict:
    return Verdict(Outcome.TEMPORARILY_REJECTED, reason)


@dataclass(frozen=True)
class Arm:
    """Arm: IDLE -> ARMED (needs a mission with goals); COMPLETE -> ARMED (fly the mission again)."""

    source: str = ""


@dataclass(frozen=True)
class Disarm:
    """Disarm: -> IDLE. While RUNNING only when ``forced`` (propeller off at once)."""

    forced: bool = False
    source: str = ""


@dataclass(frozen=True)
class Start:
    """Start the mission (ARMED -> RUNNING) at ``first_goal`` (None: the current goal, i.e. the mission's
    progress, 0 for a new mission); in HOLD it resumes."""

    first_goal: int | None = None
    source: str = ""


@dataclass(frozen=True)
class Hold:
    """Pause a running mission (RUNNING -> HOLD: propeller off, fins neutral, still armed)."""

    source: str = ""


@dataclass(frozen=True)
class Resume:
    """Continue a held mission (HOLD -> RUNNING, re-planned from where the vehicle is)."""

    source: str = ""


@dataclass(frozen=True)
class Abort:
    """Abort: propeller off, fins to surface. Accepted in every state."""

    reason: str = "operator"
    source: str = ""


@dataclass(frozen=True)
class SetCurrent:
    """Make goal ``index`` (0-based) the current goal; while RUNNING the vehicle re-plans to it."""

    index: int
    source: str = ""


ModeName = Literal["ready", "mission", "loiter", "surface"]


@dataclass(frozen=True)
class SetMode:
    """A mode request (MAVLink DO_SET_MODE): ``mission`` starts or resumes, ``loiter`` holds, ``surface``
    aborts, ``ready`` is accepted only when nothing moves and nothing is to be acknowledged (IDLE, ARMED,
    COMPLETE surfaced: nothing to change); denied with the reason while running, holding, loitering or in
    ABORT."""

    mode: ModeName
    source: str = ""


@dataclass(frozen=True)
class ReplaceMission:
    """A complete mission (goals and fence obstacles), already checked by
    :func:`onboard.core.mission.validate.check_mission`.

    ``goals_changed`` False: only the fence changed; the state and the current goal stay (a running vehicle
    re-plans its leg around the new obstacles). True: a new mission: the current goal becomes 0 and a
    running vehicle holds until an explicit START. The armed state never changes.
    """

    mission: Mission
    goals_changed: bool = True
    source: str = ""


@dataclass(frozen=True)
class SetParam:
    """Set one parameter of the table (:mod:`onboard.core.params`) to ``value`` (in its unit)."""

    name: str
    value: float
    source: str = ""


@dataclass(frozen=True)
class LinkLost:
    """No ground-station heartbeat for the configured time; ``action`` is the configured reaction."""

    action: Literal["continue", "hold", "surface"]
    source: str = ""


@dataclass(frozen=True)
class BusLost:
    """The CAN bus is gone (``reason``: the hub closed, the interface is down, ...): the vehicle can neither
    command its actuators nor hear its sensors. A mission under way aborts (propeller 0 is all a command can
    still mean, and the actuator node's own watchdog stops it anyway); START waits until :class:`BusBack`."""

    reason: str
    source: str = "CAN bus"


@dataclass(frozen=True)
class BusBack:
    """The CAN bus is open again. An ABORT the loss caused (nothing since) is acknowledged: disarmed, the
    mission and its progress kept for the operator to START again once the sensors are back."""

    source: str = "CAN bus"


Command = (
    Arm
    | Disarm
    | Start
    | Hold
    | Resume
    | Abort
    | SetCurrent
    | SetMode
    | ReplaceMission
    | SetParam
    | LinkLost
    | BusLost
    | BusBack
)


class Severity(enum.IntEnum):
    """Severity of a :class:`Note` (the MAVLink adapter maps it to MAV_SEVERITY)."""

    CRITICAL = 2
    ERROR = 3
    WARNING = 4
    NOTICE = 5
    INFO = 6


@dataclass(frozen=True)
class Note:
    """Something the operator must be told (a transition, a refusal, a miss): one line of text."""

    severity: Severity
    text: str
