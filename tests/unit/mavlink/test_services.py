"""The link as a carrier: command mapping, exactly one ACK, timeouts, refusals, mission judging, notes,
heartbeat truth, parameters, GCS loss (no sockets; the loop is the test or a real Autopilot)."""

from __future__ import annotations

import math
import threading
from pathlib import Path
from typing import Any

import pytest
from pymavlink.dialects.v20 import common as mavlink
from pymavlink.mavutil import mode_string_v10

from groundstation.mavclient import state_from_heartbeat
from onboard.adapters.mavlink import commands as link_commands
from onboard.adapters.mavlink import modes
from onboard.adapters.mavlink.api import MISSION_STATES, VehicleSnapshot
from onboard.adapters.mavlink.commands import RequestQueue, map_command
from onboard.adapters.mavlink.config import MavlinkConfig
from onboard.adapters.mavlink.mission_protocol import TYPE_FENCE, TYPE_MISSION
from onboard.adapters.mavlink.storage import load_plan
from onboard.adapters.mavlink.telemetry import STATE_TABLE, system_status
from onboard.adapters.mavlink.transport import statustext_chunks
from onboard.app.store import StateStore
from onboard.core import commands as core
from onboard.core.commands import Outcome, Severity
from onboard.core.mission.state import MissionState
from onboard.core.mission.validate import MissionCheck
from onboard.core.params import ParamSpec
from onboard.protocol.conventions import body_to_ned

from .linkkit import Captured, ready_autopilot, refuse
from .test_mission_protocol import wp

NAN = math.nan
C = mavlink
SRC = "MAVLink 255/190"
FENCE = wp(command=C.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION, param1=2.0, x=50000, y=50000, z=0.0)


class Seqs:
    def __init__(self, offset: int = 0, n: int = 3) -> None:
        self._shape = (offset, n)

    def shape(self) -> tuple[int, int]:
        return self._shape


def p7(*p: float, fill: float = 0.0) -> list[float]:
    return [*map(float, p), *([fill] * (7 - len(p)))]


# ---- the mapping ----------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("cmd", "params", "expected"),
    [
        (C.MAV_CMD_COMPONENT_ARM_DISARM, p7(1), core.Arm(SRC)),
        (C.MAV_CMD_COMPONENT_ARM_DISARM, p7(0), core.Disarm(False, SRC)),
        (C.MAV_CMD_COMPONENT_ARM_DISARM, p7(0, 21196), core.Disarm(True, SRC)),
        (C.MAV_CMD_COMPONENT_ARM_DISARM, p7(0, fill=NAN), core.Disarm(False, SRC)),  # MAVSDK: unused NaN
        (C.MAV_CMD_COMPONENT_ARM_DISARM, p7(2), core.denied("param1 must be 0 or 1")),
        (C.MAV_CMD_COMPONENT_ARM_DISARM, p7(NAN), core.denied("param1 is not a number")),
        (C.MAV_CMD_MISSION_START, p7(0), core.Start(None, SRC)),
        (C.MAV_CMD_MISSION_START, p7(NAN), core.Start(None, SRC)),
        (C.MAV_CMD_MISSION_START, p7(-3), core.Start(None, SRC)),
        (C.MAV_CMD_MISSION_START, p7(2), core.Start(2, SRC)),
        (C.MAV_CMD_MISSION_START, p7(3), core.denied("no mission item 3 (the mission has 3 items)")),
        (C.MAV_CMD_MISSION_START, p7(math.inf), core.denied("param1 is not a number")),
        (C.MAV_CMD_DO_SET_MODE, p7(1, 4, 4, fill=NAN), core.SetMode("mission", SRC)),
        (C.MAV_CMD_DO_SET_MODE, p7(129, 4, 3, fill=NAN), core.SetMode("loiter", SRC)),
        (C.MAV_CMD_DO_SET_MODE, p7(1, 4, 5), core.SetMode("surface", SRC)),
        (C.MAV_CMD_DO_SET_MODE, p7(1, 4, 1), core.SetMode("ready", SRC)),
        # ArduSub's layout, what MAVProxy's `mode NAME` sends (param2 the mode number, param3 0)
        (C.MAV_CMD_DO_SET_MODE, p7(1, 3, 0), core.SetMode("mission", SRC)),
        (C.MAV_CMD_DO_SET_MODE, p7(1, 16, 0), core.SetMode("loiter", SRC)),
        (C.MAV_CMD_DO_SET_MODE, p7(1, 9, 0), core.SetMode("surface", SRC)),
        (C.MAV_CMD_DO_SET_MODE, p7(1, 19, 0), core.SetMode("ready", SRC)),
        (
            C.MAV_CMD_DO_SET_MODE,
            p7(1, 4, 0),
            core.denied("GUIDED is not a mode of this vehicle (modes: AUTO, POSHOLD, SURFACE, MANUAL)"),
        ),
        (
            C.MAV_CMD_DO_SET_MODE,
            p7(1, 7, 0),
            core.denied(
                "CIRCLE is the end of a mission with the loiter end action; "
                "modes: AUTO, POSHOLD, SURFACE, MANUAL"
            ),
        ),
        (C.MAV_CMD_DO_SET_MODE, p7(NAN, 4, 4), core.denied("param1 is not a number")),
        (C.MAV_CMD_DO_SET_MODE, p7(1, NAN, 4), core.denied("param2 is not a number")),
        (C.MAV_CMD_DO_SET_MODE, p7(1, 4, NAN), core.denied("param3 is not a number")),
        (C.MAV_CMD_DO_PAUSE_CONTINUE, p7(0), core.Hold(SRC)),
        (C.MAV_CMD_DO_PAUSE_CONTINUE, p7(1), core.Resume(SRC)),
        (C.MAV_CMD_DO_PAUSE_CONTINUE, p7(NAN), core.denied("param1 is not a number")),
        (C.MAV_CMD_NAV_RETURN_TO_LAUNCH, p7(), core.Abort("return to surface", SRC)),
        (C.MAV_CMD_DO_FLIGHTTERMINATION, p7(1), core.Abort("termination", SRC)),
        (C.MAV_CMD_DO_FLIGHTTERMINATION, p7(NAN), core.denied("param1 is not a number")),
        (C.MAV_CMD_DO_SET_MISSION_CURRENT, p7(1), core.SetCurrent(1, SRC)),
        (C.MAV_CMD_DO_SET_MISSION_CURRENT, p7(-1), core.accepted("no change")),
        (C.MAV_CMD_DO_SET_MISSION_CURRENT, p7(NAN), core.denied("param1 is not a number")),
    ],
)
def test_command_mapping(cmd: int, params: list[float], expected: object) -> None:
    assert map_command(cmd, params, Seqs(), SRC) == expected


def test_mapping_with_home_offset_and_mode_refusals() -> None:
    assert map_command(C.MAV_CMD_MISSION_START, p7(1), Seqs(1, 2), SRC) == core.Start(0, SRC)
    assert map_command(C.MAV_CMD_DO_SET_MISSION_CURRENT, p7(0), Seqs(1, 2), SRC) == core.SetCurrent(0, SRC)
    for params in (p7(0, 4, 4), p7(1, 3, 4), p7(1, 4, 9)):
        v = map_command(C.MAV_CMD_DO_SET_MODE, params, Seqs(), SRC)
        assert isinstance(v, core.Verdict) and v.outcome is Outcome.DENIED and v.reason


# ---- exactly one ACK ------------------------------------------------------------------------------
def test_nan_in_do_set_mode_gets_exactly_one_denied_ack_and_the_reason(tmp_path: Path) -> None:
    c = Captured(tmp_path)
    c.command(C.MAV_CMD_DO_SET_MODE, NAN, NAN, NAN)
    assert c.ack() == C.MAV_RESULT_DENIED
    assert c.texts() == ["param1 is not a number"] and c.link.take_requests() == []


def test_every_command_gets_one_ack_even_when_mapping_raises(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    c = Captured(tmp_path)

    def boom(*_a: object, **_k: object) -> object:
        raise ZeroDivisionError("bug")

    monkeypatch.setattr(link_commands, "map_command", boom)
    c.command(C.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    assert c.ack() == C.MAV_RESULT_FAILED and c.texts() == ["command 400 failed: ZeroDivisionError"]
    monkeypatch.undo()
    c.command(12345)  # unknown: UNSUPPORTED, no STATUSTEXT (ground stations probe)
    assert c.ack() == C.MAV_RESULT_UNSUPPORTED and c.texts() == []
    # link-only: answered by the adapter itself, then the message
    c.command(C.MAV_CMD_REQUEST_MESSAGE, C.MAVLINK_MSG_ID_AUTOPILOT_VERSION)
    assert c.ack() == C.MAV_RESULT_ACCEPTED and len(c.sent("AUTOPILOT_VERSION")) == 1
    c.command(C.MAV_CMD_SET_MESSAGE_INTERVAL, NAN, 1000)
    assert c.ack() == C.MAV_RESULT_DENIED and c.texts() == ["param1 is not a number"]


def test_command_not_taken_in_time_is_temporarily_rejected_taken_one_waits(tmp_path: Path) -> None:
    c = Captured(tmp_path)
    c.command(C.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    c.poll(0.9)
    assert c.sent("COMMAND_ACK") == []
    c.poll(0.2)  # 1.1 s: the loop is not running
    assert c.ack() == C.MAV_RESULT_TEMPORARILY_REJECTED
    assert c.texts() == ["the control loop is not running"]
    assert c.link.take_requests() == []  # answered: gone
    # a taken request is answered only by the loop, however late
    c.command(C.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    (req,) = c.link.take_requests()
    c.poll(5.0)
    assert c.sent("COMMAND_ACK") == []
    c.link.answer(req.id, core.accepted("armed"))
    c.link.answer(req.id, core.accepted("armed"))  # a second answer is ignored
    c.poll()
    assert c.ack() == C.MAV_RESULT_ACCEPTED


def test_resent_command_while_pending_is_answered_once(tmp_path: Path) -> None:
    c = Captured(tmp_path)
    c.command(C.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    c.command(C.MAV_CMD_COMPONENT_ARM_DISARM, 1)  # the GCS retries
    (req,) = c.link.take_requests()
    c.link.answer(req.id, core.accepted("armed"))
    c.poll()
    assert c.ack() == C.MAV_RESULT_ACCEPTED


def test_the_real_judge_refuses_with_its_reason_and_arm_start_flow(tmp_path: Path) -> None:
    c = Captured(tmp_path, items=(wp(10, 0, 1), wp(20, 0, 1)))
    ap = ready_autopilot()
    ap.handle(core.ReplaceMission(c.link.mission(), True, "stored"))
    ap.take_notes()
    c.command(C.MAV_CMD_MISSION_START)
    c.serve(ap)
    assert c.ack() == C.MAV_RESULT_DENIED and "arm first" in " ".join(c.texts())
    c.command(C.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    c.serve(ap)
    assert c.ack() == C.MAV_RESULT_ACCEPTED
    c.command(C.MAV_CMD_MISSION_START, 1)  # seq 1 = goal 1 (no home item)
    c.serve(ap)
    assert c.ack() == C.MAV_RESULT_ACCEPTED
    assert ap.status.state is MissionState.RUNNING and ap.status.goal_index == 1
    assert any("RUNNING" in t for t in c.texts())  # the core's transition note, not the adapter's


def test_mission_set_current_message_refusal_is_a_statustext(tmp_path: Path) -> None:
    c = Captured(tmp_path, items=(wp(10, 0, 1),))
    c.rx(C.MAVLink_mission_set_current_message(1, 1, 0))
    c.serve(lambda cmd: core.denied("COMPLETE: the current goal cannot change now"))
    assert c.texts() == ["COMPLETE: the current goal cannot change now"] and c.sent("COMMAND_ACK") == []
    c.rx(C.MAVLink_mission_set_current_message(1, 1, 7))
    assert c.texts() == ["no mission item 7 (the mission has 1 items)"]


def test_request_queue_is_thread_safe_and_answers_each_once() -> None:
    q = RequestQueue(lambda: 0.0, 1.0)
    answers: list[int] = []
    for i in range(200):
        q.submit(core.Arm(str(i)), lambda v, i=i: answers.append(i))

    def loop() -> None:
        for r in q.take():
            q.answer(r.id, core.accepted("ok"))

    ts = [threading.Thread(target=loop) for _ in range(4)]
    for t in ts:
        t.start()
    for t in ts:
        t.join()
    q.poll(0.5)
    assert sorted(answers) == list(range(200))


# ---- mission judging ------------------------------------------------------------------------------
def test_refused_by_the_validator_maps_the_field_and_names_the_item(tmp_path: Path) -> None:
    c = Captured(tmp_path, validator=refuse("goal", 2, "x", "inside obstacle 1 (inflated)"))
    c.upload([wp(1, 0, 1), wp(2, 0, 1), wp(3, 0, 1)])
    c.settle()
    assert c.mission_ack() == C.MAV_MISSION_INVALID_PARAM5_X
    assert c.texts() == ["goal 2 refused: inside obstacle 1 (inflated)"]
    assert c.link.take_requests() == [] and c.link.mission().goals == ()
    assert load_plan(StateStore(tmp_path), TYPE_MISSION) is None  # nothing persisted


@pytest.mark.parametrize(
    ("field", "code"),
    [
        ("y", C.MAV_MISSION_INVALID_PARAM6_Y),
        ("depth", C.MAV_MISSION_INVALID_PARAM7),
        ("yaw", C.MAV_MISSION_INVALID_PARAM4),
        ("radius", C.MAV_MISSION_INVALID_PARAM1),
        ("count", C.MAV_MISSION_NO_SPACE),
        ("plan", C.MAV_MISSION_ERROR),
        ("format", C.MAV_MISSION_ERROR),
    ],
)
def test_problem_field_to_mission_result(tmp_path: Path, field: str, code: int) -> None:
    c = Captured(tmp_path, validator=refuse("mission", -1, field, "no"))
    c.upload([wp()])
    c.settle()
    assert c.mission_ack() == code and c.texts() == ["mission refused: no"]


def test_accepted_by_validator_and_core_then_persisted_and_acked(tmp_path: Path) -> None:
    seen = []

    def validator(m: object) -> MissionCheck:
        seen.append(m)
        return MissionCheck()

    c = Captured(tmp_path, validator=validator, items=(wp(1, 1, 1),))
    StateStore(tmp_path).save_plan("fence", (FENCE,))
    c = Captured(tmp_path, validator=validator)
    seen.clear()  # the stored mission was checked at boot (each time a link was made)
    c.upload([wp(7, 0, 1), wp(8, 0, 1)])
    c.settle()
    assert c.sent("MISSION_ACK") == []  # with the core
    (req,) = c.link.take_requests()
    assert isinstance(req.command, core.ReplaceMission) and req.command.goals_changed
    cand = req.command.mission
    assert [g.x_m for g in cand.goals] == [7.0, 8.0] and len(cand.obstacles) == 1  # + the stored fence
    assert seen == [cand]
    c.link.answer(req.id, core.accepted("mission replaced (2 goals), goal 0"))
    c.poll()
    assert c.mission_ack() == C.MAV_MISSION_ACCEPTED and c.link.mission() == cand
    assert c.texts() == ["mission accepted: 2 goals, 1 obstacles (255/190)"]  # told to every station
    loaded = load_plan(StateStore(tmp_path), TYPE_MISSION)
    assert loaded is not None and [i.x for i in loaded] == [70000, 80000]
    # a fence upload is checked with the stored goals and does not change them
    c.upload([FENCE, FENCE], TYPE_FENCE)
    c.settle()
    (req,) = c.link.take_requests()
    assert not req.command.goals_changed and len(req.command.mission.goals) == 2  # type: ignore[union-attr]
    c.link.answer(req.id, core.denied("no"))
    c.poll()
    assert c.mission_ack() == C.MAV_MISSION_ERROR and c.texts() == ["upload refused: no"]
    assert len(c.link.mission().obstacles) == 1


def test_core_refusal_validator_failure_and_timeout_keep_the_plans(tmp_path: Path) -> None:
    c = Captured(tmp_path, items=(wp(1, 1, 1),))
    before = c.link.mission()
    c.upload([wp(2, 2, 2)])
    c.settle(lambda cmd: core.denied("mission_replaced not allowed in ABORT"))
    assert c.mission_ack() == C.MAV_MISSION_ERROR
    assert c.texts() == ["upload refused: mission_replaced not allowed in ABORT"]

    # (the stored mission is checked at boot too: these misbehave only on the upload, goal x = 2)
    def broken(m: Any) -> MissionCheck:
        if m.goals and m.goals[0].x_m == 2.0:
            raise RuntimeError("planner exploded")
        return MissionCheck()

    c2 = Captured(tmp_path, validator=broken)
    c2.upload([wp(2, 2, 2)])
    c2.settle()
    assert c2.mission_ack() == C.MAV_MISSION_ERROR and "planner exploded" in c2.texts()[0]
    gate = threading.Event()

    def slow(m: Any) -> MissionCheck:
        if m.goals and m.goals[0].x_m == 2.0:
            gate.wait(5.0)
        return MissionCheck()

    c3 = Captured(tmp_path, validator=slow)
    c3.upload([wp(2, 2, 2)])
    c3.poll(3.5)
    gate.set()
    assert c3.mission_ack() == C.MAV_MISSION_ERROR and "longer than 3 s" in c3.texts()[0]
    for x in (c, c2, c3):
        assert x.link.mission() == before and not x.link.missions.server.upload_in_progress


def test_not_taken_upload_is_refused_loop_not_running(tmp_path: Path) -> None:
    c = Captured(tmp_path)
    c.upload([wp()])
    c.settle()
    c.poll(1.5)
    assert c.mission_ack() == C.MAV_MISSION_ERROR
    assert c.texts() == ["upload refused: the control loop is not running"]


def test_clear_all_is_one_candidate_and_a_real_core_holds_when_running(tmp_path: Path) -> None:
    StateStore(tmp_path).save_plan("fence", (FENCE,))
    c = Captured(tmp_path, validator=lambda m: MissionCheck(), items=(wp(10, 0, 1), wp(20, 0, 1)))
    ap = ready_autopilot()
    ap.handle(core.ReplaceMission(c.link.mission(), True, "stored"))
    ap.handle(core.Arm())
    ap.handle(core.Start())
    assert ap.status.state is MissionState.RUNNING
    c.rx(C.MAVLink_mission_clear_all_message(1, 1, C.MAV_MISSION_TYPE_ALL))
    c.settle(ap)
    (ack,) = c.sent("MISSION_ACK")
    assert ack.type == C.MAV_MISSION_ACCEPTED and ack.mission_type == C.MAV_MISSION_TYPE_ALL
    assert c.link.mission().goals == () and c.link.mission().obstacles == ()
    assert ap.mission.goals == () and ap.status.state is MissionState.HOLD


# ---- notes, heartbeat ---------------------------------------------------------------------------
def test_notes_become_statustext_chunked_with_id_and_seq(tmp_path: Path) -> None:
    c = Captured(tmp_path)
    long = "x" * 50 + "y" * 30
    c.link.notify([core.Note(Severity.CRITICAL, "abort: depth"), core.Note(Severity.INFO, long)])
    c.poll()
    msgs = c.sent("STATUSTEXT")
    assert [(m.severity, m.id, m.chunk_seq) for m in msgs] == [
        (C.MAV_SEVERITY_CRITICAL, 0, 0),
        (C.MAV_SEVERITY_INFO, 1, 0),
        (C.MAV_SEVERITY_INFO, 1, 1),
    ]
    assert "".join(m.text for m in msgs[1:]) == long
    exact = statustext_chunks("z" * 100, 7)
    assert [(len(t), i, s) for t, i, s in exact] == [(50, 7, 0), (50, 7, 1), (0, 7, 2)]


@pytest.mark.parametrize(
    ("snap", "status", "armed_flag"),
    [
        (VehicleSnapshot(), C.MAV_STATE_BOOT, False),
        (VehicleSnapshot(ready=True), C.MAV_STATE_STANDBY, False),
        (VehicleSnapshot(ready=True, armed=True, state=MissionState.ARMED), C.MAV_STATE_ACTIVE, True),
        (VehicleSnapshot(ready=False, armed=True, state=MissionState.HOLD), C.MAV_STATE_ACTIVE, True),
        # COMPLETE with end_action surface: not armed, whatever the state name suggests
        (VehicleSnapshot(ready=True, armed=False, state=MissionState.COMPLETE), C.MAV_STATE_STANDBY, False),
        (VehicleSnapshot(ready=True, state=MissionState.ABORT), C.MAV_STATE_CRITICAL, False),
        (
            VehicleSnapshot(ready=True, armed=True, state=MissionState.ARMED, failsafe="depth"),
            C.MAV_STATE_CRITICAL,
            True,
        ),
    ],
)
def test_heartbeat_tells_the_truth(
    tmp_path: Path, snap: VehicleSnapshot, status: int, armed_flag: bool
) -> None:
    assert system_status(snap) == status
    c = Captured(tmp_path)
    c.link.publish(snap)
    c.link.telemetry.send_message(C.MAVLINK_MSG_ID_HEARTBEAT)
    (hb,) = c.sent("HEARTBEAT")
    assert bool(hb.base_mode & C.MAV_MODE_FLAG_SAFETY_ARMED) is armed_flag and hb.system_status == status
    # the mode by ArduSub's name (what MAVProxy shows), and the ground station reads the state back from it
    assert mode_string_v10(hb) == modes.mode_name(modes.custom_mode(snap.state, snap.armed))
    assert not mode_string_v10(hb).startswith("Mode(")
    assert state_from_heartbeat(hb) == snap.state.name


def test_state_table_covers_the_vocabulary() -> None:
    assert set(STATE_TABLE) == set(MissionState)
    assert MISSION_STATES == ("IDLE", "ARMED", "RUNNING", "HOLD", "ABORT", "COMPLETE")


_S = MissionState


@pytest.mark.parametrize(
    ("state", "armed"),
    [(_S.IDLE, False), (_S.ARMED, True), (_S.RUNNING, True), (_S.HOLD, True), (_S.ABORT, False),
     (_S.ABORT, True), (_S.COMPLETE, False), (_S.COMPLETE, True)],
)  # fmt: skip
def test_every_state_reads_back_from_its_heartbeat(tmp_path: Path, state: MissionState, armed: bool) -> None:
    c = Captured(tmp_path)
    c.link.publish(VehicleSnapshot(ready=True, armed=armed, state=state))
    c.link.telemetry.send_message(C.MAVLINK_MSG_ID_HEARTBEAT)
    (hb,) = c.sent("HEARTBEAT")
    assert state_from_heartbeat(hb) == state.name
    assert mode_string_v10(hb) in {"MANUAL", "AUTO", "POSHOLD", "CIRCLE", "SURFACE"}


def test_body_to_ned() -> None:
    assert body_to_ned(0, 0, 0, 1, 2, 3) == pytest.approx((1, 2, 3))
    assert body_to_ned(0, 0, math.pi / 2, 1, 0, 0) == pytest.approx((0, 1, 0), abs=1e-12)
    assert body_to_ned(0, math.pi / 2, 0, 1, 0, 0) == pytest.approx((0, 0, -1), abs=1e-12)  # nose up
    assert all(math.isnan(v) for v in body_to_ned(NAN, 0, 0, 1, 0, 0))


# ---- parameters ---------------------------------------------------------------------------------
SPECS = (
    ParamSpec("A", 1.0, 0.0, 2.0, "", "a", "x.a"),
    ParamSpec("B", 0.1, 0.0, 2.0, "", "b", "x.b"),
)


def param_set(c: Captured, name: str, value: float) -> None:
    c.rx(C.MAVLink_param_set_message(1, 1, name.encode(), value, C.MAV_PARAM_TYPE_REAL32))


def test_param_set_through_the_core_persisted_only_when_not_default(tmp_path: Path) -> None:
    c = Captured(tmp_path, params=SPECS)
    param_set(c, "NOPE", 1.0)
    assert c.texts() == ["unknown parameter NOPE"] and c.sent("PARAM_VALUE") == []
    param_set(c, "A", 1.5)
    (req,) = c.link.take_requests()
    assert req.command == core.SetParam("A", 1.5, SRC)
    c.link.answer(req.id, core.accepted("A = 1.5", value=1.5))
    c.poll()
    (pv,) = c.sent("PARAM_VALUE")
    assert pv.param_value == 1.5 and StateStore(tmp_path).load_params() == {"A": 1.5}
    param_set(c, "A", 9.0)
    (req,) = c.link.take_requests()
    c.link.answer(req.id, core.denied("A=9 refused: above 2", value=1.5))
    c.poll()
    assert c.sent("PARAM_VALUE")[0].param_value == 1.5 and c.texts() == ["A=9 refused: above 2"]
    param_set(c, "B", 0.1)  # back at the default (compared in float32): nothing new persisted
    (req,) = c.link.take_requests()
    c.link.answer(req.id, core.accepted("B = 0.1", value=0.10000000149011612))
    c.poll()
    assert StateStore(tmp_path).load_params() == {"A": 1.5} and len(c.sent("PARAM_VALUE")) == 1
    param_set(c, "A", NAN)
    assert c.link.take_requests() == [] and c.texts() == ["A: the value is not a number"]
    assert c.sent("PARAM_VALUE")[0].param_value == 1.5
    param_set(c, "A", 1.0)  # not taken in time: the value in force and the reason
    c.poll(2.0)
    assert c.sent("PARAM_VALUE")[0].param_value == 1.5 and c.texts() == ["the control loop is not running"]


def test_persisted_edits_go_to_the_core_at_start(tmp_path: Path) -> None:
    StateStore(tmp_path).save_params({"A": 1.25, "GONE": 3.0})
    c = Captured(tmp_path, params=SPECS)
    (req,) = c.link.take_requests()
    assert req.command == core.SetParam("A", 1.25, "persisted edit")
    c.poll(10.0)  # never timed out: it waits for the loop
    c.link.answer(req.id, core.accepted("A = 1.25", value=1.25))
    c.poll()
    assert c.link.params.value("A") == 1.25
    given = Captured(tmp_path / "x", params=SPECS, param_values={"A": 0.5})
    assert given.link.take_requests() == [] and given.link.params.value("A") == 0.5


def test_no_param_or_mission_answer_until_the_persisted_edits_are_in_force(tmp_path: Path) -> None:
    # GIVEN a link alone (no values in force given) with a persisted edit handed to the core
    StateStore(tmp_path).save_params({"A": 1.25})
    c = Captured(tmp_path, params=SPECS)
    c.link.transport.reply = lambda m, _to: c.out.append(m)  # type: ignore[method-assign]
    (req,) = c.link.take_requests()
    # WHEN a station asks for the list, one value, and the mission before the core has judged the edit
    c.rx(mavlink.MAVLink_param_request_list_message(1, 1))
    c.rx(mavlink.MAVLink_param_request_read_message(1, 1, b"A", -1))
    c.rx(mavlink.MAVLink_mission_request_list_message(1, 1, TYPE_MISSION))
    # THEN nothing is answered (no table default served for a value not in force) ...
    assert c.link.params.booting and c.out == []
    # ... and once the edit is in force, the value served is it
    c.link.answer(req.id, core.accepted("A = 1.25", value=1.25))
    c.poll()
    assert not c.link.params.booting
    c.rx(mavlink.MAVLink_param_request_read_message(1, 1, b"A", -1))
    (pv,) = c.sent("PARAM_VALUE")
    assert pv.param_value == 1.25
    c.rx(mavlink.MAVLink_mission_request_list_message(1, 1, TYPE_MISSION))
    assert len(c.sent("MISSION_COUNT")) == 1


# ---- GCS loss ---------------------------------------------------------------------------------------
def test_gcs_loss_is_a_request_and_regain_a_statustext(tmp_path: Path) -> None:
    cfg = MavlinkConfig(gcs_timeout_s=0.5, gcs_loss_action="hold")
    c = Captured(tmp_path, config=cfg)
    hb = C.MAVLink_heartbeat_message(C.MAV_TYPE_GCS, C.MAV_AUTOPILOT_INVALID, 0, 0, 0, 3)
    c.rx(hb)
    c.poll(0.6)
    (req,) = c.link.take_requests()
    assert req.command == core.LinkLost("hold", "MAVLink GCS watch")
    assert c.texts() == ["GCS heartbeat lost: action hold"]
    c.link.answer(req.id, core.accepted("holding"))
    c.rx(hb)
    c.poll()
    assert c.texts() == ["GCS link regained"]


def test_quarantined_files_announced_when_a_gcs_connects(tmp_path: Path) -> None:
    (tmp_path / "fence.json").write_text("{broken")
    c = Captured(tmp_path)
    assert c.link.mission().obstacles == ()
    hb = C.MAVLink_heartbeat_message(C.MAV_TYPE_GCS, C.MAV_AUTOPILOT_INVALID, 0, 0, 0, 3)
    c.rx(hb)
    (text,) = c.texts()
    assert text.startswith("fence.json was invalid")
    c.rx(hb)
    assert c.texts() == []  # once


def test_progress_persisted_when_the_current_goal_changes(tmp_path: Path) -> None:
    c = Captured(tmp_path, items=(wp(10, 0, 1), wp(20, 0, 1), wp(30, 0, 1)))
    assert c.link.progress() is None
    c.poll()  # nothing published yet: nothing saved
    goals = c.link.mission().goals
    c.link.publish(VehicleSnapshot(state=MissionState.RUNNING, current_goal=1, mission_goals=()))
    c.poll()  # the progress of another mission (a snapshot from before this one was taken): not saved
    assert Captured(tmp_path).link.progress() is None
    c.link.publish(VehicleSnapshot(state=MissionState.RUNNING, current_goal=2, mission_goals=goals))
    c.poll()
    assert Captured(tmp_path).link.progress() == 2


def test_a_different_command_while_one_is_pending_is_its_own_request_a_resend_is_not(tmp_path: Path) -> None:
    c = Captured(tmp_path)
    c.command(C.MAV_CMD_COMPONENT_ARM_DISARM, 1.0)
    c.command(C.MAV_CMD_COMPONENT_ARM_DISARM, 1.0)  # a resend: answered by the first one's ACK
    c.command(C.MAV_CMD_COMPONENT_ARM_DISARM, 0.0)  # a disarm right after: a command of its own
    reqs = c.link.take_requests()
    assert [type(r.command).__name__ for r in reqs] == ["Arm", "Disarm"]
    for r in reqs:
        c.link.answer(r.id, core.accepted("ok"))
    c.poll()
    assert len(c.sent("COMMAND_ACK")) == 2


def test_a_stored_mission_that_cannot_be_checked_at_boot_is_set_aside(tmp_path: Path) -> None:
    def broken(_m: object) -> MissionCheck:
        raise RuntimeError("planner exploded")

    c = Captured(tmp_path, validator=broken, items=(wp(1, 1, 1),))
    assert c.link.mission().goals == ()
    (line,) = c.link.store.quarantined()
    assert "could not be checked" in line and "planner exploded" in line
