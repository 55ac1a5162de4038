"""The CAN bus lost and back, judged by the one judge (issue 21, row 5): BusLost / BusBack."""

from __future__ import annotations

from onboard.core import commands as c
from onboard.core.autopilot import Autopilot
from onboard.core.mission.model import Goal, Mission
from onboard.core.mission.state import MissionState
from tests.unit.autopilot.test_autopilot import core, started, tick

S = MissionState
GOAL = Goal(20.0, 0.0, 1.0, 0.0)


def test_a_lost_bus_aborts_a_running_mission_and_its_return_disarms_keeping_the_mission() -> None:
    # GIVEN a running mission
    ap = started((GOAL,))
    assert tick(ap, 0.05).status.state is S.RUNNING
    ap.take_notes()
    # WHEN the loop says the bus is lost
    ap.note_bus("the hub closed the connection")
    # THEN the vehicle aborts with the reason, propeller 0, and START waits for the bus
    out = tick(ap, 0.1)
    assert out.status.state is S.ABORT and out.propeller_rps == 0.0
    assert "CAN bus lost (the hub closed the connection)" in out.status.reason
    assert [n.text for n in ap.take_notes() if "CAN bus lost" in n.text]
    assert ap.ready == (False, "CAN bus lost (the hub closed the connection)")
    assert not ap.actuators_live
    # WHEN the bus is back: disarmed, the same mission, ready once the sensors are
    ap.note_bus("")
    assert ap.status.state is S.IDLE and ap.mission.goals == (GOAL,) and not ap.bus_lost
    assert "CAN bus back" in ap.status.reason
    tick(ap, 0.15)
    assert ap.ready == (True, "")
    assert ap.handle(c.Arm("test")).accepted and ap.handle(c.Start(None, "test")).accepted


def test_the_bus_back_acknowledges_only_the_abort_the_loss_caused() -> None:
    ap = started((GOAL,))
    tick(ap, 0.05)
    ap.note_bus("ENETDOWN")
    ap.handle(c.Disarm(source="operator"))  # the operator acknowledged it meanwhile
    assert ap.handle(c.Abort("operator", "operator")).accepted  # and aborted again, on purpose
    ap.note_bus("")
    assert ap.status.state is S.ABORT and "operator" in ap.status.reason


def test_a_lost_bus_while_disarmed_changes_no_state_but_says_so() -> None:
    ap = Autopilot(core())
    assert ap.replace_mission(Mission((GOAL,))).accepted
    ap.take_notes()
    verdict = ap.handle(c.BusLost("CanOperationError: Network is down"))
    assert verdict.accepted and ap.status.state is S.IDLE
    arm = ap.handle(c.Arm("test"))  # nothing can be armed that cannot be reached
    assert arm.outcome is c.Outcome.TEMPORARILY_REJECTED and "CAN bus lost" in arm.reason
    notes = [n.text for n in ap.take_notes()]
    assert any("CAN bus lost (CanOperationError: Network is down)" in t for t in notes), notes
    assert ap.handle(c.BusBack()).accepted and ap.status.state is S.IDLE and not ap.bus_lost
