"""The mission state machine: IDLE, ARMED, RUNNING, HOLD, ABORT, COMPLETE and the current goal index.

Pure: :func:`transition` takes the current :class:`MissionStatus` and one :class:`MissionEvent` and returns a
:class:`Transition` (the new status, whether the event was accepted, and a human-readable reason). An illegal
event leaves the status unchanged, ``accepted=False`` and says why. This table is the vocabulary of states
and the one owner of every precondition that depends on the state alone: which event is allowed where (and
the hint the operator reads when it is not, :data:`_HINTS`), which command changes nothing where
(:func:`no_op`: "already armed"), that a mission has goals, that a goal index is in range
(:func:`goal_problem`), and which states may move the actuators (:func:`actuators_live`). The one judge of
commands, :mod:`onboard.core.commander`, asks it (pure: a dry run) and adds only what the state
cannot know (navigation valid, the CAN bus, the actuator node's failsafe).

Table (anything not listed is rejected)::

    IDLE      arm -> ARMED (needs >= 1 goal)         mission_replaced -> IDLE       abort -> ABORT
    ARMED     start -> RUNNING (at the current goal) disarm -> IDLE                 mission_replaced -> ARMED
              abort, failsafe -> ABORT
    RUNNING   goal_reached -> RUNNING (next goal) or COMPLETE (after the last)     hold -> HOLD
              mission_replaced -> HOLD (goal 0: a new mission needs an explicit START)
              disarm_forced -> IDLE                  abort, failsafe -> ABORT
    HOLD      resume, start -> RUNNING               disarm -> IDLE                 mission_replaced -> HOLD
              abort, failsafe -> ABORT
    COMPLETE  arm -> ARMED (goal 0: fly it again)    disarm -> IDLE (goal 0)        abort, failsafe -> ABORT
              mission_replaced -> IDLE (surfaced) or ARMED (loitering: still armed)
    ABORT     disarm -> IDLE (operator acknowledges) mission_replaced -> ABORT (goal 0)

``disarm_forced`` is accepted wherever ``disarm`` is, and in RUNNING. ``mission_replaced`` means new goals
(the goal index goes to 0); a fence change alone is no event (the state and the goal stay). The armed state
never changes with a mission: the states that may move the actuators stay such, the others stay still.

Behaviour per state (the autopilot's job): IDLE/ARMED propeller off, fins neutral; RUNNING flies the path to
goal ``goal_index``; HOLD propeller off, fins neutral, still armed; COMPLETE does the configured end action
(``surface``: propeller 0 and fins neutral at once; ``loiter``: circle the last goal); ABORT sends
:func:`onboard.core.safety.failsafe.abort_command`. A FAILSAFE in IDLE is rejected (nothing is moving) and in
ABORT it is already in force.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, replace

from onboard.protocol.messages import LIVE_MISSION_STATES, MissionStateCode

#: The mission states: the bus contract's enumeration (the DBC's ONBOARD_HEARTBEAT node_state values), so the
#: vocabulary is spelled once; names are what the operator reads, values what the bus carries.
MissionState = MissionStateCode


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
    DISARM_FORCED = "disarm_forced"


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
    def live(self) -> bool:
        """True in a state whose actuators may move (:data:`LIVE_STATES`; COMPLETE: :func:`actuators_live`
        says whether they do)."""
        return self.state in LIVE_STATES

    @property
    def active(self) -> bool:
        """True when the vehicle may be moving under its own power: the failsafes apply
        (:data:`ACTIVE_STATES`)."""
        return self.state in ACTIVE_STATES


#: The one definition of the "live" states: those in which the actuators may move under the vehicle's own
#: command: ARMED, RUNNING, HOLD, COMPLETE (COMPLETE only while it loiters: :func:`actuators_live`). It is the
#: bus contract's set (``messages.LIVE_MISSION_STATES``: the actuator node obeys ARMED commands only while the
#: onboard heartbeat names one of these), spelled there because the bench, which may import only the
#: protocol, applies it too; the core asks it here.
LIVE_STATES: frozenset[MissionState] = LIVE_MISSION_STATES
#: The live states in which the vehicle may be moving under its own power, so the failsafes apply: all but
#: ARMED (still: the propeller stays off until START).
ACTIVE_STATES: frozenset[MissionState] = LIVE_STATES - {MissionState.ARMED}


def actuators_live(state: MissionState, loitering: bool) -> bool:
    """True exactly when the actuators may move under the vehicle's own command: ARMED, RUNNING, HOLD, and
    COMPLETE while ``loitering`` (the ``loiter`` end action, not fallen back to surfacing)."""
    if state is MissionState.COMPLETE:
        return loitering
    return state in LIVE_STATES


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
    (S.ARMED, E.DISARM_FORCED): S.IDLE,
    (S.ARMED, E.ABORT): S.ABORT,
    (S.ARMED, E.FAILSAFE): S.ABORT,
    (S.ARMED, E.MISSION_REPLACED): S.ARMED,
    (S.RUNNING, E.HOLD): S.HOLD,
    (S.RUNNING, E.ABORT): S.ABORT,
    (S.RUNNING, E.FAILSAFE): S.ABORT,
    (S.RUNNING, E.GOAL_REACHED): S.RUNNING,
    (S.RUNNING, E.MISSION_REPLACED): S.HOLD,
    (S.RUNNING, E.DISARM_FORCED): S.IDLE,
    (S.HOLD, E.RESUME): S.RUNNING,
    (S.HOLD, E.START): S.RUNNING,
    (S.HOLD, E.DISARM): S.IDLE,
    (S.HOLD, E.DISARM_FORCED): S.IDLE,
    (S.HOLD, E.ABORT): S.ABORT,
    (S.HOLD, E.FAILSAFE): S.ABORT,
    (S.HOLD, E.MISSION_REPLACED): S.HOLD,
    (S.COMPLETE, E.ARM): S.ARMED,
    (S.COMPLETE, E.DISARM): S.IDLE,
    (S.COMPLETE, E.DISARM_FORCED): S.IDLE,
    (S.COMPLETE, E.ABORT): S.ABORT,
    (S.COMPLETE, E.FAILSAFE): S.ABORT,
    (S.COMPLETE, E.MISSION_REPLACED): S.IDLE,
    (S.ABORT, E.DISARM): S.IDLE,
    (S.ABORT, E.DISARM_FORCED): S.IDLE,
    (S.ABORT, E.MISSION_REPLACED): S.ABORT,
}


# (state, event) -> what the operator should do instead, added to "<event> not allowed in <STATE>".
_HINTS: dict[tuple[MissionState, MissionEvent], str] = {
    (S.ABORT, E.ARM): "disarm first to acknowledge the abort",
    (S.ABORT, E.START): "disarm first to acknowledge the abort",
    (S.RUNNING, E.DISARM): "hold (or force the disarm) first",
    (S.IDLE, E.START): "disarmed, arm first",
    (S.COMPLETE, E.START): "the mission is complete, arm to fly it again",
    **{(s, E.HOLD): "not running" for s in (S.IDLE, S.ARMED, S.COMPLETE, S.ABORT)},
    **{(s, E.RESUME): "not holding" for s in (S.IDLE, S.ARMED, S.COMPLETE, S.ABORT)},
}

# (state, event) -> why the command that asks for the event changes nothing there (accepted as a no-op).
_NO_OPS: dict[tuple[MissionState, MissionEvent], str] = {
    **{(s, E.ARM): f"already armed ({s.name})" for s in (S.ARMED, S.RUNNING, S.HOLD)},
    (S.IDLE, E.DISARM): "already disarmed",
    (S.IDLE, E.DISARM_FORCED): "already disarmed",
    (S.HOLD, E.HOLD): "already holding",
    (S.RUNNING, E.RESUME): "already running",
    (S.RUNNING, E.START): "already running",
    (S.ABORT, E.ABORT): "already in ABORT",
}

#: The states in which the current goal may be set (not COMPLETE: done; not ABORT: to be acknowledged).
_GOAL_SETTABLE = frozenset({S.IDLE, S.ARMED, S.RUNNING, S.HOLD})


def no_op(status: MissionStatus, event: MissionEvent) -> str:
    """Why ``event`` would change nothing in ``status`` ("already armed (RUNNING)"), else ""."""
    return _NO_OPS.get((status.state, event), "")


def goal_problem(status: MissionStatus, index: int) -> str:
    """Why goal ``index`` cannot be made the current goal now ("" when it can): the one owner of the goal
    index's range (START and RESUME use it too, through :func:`transition`)."""
    if not 0 <= index < status.goal_count:
        return f"no goal {index}: the mission has {status.goal_count} goals"
    if status.state not in _GOAL_SETTABLE:
        return f"{status.state.name}: the current goal cannot change now"
    return ""


def transition(
    status: MissionStatus,
    event: MissionEvent,
    *,
    goal_count: int | None = None,
    goal_index: int | None = None,
    detail: str = "",
    complete_armed: bool = False,
) -> Transition:
    """Apply ``event`` to ``status``.

    ``goal_count`` is required with ``MISSION_REPLACED`` (the new mission's number of goals, >= 0);
    ``goal_index`` is the goal a START begins at (default: the current goal, the mission's progress);
    ``detail`` is appended to the reason (e.g. the failsafe's reason or who sent the command);
    ``complete_armed``: COMPLETE is armed (the loiter end action), so a new mission leaves it ARMED.
    """
    suffix = f": {detail}" if detail else ""
    target = _EDGES.get((status.state, event))
    if target is None:
        why = f"{event.value} not allowed in {status.state.name}"
        hint = _HINTS.get((status.state, event))
        return Transition(status, False, why + (f": {hint}" if hint else "") + suffix)

    if event is E.MISSION_REPLACED:
        if goal_count is None or goal_count < 0:
            return Transition(status, False, "mission_replaced needs the new goal count" + suffix)
        if status.state is S.COMPLETE and complete_armed:
            target = S.ARMED
        reason = f"new mission ({goal_count} goals), goal 0" + suffix
        if status.state is S.RUNNING:
            reason += "; holding until START"
        new = MissionStatus(target, 0, goal_count, reason)
        return Transition(new, True, reason)

    if event in (E.ARM, E.START, E.RESUME) and status.goal_count == 0:
        return Transition(
            status, False, f"{event.value} rejected: the mission has no goals (upload one first)" + suffix
        )

    if event is E.GOAL_REACHED:
        done = status.goal_index
        if done + 1 >= status.goal_count:
            reason = f"goal {done} reached, the last: COMPLETE" + suffix
            return Transition(
                replace(status, state=S.COMPLETE, goal_index=status.goal_count, reason=reason), True, reason
            )
        reason = f"goal {done} reached, next goal {done + 1}" + suffix
        return Transition(replace(status, goal_index=done + 1, reason=reason), True, reason)

    index = status.goal_index
    if status.state is S.COMPLETE and event in (E.ARM, E.DISARM, E.DISARM_FORCED):
        index = 0  # a completed mission's progress is done: the next flight of it starts at goal 0
    elif event in (E.START, E.RESUME):
        index = status.goal_index if goal_index is None else goal_index
        if not 0 <= index < status.goal_count:
            why = f"{event.value} rejected: {goal_problem(status, index)}"
            return Transition(status, False, why + suffix)
    reason = f"{event.value}: {status.state.name} -> {target.name}" + suffix
    return Transition(replace(status, state=target, goal_index=index, reason=reason), True, reason)
