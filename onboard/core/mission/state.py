"""The mission state machine: IDLE, ARMED, RUNNING, HOLD, ABORT, COMPLETE and the current goal index.

Pure: :func:`transition` takes the current :class:`MissionStatus` and one :class:`MissionEvent` and returns a
:class:`Transition` (the new status, whether the event was accepted, and a human-readable reason). An illegal
event leaves the status unchanged, ``accepted=False`` and says why. The loop logs transitions, not ticks.

Table (anything not listed is rejected)::

    IDLE      arm -> ARMED (needs >= 1 goal)         mission_replaced -> IDLE       abort -> ABORT
    ARMED     start -> RUNNING (goal 0)              disarm -> IDLE                 mission_replaced -> ARMED
              abort, failsafe -> ABORT
    RUNNING   goal_reached -> RUNNING (next goal) or COMPLETE (after the last)     hold -> HOLD
              mission_replaced -> RUNNING (goal 0)   abort, failsafe -> ABORT
    HOLD      resume -> RUNNING                      disarm -> IDLE                 mission_replaced -> HOLD
              abort, failsafe -> ABORT
    COMPLETE  disarm -> IDLE                         mission_replaced -> ARMED      abort, failsafe -> ABORT
    ABORT     disarm -> IDLE (operator acknowledges) mission_replaced -> ABORT (goal 0)

Behaviour per state (the loop's job): IDLE/ARMED propeller off, fins neutral; RUNNING flies the path to goal
``goal_index``; HOLD is the loop's choice (e.g. hold heading and depth); COMPLETE flies the straight
extension at reduced speed (``guidance.step(..., complete=True)``); ABORT sends
:func:`onboard.core.safety.failsafe.abort_command`. A FAILSAFE in IDLE is rejected (nothing is moving) and in
ABORT it is already in force.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, replace


class MissionState(enum.Enum):
    IDLE = "IDLE"
    ARMED = "ARMED"
    RUNNING = "RUNNING"
    HOLD = "HOLD"
    ABORT = "ABORT"
    COMPLETE = "COMPLETE"


class MissionEvent(enum.Enum):
    ARM = "arm"
    DISARM = "disarm"
    START = "start"
    HOLD = "hold"
    RESUME = "resume"
    ABORT = "abort"
    GOAL_REACHED = "goal_reached"
    MISSION_REPLACED = "mission_replaced"
    FAILSAFE = "failsafe"


@dataclass(frozen=True)
class MissionStatus:
    """The mission state, the index of the active goal (0-based) and how many goals the mission has.

    ``reason`` says why the last accepted transition happened (e.g. the failsafe's reason).
    """

    state: MissionState = MissionState.IDLE
    goal_index: int = 0
    goal_count: int = 0
    reason: str = "boot"

    @property
    def active(self) -> bool:
        """True when the vehicle may be moving under its own power (the failsafes apply)."""
        return self.state in (MissionState.RUNNING, MissionState.HOLD, MissionState.COMPLETE)


@dataclass(frozen=True)
class Transition:
    """The result of one event: the new status (unchanged when rejected), acceptance and the reason."""

    status: MissionStatus
    accepted: bool
    reason: str


S = MissionState
E = MissionEvent

# (state, event) -> target state, for the simple edges. GOAL_REACHED, MISSION_REPLACED, ARM and START have
# extra rules in transition().
_EDGES: dict[tuple[MissionState, MissionEvent], MissionState] = {
    (S.IDLE, E.ARM): S.ARMED,
    (S.IDLE, E.ABORT): S.ABORT,
    (S.IDLE, E.MISSION_REPLACED): S.IDLE,
    (S.ARMED, E.START): S.RUNNING,
    (S.ARMED, E.DISARM): S.IDLE,
    (S.ARMED, E.ABORT): S.ABORT,
    (S.ARMED, E.FAILSAFE): S.ABORT,
    (S.ARMED, E.MISSION_REPLACED): S.ARMED,
    (S.RUNNING, E.HOLD): S.HOLD,
    (S.RUNNING, E.ABORT): S.ABORT,
    (S.RUNNING, E.FAILSAFE): S.ABORT,
    (S.RUNNING, E.GOAL_REACHED): S.RUNNING,
    (S.RUNNING, E.MISSION_REPLACED): S.RUNNING,
    (S.HOLD, E.RESUME): S.RUNNING,
    (S.HOLD, E.DISARM): S.IDLE,
    (S.HOLD, E.ABORT): S.ABORT,
    (S.HOLD, E.FAILSAFE): S.ABORT,
    (S.HOLD, E.MISSION_REPLACED): S.HOLD,
    (S.COMPLETE, E.DISARM): S.IDLE,
    (S.COMPLETE, E.ABORT): S.ABORT,
    (S.COMPLETE, E.FAILSAFE): S.ABORT,
    (S.COMPLETE, E.MISSION_REPLACED): S.ARMED,
    (S.ABORT, E.DISARM): S.IDLE,
    (S.ABORT, E.MISSION_REPLACED): S.ABORT,
}


def transition(
    status: MissionStatus, event: MissionEvent, *, goal_count: int | None = None, detail: str = ""
) -> Transition:
    """Apply ``event`` to ``status``.

    ``goal_count`` is required with ``MISSION_REPLACED`` (the new mission's number of goals, >= 0);
    ``detail`` is appended to the reason (e.g. the failsafe's reason or who sent the command).
    """
    suffix = f": {detail}" if detail else ""
    target = _EDGES.get((status.state, event))
    if target is None:
        why = f"{event.value} not allowed in {status.state.value}"
        return Transition(status, False, why + suffix)

    if event is E.MISSION_REPLACED:
        if goal_count is None or goal_count < 0:
            return Transition(status, False, "mission_replaced needs the new goal count" + suffix)
        if status.state is S.RUNNING and goal_count == 0:
            return Transition(status, False, "mission_replaced with no goals while RUNNING" + suffix)
        reason = f"mission replaced ({goal_count} goals), goal 0" + suffix
        new = MissionStatus(target, 0, goal_count, reason)
        return Transition(new, True, reason)

    if event in (E.ARM, E.START) and status.goal_count == 0:
        return Transition(status, False, f"{event.value} rejected: the mission has no goals" + suffix)

    if event is E.GOAL_REACHED:
        done = status.goal_index
        if done + 1 >= status.goal_count:
            reason = f"goal {done} reached, the last: COMPLETE" + suffix
            return Transition(
                replace(status, state=S.COMPLETE, goal_index=status.goal_count, reason=reason), True, reason
            )
        reason = f"goal {done} reached, next goal {done + 1}" + suffix
        return Transition(replace(status, goal_index=done + 1, reason=reason), True, reason)

    index = 0 if event is E.START else status.goal_index
    reason = f"{event.value}: {status.state.value} -> {target.value}" + suffix
    return Transition(replace(status, state=target, goal_index=index, reason=reason), True, reason)
