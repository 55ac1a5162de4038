"""Unit tests of the mission state machine: the transition table, goal indices, rejections with reasons."""

from __future__ import annotations

import pytest

from onboard.core.mission.state import MissionEvent, MissionState, MissionStatus, transition

S, E = MissionState, MissionEvent

# (from, event, to) for every accepted edge; every other (state, event) pair must be rejected.
ACCEPTED = [
    (S.IDLE, E.ARM, S.ARMED),
    (S.IDLE, E.ABORT, S.ABORT),
    (S.IDLE, E.MISSION_REPLACED, S.IDLE),
    (S.ARMED, E.START, S.RUNNING),
    (S.ARMED, E.DISARM, S.IDLE),
    (S.ARMED, E.DISARM_FORCED, S.IDLE),
    (S.ARMED, E.ABORT, S.ABORT),
    (S.ARMED, E.FAILSAFE, S.ABORT),
    (S.ARMED, E.MISSION_REPLACED, S.ARMED),
    (S.RUNNING, E.HOLD, S.HOLD),
    (S.RUNNING, E.ABORT, S.ABORT),
    (S.RUNNING, E.FAILSAFE, S.ABORT),
    (S.RUNNING, E.GOAL_REACHED, S.RUNNING),
    (S.RUNNING, E.MISSION_REPLACED, S.HOLD),  # a new mission needs an explicit START
    (S.RUNNING, E.DISARM_FORCED, S.IDLE),
    (S.HOLD, E.RESUME, S.RUNNING),
    (S.HOLD, E.START, S.RUNNING),
    (S.HOLD, E.DISARM, S.IDLE),
    (S.HOLD, E.DISARM_FORCED, S.IDLE),
    (S.HOLD, E.ABORT, S.ABORT),
    (S.HOLD, E.FAILSAFE, S.ABORT),
    (S.HOLD, E.MISSION_REPLACED, S.HOLD),
    (S.COMPLETE, E.ARM, S.ARMED),
    (S.COMPLETE, E.DISARM, S.IDLE),
    (S.COMPLETE, E.DISARM_FORCED, S.IDLE),
    (S.COMPLETE, E.ABORT, S.ABORT),
    (S.COMPLETE, E.FAILSAFE, S.ABORT),
    (S.COMPLETE, E.MISSION_REPLACED, S.IDLE),  # surfaced: stays disarmed
    (S.ABORT, E.DISARM, S.IDLE),
    (S.ABORT, E.DISARM_FORCED, S.IDLE),
    (S.ABORT, E.MISSION_REPLACED, S.ABORT),
]
ACCEPTED_PAIRS = {(a, e) for a, e, _ in ACCEPTED}
REJECTED = [(a, e) for a in S for e in E if (a, e) not in ACCEPTED_PAIRS]


@pytest.mark.parametrize(("state", "event", "target"), ACCEPTED)
def test_accepted_transitions(state: MissionState, event: MissionEvent, target: MissionState) -> None:
    # GIVEN a mission of 3 goals in `state`, at goal 0
    status = MissionStatus(state, 0, 3)
    # WHEN the event arrives
    tr = transition(status, event, goal_count=3, detail="test")
    # THEN it is accepted with a reason naming the detail
    assert tr.accepted and tr.status.state is target
    assert "test" in tr.reason and tr.status.reason == tr.reason


@pytest.mark.parametrize(("state", "event"), REJECTED)
def test_rejected_transitions_leave_the_status_unchanged(state: MissionState, event: MissionEvent) -> None:
    status = MissionStatus(state, 1, 3, "before")
    tr = transition(status, event, goal_count=3)
    assert not tr.accepted and tr.status == status
    assert event.value in tr.reason and state.name in tr.reason


def test_goals_advance_then_complete_after_the_last() -> None:
    # GIVEN a running mission of 3 goals
    status = transition(transition(MissionStatus(S.IDLE, 0, 3), E.ARM).status, E.START).status
    assert (status.state, status.goal_index) == (S.RUNNING, 0)
    # WHEN each goal is reached
    seen = []
    for _ in range(3):
        status = transition(status, E.GOAL_REACHED).status
        seen.append((status.state, status.goal_index))
    # THEN the index advances and the mission completes after the last goal
    assert seen == [(S.RUNNING, 1), (S.RUNNING, 2), (S.COMPLETE, 3)]
    # and a further goal_reached is rejected
    assert not transition(status, E.GOAL_REACHED).accepted


@pytest.mark.parametrize("event", [E.ARM, E.START])
def test_no_goals_cannot_arm_or_start(event: MissionEvent) -> None:
    state = S.IDLE if event is E.ARM else S.ARMED
    tr = transition(MissionStatus(state, 0, 0), event)
    assert not tr.accepted and "no goals" in tr.reason


@pytest.mark.parametrize("state", [S.RUNNING, S.HOLD, S.ARMED])
def test_mission_replaced_restarts_at_goal_zero(state: MissionState) -> None:
    tr = transition(MissionStatus(state, 2, 3), E.MISSION_REPLACED, goal_count=5)
    assert tr.accepted and (tr.status.goal_index, tr.status.goal_count) == (0, 5)


def test_mission_replaced_needs_a_goal_count() -> None:
    assert not transition(MissionStatus(S.IDLE), E.MISSION_REPLACED).accepted


def test_an_empty_mission_while_running_holds() -> None:
    tr = transition(MissionStatus(S.RUNNING, 1, 2), E.MISSION_REPLACED, goal_count=0)
    assert tr.accepted and tr.status.state is S.HOLD and "START" in tr.reason


def test_a_new_mission_keeps_a_loitering_vehicle_armed() -> None:
    tr = transition(MissionStatus(S.COMPLETE, 2, 2), E.MISSION_REPLACED, goal_count=3, complete_armed=True)
    assert tr.status.state is S.ARMED


def test_start_begins_at_the_current_goal_or_the_one_given() -> None:
    armed = MissionStatus(S.ARMED, 2, 4)
    assert transition(armed, E.START).status.goal_index == 2
    assert transition(armed, E.START, goal_index=0).status.goal_index == 0
    assert not transition(armed, E.START, goal_index=4).accepted


def test_arm_after_complete_flies_the_mission_again() -> None:
    tr = transition(MissionStatus(S.COMPLETE, 3, 3), E.ARM)
    assert tr.status.state is S.ARMED and tr.status.goal_index == 0


def test_resume_keeps_the_goal_index() -> None:
    status = MissionStatus(S.HOLD, 2, 4)
    assert transition(status, E.RESUME).status.goal_index == 2


def test_failsafe_reason_is_kept() -> None:
    tr = transition(MissionStatus(S.RUNNING, 0, 1), E.FAILSAFE, detail="depth 12.0 m beyond limit")
    assert tr.status.state is S.ABORT and "depth 12.0 m" in tr.status.reason


@pytest.mark.parametrize("event", [E.DISARM, E.DISARM_FORCED])
def test_disarm_after_complete_then_arm_and_start_flies_from_goal_zero(event: MissionEvent) -> None:
    # (found with MAVProxy: disarm in COMPLETE, arm, start was DENIED "no goal 1 to fly")
    idle = transition(MissionStatus(S.COMPLETE, 1, 1), event).status
    assert (idle.state, idle.goal_index) == (S.IDLE, 0)
    armed = transition(idle, E.ARM).status
    assert transition(armed, E.START).status.state is S.RUNNING
