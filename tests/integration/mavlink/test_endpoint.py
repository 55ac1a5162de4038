"""The vehicle link over real UDP on 127.0.0.1 with the ground-station client; the fake loop runs the real
judge (``Autopilot.handle``) over a fake plant."""

from __future__ import annotations

import math
import threading
import time
from pathlib import Path

import pytest
from pymavlink.dialects.v20 import common as mavlink

from groundstation.mavclient import MavClient, state_from_heartbeat
from groundstation.mission_files import goal_item, obstacle_item
from onboard.adapters.mavlink import api
from onboard.adapters.mavlink.endpoint import CAPABILITIES
from onboard.app.standalone import make_link
from onboard.app.store import StateStore
from onboard.core import commands as core
from onboard.core.mission.model import Goal, Mission
from tests.integration.mavlink.conftest import Vehicle

GOALS = [goal_item(10.0, 0.0, 1.0, None), goal_item(10.0, 10.0, 2.0, 90.0)]


def wait_for(
    client: MavClient, kind: str, timeout_s: float = 3.0, pred=lambda m: True
) -> mavlink.MAVLink_message:
    t_end = time.monotonic() + timeout_s
    while time.monotonic() < t_end:
        m = client.recv(0.1)
        if m is not None and m.get_type() == kind and pred(m):
            return m
    raise AssertionError(f"no {kind} within {timeout_s} s")


def test_heartbeat_and_autopilot_version(vehicle: Vehicle) -> None:
    with vehicle.client() as c:
        hb = wait_for(c, "HEARTBEAT", pred=lambda m: m.get_srcSystem() == 1)
        assert hb.type == mavlink.MAV_TYPE_SUBMARINE and hb.autopilot == mavlink.MAV_AUTOPILOT_GENERIC
        assert hb.get_srcComponent() == 1 and state_from_heartbeat(hb) == "IDLE"
        assert c.command(mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION) == 0
        av = wait_for(c, "AUTOPILOT_VERSION")
        assert av.capabilities == CAPABILITIES
        assert av.capabilities & mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_INT
        assert c.command(mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN) == 0
        origin = wait_for(c, "GPS_GLOBAL_ORIGIN")
        assert origin.latitude == round(vehicle.config.origin_lat_deg * 1e7)
        assert c.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_ATTITUDE, 20_000) == 0
        assert c.command(12345) == mavlink.MAV_RESULT_UNSUPPORTED


def test_commands_judged_by_the_core_with_reasons(vehicle: Vehicle) -> None:
    with vehicle.client() as c:
        assert c.command(mavlink.MAV_CMD_MISSION_START) == mavlink.MAV_RESULT_DENIED  # no goals
        assert c.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1.0) == mavlink.MAV_RESULT_DENIED
        wait_for(c, "STATUSTEXT", pred=lambda m: "no goals" in m.text)  # the core's reason
        assert c.upload(GOALS).ok
        assert c.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1.0) == 0
        assert c.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1.0) == 0  # already armed
        hb = wait_for(c, "HEARTBEAT", pred=lambda m: state_from_heartbeat(m) == "ARMED")
        assert (
            hb.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED and hb.system_status == mavlink.MAV_STATE_ACTIVE
        )
        assert c.command(mavlink.MAV_CMD_MISSION_START) == 0
        seen: list[str] = []
        t_end = time.monotonic() + 30.0  # generous: the run-in to the last goal slows to the arrival speed
        while time.monotonic() < t_end and not {"reached 1", "text COMPLETE"} <= set(seen):
            m = c.recv(0.1)
            if m is not None and m.get_type() == "MISSION_ITEM_REACHED":
                seen.append(f"reached {m.seq}")
            elif m is not None and m.get_type() == "STATUSTEXT" and "COMPLETE" in m.text:
                seen.append("text COMPLETE")
        assert "reached 0" in seen and "reached 1" in seen and "text COMPLETE" in seen
        cur = wait_for(c, "MISSION_CURRENT")
        assert cur.total == 2 and cur.mission_state == mavlink.MISSION_STATE_COMPLETE
        assert c.command(mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH) == 0
        wait_for(c, "HEARTBEAT", pred=lambda m: state_from_heartbeat(m) == "ABORT")
        assert c.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1.0) == mavlink.MAV_RESULT_DENIED


def test_mavsdk_style_mode_change_starts_mission_and_set_current(vehicle: Vehicle) -> None:
    with vehicle.client() as c:
        assert c.upload([goal_item(400.0, 400.0, 1.0, None), goal_item(-400, 0, 1, None)]).ok
        assert c.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1.0) == 0
        assert c.command(mavlink.MAV_CMD_DO_SET_MODE, 1, 4, 4) == 0  # PX4 AUTO/MISSION, as MAVSDK sends
        wait_for(c, "HEARTBEAT", pred=lambda m: state_from_heartbeat(m) == "RUNNING")
        assert c.command(mavlink.MAV_CMD_DO_SET_MISSION_CURRENT, 1) == 0
        wait_for(c, "MISSION_CURRENT", pred=lambda m: m.seq == 1)
        assert c.command(mavlink.MAV_CMD_DO_SET_MISSION_CURRENT, 5) == mavlink.MAV_RESULT_DENIED
        assert c.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0.0) == mavlink.MAV_RESULT_DENIED  # not forced
        assert c.command(mavlink.MAV_CMD_DO_PAUSE_CONTINUE, 0) == 0
        wait_for(c, "HEARTBEAT", pred=lambda m: state_from_heartbeat(m) == "HOLD")


def test_upload_download_fence_clear(vehicle: Vehicle) -> None:
    with vehicle.client() as c:
        assert c.upload(GOALS).ok
        assert c.upload([obstacle_item(5.0, 5.0, 2.0)], mavlink.MAV_MISSION_TYPE_FENCE).ok
        got = c.download()
        assert [(i.x, i.y, i.z) for i in got] == [(g.x, g.y, g.z) for g in GOALS]
        assert math.isnan(got[0].param4) and got[1].param4 == 90.0
        assert len(c.download(mavlink.MAV_MISSION_TYPE_FENCE)) == 1
        m = vehicle.link.mission()
        assert len(m.goals) == 2 and m.obstacles[0].radius_m == 2.0
        bad = c.upload([goal_item(10, 0, 1, None), goal_item(600, 0, 1, None)])
        assert not bad.ok and bad.result_name == "MAV_MISSION_INVALID_PARAM5_X"
        assert len(vehicle.link.mission().goals) == 2  # unchanged
        assert c.clear(mavlink.MAV_MISSION_TYPE_ALL).ok
        assert c.download() == [] and vehicle.link.mission().obstacles == ()


def test_params_set_refuse_persist(tmp_path: Path) -> None:
    v = Vehicle(tmp_path / "s").start()
    try:
        with v.client() as c:
            assert len(c.param_list()) == len(v.link.params.specs)
            ok, val = c.param_set("PD_KP5", 0.25)
            assert ok and val == pytest.approx(0.25)
            assert v.loop.ap.config.control.gains.Kp5 == pytest.approx(0.25)  # the core applied it
            ok, val = c.param_set("PD_KP5", 555.0)  # out of range: refused by the core, value in force
            assert not ok and val == pytest.approx(0.25)
            assert c.param_get("PD_KP5") == pytest.approx(0.25)
    finally:
        v.stop()
    v2 = make_link(v.config, store=StateStore(v.state_dir))  # the persisted edit goes to the core at start
    (req,) = v2.take_requests()
    assert req.command == core.SetParam("PD_KP5", pytest.approx(0.25), "persisted edit")


def test_mission_persisted_and_initial_mission_wins(tmp_path: Path) -> None:
    v = Vehicle(tmp_path / "s").start()
    try:
        with v.client() as c:
            assert c.upload(GOALS).ok
    finally:
        v.stop()
    stored = StateStore(v.state_dir)
    assert [g.x_m for g in make_link(v.config, store=stored).mission().goals] == [10.0, 10.0]
    given = Mission(goals=(Goal(1.0, 2.0, 3.0, None),))
    wins = make_link(v.config, initial_mission=given, store=stored)
    assert wins.mission().goals == given.goals
    assert make_link(v.config, store=stored).mission().goals == given.goals  # and it was persisted


def test_gcs_heartbeat_loss_is_a_request_and_regain_a_statustext(tmp_path: Path) -> None:
    v = Vehicle(tmp_path / "s", gcs_timeout_s=0.5, gcs_loss_action="hold").start(with_loop=False)
    try:
        c = v.client()
        c.close()  # the GCS goes silent
        t_end = time.monotonic() + 3.0
        reqs: list[api.Request] = []
        while time.monotonic() < t_end and not reqs:
            reqs += v.link.take_requests()
            time.sleep(0.05)
        assert [r.command for r in reqs] == [core.LinkLost("hold", "MAVLink GCS watch")]
        v.link.answer(reqs[0].id, core.accepted("holding"))
        with v.client() as c2:
            wait_for(c2, "STATUSTEXT", pred=lambda m: m.text == "GCS link regained")
    finally:
        v.stop()


def test_the_loop_api_keeps_only_the_latest_state_and_never_blocks(tmp_path: Path) -> None:
    # GIVEN a running link with a ground station on it, this test in the loop's place
    vehicle = Vehicle(tmp_path / "s").start(with_loop=False)
    link = vehicle.link
    try:
        with vehicle.client() as c:
            # WHEN the loop publishes 10,000 ticks and takes requests after each (its cost per tick is
            # measured by auv-bench, section loop: link_publish_take_us)
            taken = []
            for i in range(10_000):
                link.publish(api.VehicleSnapshot(t_s=i * 0.05))
                taken += link.take_requests()
            # THEN nothing queued up: the link holds the latest state only, no request was made up, and
            # the ground station is still served
            assert link.telemetry.snapshot().t_s == 9_999 * 0.05
            assert taken == []
            wait_for(c, "HEARTBEAT", pred=lambda m: m.get_srcSystem() == 1)
    finally:
        vehicle.stop()


def test_threads_do_not_leak(tmp_path: Path) -> None:
    before = threading.active_count()
    v = Vehicle(tmp_path / "s").start()
    v.stop()
    assert threading.active_count() <= before


def test_a_persisted_mission_that_fails_the_mission_check_is_set_aside_at_boot(tmp_path: Path) -> None:
    # GIVEN a well-formed persisted mission whose goal lies below the failsafe depth (20 m), and its fence
    from onboard.adapters.mavlink.mission_protocol import items_from_mission
    from onboard.core.mission.model import Goal, Mission, Obstacle
    from tests.integration.mavlink.conftest import Vehicle

    state = tmp_path / "state"
    goals, fence = items_from_mission(Mission((Goal(10.0, 0.0, 25.0, None),), (Obstacle(0.0, 30.0, 1.0),)))
    StateStore(state).save_plan("mission", goals)
    StateStore(state).save_plan("fence", fence)
    # WHEN the vehicle boots
    v = Vehicle(state)
    # THEN it boots with no mission, both files are moved aside (kept), and the reason is recorded for the GCS
    assert v.link.mission().goals == () and v.link.mission().obstacles == ()
    assert v.loop.ap.mission.goals == ()
    lines = v.link.store.quarantined()
    assert len(lines) == 2 and all("depth 25" in line for line in lines)
    assert sorted(p.name.split(".invalid-")[0] for p in state.glob("*.invalid-*")) == [
        "fence.json",
        "mission.json",
    ]
