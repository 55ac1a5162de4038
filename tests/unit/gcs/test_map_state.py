"""The map's pure state: the vehicle's MAVLink messages -> the picture the page draws (no browser)."""

from __future__ import annotations

import json
import math
from typing import Any

import pytest
from pymavlink.dialects.v20 import common as mavlink

from auv_common import mavlink_ftp as ftp
from groundstation.map.state import (
    GEOFENCE_BIT,
    PLANNED_PATH_FILE,
    STALE_AFTER_S,
    FileReadRecorder,
    MapModel,
    PlanRecorder,
    Sent,
    goals_of,
    messages_of,
    mission_state,
    obstacles_of,
    parse_planned,
    picture_at,
    replay_pictures,
    update_for,
    wrap_deg,
    yaw_error_deg,
)
from groundstation.mission_client import Item
from groundstation.mission_files import fence_circle_item, goal_item, home_item, obstacle_item
from onboard.adapters.mavlink.modes import custom_mode
from onboard.core.mission.state import MissionState

VEHICLE = (1, 1)
GCS = (255, 190)
T0 = 1_800_000_000.0  # unix s
MISSION, FENCE = mavlink.MAV_MISSION_TYPE_MISSION, mavlink.MAV_MISSION_TYPE_FENCE
LOCAL, WAYPOINT = mavlink.MAV_FRAME_LOCAL_NED, mavlink.MAV_CMD_NAV_WAYPOINT
EXCLUSION = mavlink.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION


def wire(msg: Any, src: tuple[int, int] = VEHICLE) -> Any:
    """``msg`` as it arrives: packed by ``src`` and decoded (float32 fields, source ids in the header)."""
    buf = msg.pack(mavlink.MAVLink(None, srcSystem=src[0], srcComponent=src[1]))
    return mavlink.MAVLink(None).decode(bytearray(buf))


def heartbeat(state: MissionState = MissionState.RUNNING, *, armed: bool = True, src=VEHICLE) -> Any:
    """The vehicle's HEARTBEAT in ``state``, encoded by the vehicle's one table of modes."""
    base = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | (mavlink.MAV_MODE_FLAG_SAFETY_ARMED if armed else 0)
    status = mavlink.MAV_STATE_CRITICAL if state is MissionState.ABORT else mavlink.MAV_STATE_ACTIVE
    return wire(
        mavlink.MAVLink_heartbeat_message(
            mavlink.MAV_TYPE_SUBMARINE,
            mavlink.MAV_AUTOPILOT_GENERIC,
            base,
            custom_mode(state, armed),
            status,
            3,
        ),
        src,
    )


def gcs_heartbeat() -> Any:
    return wire(
        mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 4, 3),
        GCS,
    )


def position(x_m: float, y_m: float, depth_m: float = 1.0, t_ms: int = 0, src=VEHICLE) -> Any:
    return wire(mavlink.MAVLink_local_position_ned_message(t_ms, x_m, y_m, depth_m, 0.6, 0.8, 0.0), src)


def attitude(yaw_rad: float) -> Any:
    return wire(mavlink.MAVLink_attitude_message(0, 0.0, 0.0, yaw_rad, 0.0, 0.0, 0.0))


def nav(xtrack_m: float, depth_err_m: float, nav_deg: int, target_deg: int, dist_m: int) -> Any:
    return wire(
        mavlink.MAVLink_nav_controller_output_message(
            0.0, 0.0, nav_deg, target_deg, dist_m, depth_err_m, 0.0, xtrack_m
        )
    )


def mission_current(seq: int, total: int, state: int = mavlink.MISSION_STATE_ACTIVE) -> Any:
    return wire(mavlink.MAVLink_mission_current_message(seq, total, state, 1))


def sys_status(fence: bool) -> Any:
    bits = GEOFENCE_BIT if fence else 0
    return wire(mavlink.MAVLink_sys_status_message(bits, bits, bits, 250, 0, -1, -1, 0, 0, 0, 0, 0, 0))


def statustext(text: str, severity: int = mavlink.MAV_SEVERITY_INFO, chunk_id: int = 0, seq: int = 0) -> Any:
    return wire(mavlink.MAVLink_statustext_message(severity, text.encode(), chunk_id, seq))


def running_model() -> MapModel:
    m = MapModel()
    m.apply(T0, heartbeat())
    return m


# ---- decoding --------------------------------------------------------------------------------------------
S = MissionState


@pytest.mark.parametrize(
    ("state", "armed"),
    [(S.IDLE, False), (S.ARMED, True), (S.RUNNING, True), (S.HOLD, True), (S.ABORT, False), (S.ABORT, True),
     (S.COMPLETE, False), (S.COMPLETE, True)],
)  # fmt: skip
def test_mission_state_is_the_heartbeat_owner_s_decoding(state: MissionState, armed: bool) -> None:
    # GIVEN a HEARTBEAT as the vehicle sends it in this state (its one table of modes)
    hb = heartbeat(state, armed=armed)
    # THEN the map names the state as the ground station's one decoder does: the vehicle's state
    assert mission_state(hb, mission_current(0, 1)) == state.name


@pytest.mark.parametrize(
    ("nav_deg", "target_deg", "want"),
    [(0, 10, 10.0), (10, 0, -10.0), (350, 10, 20.0), (10, 350, -20.0), (0, 180, -180.0), (-170, 170, -20.0)],
)
def test_yaw_error_is_target_minus_nav_bearing_wrapped(nav_deg: int, target_deg: int, want: float) -> None:
    assert yaw_error_deg(nav(0.0, 0.0, nav_deg, target_deg, 5)) == pytest.approx(want)


@pytest.mark.parametrize(
    ("angle", "want"), [(180.0, -180.0), (-180.0, -180.0), (540.0, -180.0), (359.0, -1.0)]
)
def test_wrap_deg(angle: float, want: float) -> None:
    assert wrap_deg(angle) == pytest.approx(want)


def test_goals_are_decoded_by_the_mission_files_owner_with_their_seq() -> None:
    # GIVEN a mission of two local goals (one with a yaw) and an item in a global frame between them
    global_item = Item(mavlink.MAV_FRAME_GLOBAL_INT, mavlink.MAV_CMD_NAV_WAYPOINT, 0, 0, 0, 0, 1, 2, -3.0)
    items = [goal_item(12.5, -3.25, 2.0, 90.0), global_item, goal_item(30.0, 20.0, 1.0, None)]
    # WHEN decoded for the map
    goals = goals_of(items)
    # THEN the local goals come out in metres with their MAVLink seq and goal index (no home placeholder:
    # the same); the global one is not drawn (no origin given)
    assert goals == [
        {"seq": 0, "index": 0, "x_m": 12.5, "y_m": -3.25, "depth_m": 2.0, "yaw_deg": 90.0, "radius_m": 0.0},
        {"seq": 2, "index": 2, "x_m": 30.0, "y_m": 20.0, "depth_m": 1.0, "yaw_deg": None, "radius_m": 0.0},
    ]
    assert goals_of([]) == []


def test_obstacles_are_the_local_exclusion_circles() -> None:
    other = Item(
        mavlink.MAV_FRAME_LOCAL_NED, mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION, 4, 0, 0, 0, 0, 0, 0
    )
    got = obstacles_of([obstacle_item(20.0, 5.0, 1.5), other, obstacle_item(-1.0, -2.0, 3.0)])
    assert got == [{"x_m": 20.0, "y_m": 5.0, "radius_m": 1.5}, {"x_m": -1.0, "y_m": -2.0, "radius_m": 3.0}]


# ---- the planned path file -------------------------------------------------------------------------------
def test_parse_planned_reads_the_vehicle_s_file() -> None:
    raw = json.dumps(
        {"version": 3, "kind": "goal", "goal_index": 1, "frame": "local_ned",
         "length_m": 2.9, "points_m": [[0, 0, 1], [1.23456, 2.5, 1.5]]}
    ).encode()  # fmt: skip
    assert parse_planned(raw) == {
        "version": 3,
        "kind": "goal",
        "goal_index": 1,
        "length_m": 2.9,
        "points_m": [[0.0, 0.0, 1.0], [1.235, 2.5, 1.5]],
    }


def test_parse_planned_of_no_path_has_no_points() -> None:
    raw = b'{"version": 0, "kind": "", "goal_index": -1, "frame": "local_ned", "points_m": []}'
    assert parse_planned(raw)["points_m"] == [] and parse_planned(raw)["kind"] == ""
    assert parse_planned(raw)["length_m"] is None


@pytest.mark.parametrize(
    "raw",
    [
        b"not json",
        b"\xff\xfe",
        b"[1, 2]",
        b'{"frame": "global", "points_m": []}',
        b'{"points_m": {"a": 1}}',
        b'{"points_m": [[1, 2, 3, 4]]}',
        b'{"points_m": [[1, "2", 3]]}',
        b'{"points_m": [[1, true, 3]]}',
        b'{"points_m": [[1, NaN, 3]]}',
    ],
)
def test_parse_planned_refuses_a_bad_file_with_a_reason(raw: bytes) -> None:
    with pytest.raises(ValueError, match=PLANNED_PATH_FILE):
        parse_planned(raw)


# ---- the model -------------------------------------------------------------------------------------------
def test_nothing_counts_before_the_vehicle_s_heartbeat_nor_from_another_system() -> None:
    # GIVEN a model that has heard no vehicle yet
    m = MapModel()
    m.apply(T0, position(1.0, 2.0))
    m.apply(T0, gcs_heartbeat())
    t = m.telemetry(T0)
    assert m.vehicle is None and t["vehicle"] is None and t["link"].startswith("waiting")
    # WHEN the vehicle's heartbeat comes, then a position of another system and one of the vehicle
    m.apply(T0 + 0.1, heartbeat(MissionState.RUNNING))
    m.apply(T0 + 0.2, position(50.0, 50.0, src=(2, 1)))
    m.apply(T0 + 0.3, position(3.0, 4.0, 1.5, t_ms=300))
    t = m.telemetry(T0 + 0.4)
    # THEN only the vehicle's own position is shown
    assert m.vehicle == VEHICLE and t["link"] == "ok" and t["state"] == "RUNNING" and t["armed"] is True
    assert t["vehicle"]["x_m"] == pytest.approx(3.0) and t["vehicle"]["y_m"] == pytest.approx(4.0)
    assert t["vehicle"]["depth_m"] == pytest.approx(1.5) and t["vehicle"]["time_boot_ms"] == 300
    assert t["vehicle"]["speed_mps"] == pytest.approx(1.0, abs=1e-6)
    assert m.track == [[3.0, 4.0, 1.5]]


def test_telemetry_carries_heading_goal_and_errors_and_is_strict_json() -> None:
    m = running_model()
    m.apply(T0, position(1.0, 2.0))
    m.apply(T0, attitude(-math.pi / 2))
    m.apply(T0, nav(0.25, -0.5, 350, 10, 17))
    m.apply(T0, mission_current(1, 2))
    t = m.telemetry(T0 + 0.5)
    assert t["vehicle"]["yaw_deg"] == pytest.approx(270.0)
    assert t["goal"] == {"seq": 1, "index": 1, "total": 2, "mission_state": "MISSION_STATE_ACTIVE"}
    assert t["errors"] == {
        "goal_distance_m": 17.0,
        "cross_track_m": pytest.approx(0.25),
        "depth_error_m": pytest.approx(-0.5),
        "yaw_error_deg": pytest.approx(20.0),
    }
    json.dumps(t, allow_nan=False)


def test_unknown_values_are_none_not_nan() -> None:
    # GIVEN the vehicle not running: NaN cross-track and depth error, NaN yaw, NaN depth
    m = running_model()
    m.apply(T0, position(1.0, 2.0, math.nan))
    m.apply(T0, attitude(math.nan))
    m.apply(T0, nav(math.nan, math.nan, 0, 0, 0))
    t = m.telemetry(T0)
    # THEN they are None (the page shows "-") and the record is valid JSON
    assert t["errors"]["cross_track_m"] is None and t["errors"]["depth_error_m"] is None
    assert t["vehicle"]["yaw_deg"] is None and t["vehicle"]["depth_m"] is None
    json.dumps(m.picture(T0).telemetry, allow_nan=False)


def test_a_position_of_nan_draws_no_vehicle_and_no_track() -> None:
    m = running_model()
    m.apply(T0, position(math.nan, 0.0))
    assert m.telemetry(T0)["vehicle"] is None and m.track == []


def test_link_is_stale_after_silence() -> None:
    m = running_model()
    assert m.telemetry(T0 + STALE_AFTER_S - 0.1)["link"] == "ok"
    assert m.telemetry(T0 + STALE_AFTER_S + 1.0)["link"] == "no message for 4 s"


def test_track_keeps_a_point_per_step_and_halves_at_its_cap() -> None:
    # GIVEN a model with room for 10 track points
    m = MapModel(track_max_points=10)
    m.apply(T0, heartbeat())
    # WHEN the vehicle reports 1 cm steps (below the track step), then 1 m steps
    for i in range(5):
        m.apply(T0, position(i * 0.01, 0.0))
    assert len(m.track) == 1
    old = m.track
    for i in range(1, 11):
        m.apply(T0, position(float(i), 0.0))
    # THEN at the 11th point the older half was dropped, into a new list and a new epoch
    assert m.track_epoch == 1 and len(m.track) == 6 and m.track[-1][0] == 10.0
    assert len(old) == 10  # a picture taken before keeps its track whole


def test_plans_set_bump_the_version_only_when_they_change() -> None:
    m = running_model()
    m.set_plan(mavlink.MAV_MISSION_TYPE_MISSION, [goal_item(5.0, 0.0, 1.0, 0.0)])
    m.set_plan(mavlink.MAV_MISSION_TYPE_FENCE, [obstacle_item(2.0, 4.0, 1.5)])
    v = m.plan_version
    m.set_plan(mavlink.MAV_MISSION_TYPE_MISSION, [goal_item(5.0, 0.0, 1.0, 0.0)])
    m.set_plan(mavlink.MAV_MISSION_TYPE_RALLY, [goal_item(5.0, 0.0, 1.0, 0.0)])
    pic = m.picture(T0)
    assert v == 2 and pic.plan_version == 2
    assert pic.plan["goals"][0]["x_m"] == 5.0 and pic.plan["obstacles"] == [
        {"x_m": 2.0, "y_m": 4.0, "radius_m": 1.5}
    ]
    assert pic.plan["goals_not_drawn"] == 0 and pic.plan["fence_not_drawn"] == 0


def test_plan_numbers_that_are_not_finite_are_none_and_the_update_is_strict_json() -> None:
    # GIVEN plans with a NaN depth and an infinite yaw, and an infinite radius (the vehicle takes neither,
    # but a download is what the vehicle says, and one picture with a NaN stopped every page's updates)
    bad_goal = Item(LOCAL, WAYPOINT, 0.0, math.nan, 0.0, math.inf, 100_000, 0, math.nan)
    bad_circle = Item(LOCAL, EXCLUSION, math.inf, 0.0, 0.0, 0.0, 20_000, 0, 0.0)
    m = running_model()
    m.set_plan(MISSION, [bad_goal, goal_item(5.0, 0.0, 1.0, None)])
    m.set_plan(FENCE, [bad_circle])
    # WHEN a page is sent the picture
    msg, _ = update_for(m.picture(T0), None)
    # THEN it is JSON (no NaN), each number that is not finite None: the page does not draw that item
    json.dumps(msg, allow_nan=False)
    assert [(g["depth_m"], g["yaw_deg"]) for g in msg["plan"]["goals"]] == [(None, None), (1.0, None)]
    assert msg["plan"]["obstacles"] == [{"x_m": 2.0, "y_m": 0.0, "radius_m": None}]


@pytest.mark.parametrize(
    ("home", "seq", "index"),
    [
        (True, 1, 0),  # with a home placeholder, seq = goal index + 1
        (True, 2, 1),
        (True, 0, 0),  # the home's seq: the vehicle flies goal 0
        (False, 1, 1),  # without one, seq = goal index
        (False, 0, 0),
    ],
)
def test_the_goal_index_is_mission_current_s_seq_less_the_home_placeholder(
    home: bool, seq: int, index: int
) -> None:
    # GIVEN a downloaded mission of two goals, with or without a home placeholder in front (QGC sends one)
    goals = [goal_item(10.0, 0.0, 1.0, None), goal_item(20.0, 0.0, 1.0, None)]
    m = running_model()
    m.set_plan(MISSION, [home_item(35.1, 129.04, 0.0), *goals] if home else goals)
    # WHEN the vehicle reports MISSION_CURRENT
    m.apply(T0, mission_current(seq, 2))
    pic = m.picture(T0)
    # THEN the telemetry carries the goal index (0-based) the page shows as "goal index+1 of 2", and each
    # goal drawn has its index; the home placeholder is no goal (neither drawn nor "not drawn")
    assert pic.telemetry["goal"]["index"] == index and pic.telemetry["goal"]["seq"] == seq
    assert [(g["seq"], g["index"]) for g in pic.plan["goals"]] == [(0 + home, 0), (1 + home, 1)]
    assert pic.plan["goals_not_drawn"] == 0


def origin_message(lat_e7: int = 351_000_000, lon_e7: int = 1_290_400_000, alt_mm: int = 12_000) -> Any:
    return wire(mavlink.MAVLink_gps_global_origin_message(lat_e7, lon_e7, alt_mm, 0))


def test_global_items_are_drawn_in_metres_once_the_vehicle_s_origin_is_known() -> None:
    # GIVEN a plan as QGC uploads it: a home placeholder, a waypoint 0.001 deg north at altitude -2 m
    # relative, one 0.001 deg east at 9 m AMSL, and an exclusion circle 0.0005 deg north
    rel = Item(mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, WAYPOINT, 0, 0, 0, math.nan, 351_010_000,
               1_290_400_000, -2.0)  # fmt: skip
    amsl = Item(mavlink.MAV_FRAME_GLOBAL_INT, WAYPOINT, 0, 0, 0, math.nan, 351_000_000, 1_290_410_000, 9.0)
    m = running_model()
    m.set_plan(MISSION, [home_item(35.1, 129.04, 12.0), rel, amsl])
    m.set_plan(FENCE, [fence_circle_item(35.1005, 129.04, 3.0)])
    # THEN before the vehicle's origin came they are not drawn (and counted so)
    pic = m.picture(T0)
    assert pic.plan["goals"] == [] and pic.plan["obstacles"] == [] and pic.plan["origin"] is None
    assert (pic.plan["goals_not_drawn"], pic.plan["fence_not_drawn"]) == (2, 1)
    version = m.plan_version
    # WHEN the vehicle's GPS_GLOBAL_ORIGIN comes (35.1 N, 129.04 E, 12 m AMSL)
    m.apply(T0, origin_message())
    m.apply(T0 + 5.0, origin_message())  # (the same again: no new plan)
    pic = m.picture(T0 + 5.0)
    # THEN they are drawn in local NED metres, projected as the vehicle does (flat earth about its origin):
    # 0.001 deg north = 111.3195 m, 0.001 deg east = 91.076 m at 35.1 N (to 0.1 mm); depth = -altitude
    # relative, the origin's altitude - altitude AMSL
    assert m.plan_version == version + 1
    assert pic.plan["origin"] == {"lat_deg": 35.1, "lon_deg": 129.04, "alt_m": 12.0}
    assert [(g["seq"], g["index"], g["x_m"], g["y_m"], g["depth_m"]) for g in pic.plan["goals"]] == [
        (1, 0, 111.3195, 0.0, 2.0),
        (2, 1, 0.0, 91.076, 3.0),
    ]
    assert pic.plan["obstacles"] == [{"x_m": 55.6597, "y_m": 0.0, "radius_m": 3.0}]
    assert (pic.plan["goals_not_drawn"], pic.plan["fence_not_drawn"]) == (0, 0)
    json.dumps(update_for(pic, None)[0], allow_nan=False)


def test_path_set_bumps_its_version_only_when_it_changes() -> None:
    m = running_model()
    path = {"version": 1, "kind": "goal", "goal_index": 0, "points_m": [[0.0, 0.0, 1.0], [5.0, 0.0, 1.0]]}
    m.set_path(path)
    m.set_path(dict(path))
    assert m.path_version == 1
    m.set_path(None, "no planned path: no such file")
    pic = m.picture(T0)
    assert (
        m.path_version == 2 and pic.path is None and pic.telemetry["note"] == "no planned path: no such file"
    )


@pytest.mark.parametrize(
    ("messages", "refresh"),
    [
        ([mission_current(0, 2)], False),  # the first MISSION_CURRENT: the plans were just downloaded
        ([mission_current(0, 2), mission_current(1, 2)], False),  # progress, same mission
        ([mission_current(0, 2), mission_current(0, 3)], True),  # a new mission
        ([statustext("mission accepted: 2 goals")], True),
        ([statustext("fence cleared")], True),
        ([statustext("depth sensor stale")], False),
        ([statustext("fence breach: obstacle 0")], False),
        ([sys_status(False), sys_status(False)], False),
        ([sys_status(False), sys_status(True)], True),  # a fence came
        ([sys_status(True), sys_status(False)], True),  # ... or went
    ],
)
def test_the_model_says_when_the_plans_may_have_changed(messages: list[Any], refresh: bool) -> None:
    m = running_model()
    for msg in messages:
        m.apply(T0, msg)
    assert m.take_refresh() is refresh
    assert m.take_refresh() is False  # taken once


def test_texts_are_reassembled_from_chunks_and_the_last_few_kept() -> None:
    m = running_model()
    m.apply(T0, statustext("x" * 50, mavlink.MAV_SEVERITY_WARNING, chunk_id=7, seq=0))
    m.apply(T0, statustext("yz", mavlink.MAV_SEVERITY_WARNING, chunk_id=7, seq=1))
    for i in range(6):
        m.apply(T0, statustext(f"text {i}"))
    texts = m.telemetry(T0)["texts"]
    assert [t["text"] for t in texts] == [f"text {i}" for i in range(1, 6)]
    m2 = running_model()
    m2.apply(T0, statustext("x" * 50, mavlink.MAV_SEVERITY_WARNING, chunk_id=7, seq=0))
    m2.apply(T0, statustext("yz", mavlink.MAV_SEVERITY_WARNING, chunk_id=7, seq=1))
    assert m2.telemetry(T0)["texts"] == [{"severity": 4, "text": "x" * 50 + "yz", "t_s": T0}]


# ---- what one page is sent -------------------------------------------------------------------------------
def test_update_for_sends_plans_and_path_on_change_and_the_track_as_new_points() -> None:
    # GIVEN a model with a plan, a path and two track points
    m = running_model()
    m.set_plan(mavlink.MAV_MISSION_TYPE_MISSION, [goal_item(5.0, 0.0, 1.0, 0.0)])
    m.set_path({"version": 1, "kind": "goal", "goal_index": 0, "points_m": [[0.0, 0.0, 1.0]]})
    m.apply(T0, position(0.0, 0.0))
    m.apply(T0, position(1.0, 0.0))
    # WHEN a new page gets its first update
    first, sent = update_for(m.picture(T0), None)
    # THEN it has everything
    assert first["type"] == "update" and first["plan"]["goals"][0]["x_m"] == 5.0
    assert first["path"]["points_m"] == [[0.0, 0.0, 1.0]]
    assert first["track_from"] == 0 and first["track"] == [[0.0, 0.0, 1.0], [1.0, 0.0, 1.0]]
    json.dumps(first, allow_nan=False)
    # WHEN nothing but a new position came
    m.apply(T0 + 0.1, position(2.0, 0.0))
    second, sent = update_for(m.picture(T0 + 0.1), sent)
    # THEN only the telemetry and the new point
    assert "plan" not in second and "path" not in second
    assert second["track_from"] == 2 and second["track"] == [[2.0, 0.0, 1.0]]
    assert sent == Sent(m.plan_version, m.path_version, 0, 3)
    # WHEN the path went away
    m.set_path(None)
    third, _ = update_for(m.picture(T0 + 0.2), sent)
    assert "path" in third and third["path"] is None and third["track"] == []


def test_update_for_resends_the_whole_track_after_a_new_epoch() -> None:
    m = MapModel(track_max_points=4)
    m.apply(T0, heartbeat())
    for i in range(4):
        m.apply(T0, position(float(i), 0.0))
    _, sent = update_for(m.picture(T0), None)
    m.apply(T0, position(10.0, 0.0))
    msg, sent = update_for(m.picture(T0), sent)
    assert msg["track_from"] == 0 and [p[0] for p in msg["track"]] == [2.0, 3.0, 10.0]
    assert sent.track_epoch == 1 and sent.track_len == 3


# ---- plans in a recording --------------------------------------------------------------------------------
def _transfer(items: list[Item], mission_type: int, ack: int, sender=GCS, acker=VEHICLE) -> list[Any]:
    """An upload as a tlog holds it (the items from ``sender``, the ACK from ``acker``)."""
    out = [wire(mavlink.MAVLink_mission_count_message(1, 1, len(items), mission_type), sender)]
    for seq, it in enumerate(items):
        out.append(
            wire(
                mavlink.MAVLink_mission_item_int_message(
                    1, 1, seq, it.frame, it.command, 0, it.autocontinue, it.param1, it.param2, it.param3,
                    it.param4, it.x, it.y, it.z, mission_type,
                ),
                sender,
            )
        )  # fmt: skip
    out.append(wire(mavlink.MAVLink_mission_ack_message(255, 190, ack, mission_type), acker))
    return out


def _feed(rec: PlanRecorder, msgs: list[Any]) -> list[tuple[int, list[Item]]]:
    return [c for msg in msgs for c in rec.feed(msg)]


def test_plan_recorder_commits_an_accepted_upload_and_download() -> None:
    goals = [goal_item(5.0, 0.0, 1.0, 0.0), goal_item(10.0, 5.0, 2.0, None)]
    fence = [obstacle_item(2.0, 4.0, 1.5)]
    rec = PlanRecorder()
    got = _feed(rec, _transfer(goals, 0, mavlink.MAV_MISSION_ACCEPTED))
    got += _feed(rec, _transfer(fence, 1, mavlink.MAV_MISSION_ACCEPTED, sender=VEHICLE, acker=GCS))
    assert len(got) == 2 and got[0][0] == 0 and got[1][0] == 1
    assert goals_of(got[0][1]) == goals_of(goals) and obstacles_of(got[1][1]) == obstacles_of(fence)


def test_plan_recorder_commits_nothing_refused_or_incomplete() -> None:
    goals = [goal_item(5.0, 0.0, 1.0, 0.0), goal_item(10.0, 5.0, 2.0, None)]
    rec = PlanRecorder()
    assert _feed(rec, _transfer(goals, 0, mavlink.MAV_MISSION_ERROR)) == []
    broken = _transfer(goals, 0, mavlink.MAV_MISSION_ACCEPTED)
    del broken[2]  # the second item never came
    assert _feed(rec, broken) == []


def test_plan_recorder_splits_an_accepted_whole_plan_upload() -> None:
    goals = [goal_item(5.0, 0.0, 1.0, 0.0), goal_item(10.0, 5.0, 2.0, None)]
    fence = [obstacle_item(2.0, 4.0, 1.5)]
    rec = PlanRecorder()
    assert _feed(rec, _transfer(goals + fence, mavlink.MAV_MISSION_TYPE_ALL, mavlink.MAV_MISSION_ERROR)) == []
    got = _feed(rec, _transfer(goals + fence, mavlink.MAV_MISSION_TYPE_ALL, mavlink.MAV_MISSION_ACCEPTED))
    assert [t for t, _ in got] == [0, 1]
    assert goals_of(got[0][1]) == goals_of(goals) and obstacles_of(got[1][1]) == obstacles_of(fence)


def test_plan_recorder_commits_empty_plans_on_an_accepted_clear_all() -> None:
    rec = PlanRecorder()
    clear = wire(mavlink.MAVLink_mission_clear_all_message(1, 1, mavlink.MAV_MISSION_TYPE_ALL), GCS)
    ack = wire(mavlink.MAVLink_mission_ack_message(255, 190, 0, mavlink.MAV_MISSION_TYPE_ALL))
    assert rec.feed(clear) == [] and rec.feed(ack) == [(0, []), (1, [])]


# ---- replay ----------------------------------------------------------------------------------------------
def _recording() -> list[tuple[float, Any]]:
    msgs: list[tuple[float, Any]] = [(T0, gcs_heartbeat())]
    upload = [
        *_transfer([goal_item(20.0, 0.0, 1.0, 0.0)], 0, 0),
        *_transfer([obstacle_item(5.0, 5.0, 2.0)], 1, 0),
    ]
    msgs += [(T0 + 0.01 + 0.001 * i, m) for i, m in enumerate(upload)]
    msgs.append((T0 + 0.05, heartbeat()))
    for i in range(30):  # 3 s at 10 Hz, 1 m/s north
        msgs.append((T0 + 0.1 + i * 0.1, position(i * 0.1, 0.0, t_ms=i * 100)))
    msgs.append((T0 + 100.0, position(50.0, 0.0)))  # after a long silence (another session)
    return msgs


def test_replay_pictures_follow_the_recording_with_its_plans() -> None:
    # GIVEN a recording: an upload of goal and fence, then 3 s of positions, then one more after 97 s
    pics = replay_pictures(messages_of(reversed(_recording())))
    # THEN a picture every 0.1 s while messages come, and the long silence is skipped
    assert len(pics) < 40
    assert pics[0].t_s == T0 and pics[-1].t_s == pytest.approx(T0 + 100.0)
    # AND each picture shows the vehicle where it was at that time, with the plans the recording uploaded
    early, later = picture_at(pics, T0 + 0.55), picture_at(pics, T0 + 2.55)
    assert early.telemetry["vehicle"]["x_m"] < later.telemetry["vehicle"]["x_m"]
    assert later.telemetry["vehicle"]["x_m"] == pytest.approx(2.4, abs=0.11)
    assert later.plan["goals"][0]["x_m"] == 20.0 and later.plan["obstacles"][0]["radius_m"] == 2.0
    assert later.track_len > early.track_len and later.track is early.track  # one track, prefixes of it
    assert picture_at(pics, T0 - 10.0) is pics[0] and picture_at(pics, T0 + 1e6) is pics[-1]
    # AND seeking backwards cuts the page's track
    _, sent = update_for(later, None)
    back, _ = update_for(early, sent)
    assert back["track_from"] == early.track_len and back["track"] == []


def test_replay_of_nothing_is_no_picture() -> None:
    assert replay_pictures([]) == []


# ---- files read in a recording (MAVLink FTP) -------------------------------------------------------------
def ftp_msg(seq: int, opcode: int, *, req: int = 0, session: int = 0, offset: int = 0, data: bytes = b"",
            src: tuple[int, int] = VEHICLE) -> Any:  # fmt: skip
    payload = ftp.Packet(seq, session, opcode, len(data), req, 0, offset, data).encode()
    return wire(mavlink.MAVLink_file_transfer_protocol_message(0, 1, 1, payload), src)


def file_read(name: str, content: bytes, seq: int = 40, session: int = 2) -> list[Any]:
    """A read as MavClient.read_file does it and a tlog records it: open, reads of DATA_MAX, terminate."""
    out = [
        ftp_msg(seq, ftp.OPEN_RO, data=name.encode(), src=GCS),
        ftp_msg(seq + 1, ftp.ACK, req=ftp.OPEN_RO, session=session, data=len(content).to_bytes(4, "little")),
    ]
    seq += 2
    for offset in range(0, len(content), ftp.DATA_MAX):
        out.append(ftp_msg(seq, ftp.READ, session=session, offset=offset, src=GCS))
        chunk = content[offset : offset + ftp.DATA_MAX]
        out.append(ftp_msg(seq + 1, ftp.ACK, req=ftp.READ, session=session, offset=offset, data=chunk))
        seq += 2
    out.append(ftp_msg(seq, ftp.TERMINATE, session=session, src=GCS))
    out.append(ftp_msg(seq + 1, ftp.ACK, req=ftp.TERMINATE, session=session))
    return out


PATH_DOC = json.dumps(
    {"version": 2, "kind": "goal", "goal_index": 0, "frame": "local_ned", "length_m": 60.0,
     "points_m": [[i * 0.5, 0.0, 1.0] for i in range(121)]}
).encode()  # fmt: skip


def test_file_read_recorder_gives_the_whole_file_once() -> None:
    rec = FileReadRecorder()
    done = [r for m in file_read(PLANNED_PATH_FILE, PATH_DOC) if (r := rec.feed(m)) is not None]
    assert len(PATH_DOC) > 4 * ftp.DATA_MAX and done == [(PLANNED_PATH_FILE, PATH_DOC)]


def test_file_read_recorder_reports_a_missing_file_and_ignores_a_torn_read() -> None:
    rec = FileReadRecorder()
    nak = ftp_msg(8, ftp.NAK, req=ftp.OPEN_RO, data=bytes([ftp.FILE_NOT_FOUND]))
    assert rec.feed(ftp_msg(7, ftp.OPEN_RO, data=b"@PATH/planned.json", src=GCS)) is None
    assert rec.feed(nak) == (PLANNED_PATH_FILE, None)
    torn = file_read(PLANNED_PATH_FILE, PATH_DOC)
    del torn[5]  # one chunk's reply lost (and never re-sent): no file
    assert [r for m in torn if (r := rec.feed(m)) is not None] == []
    assert rec.feed(position(0.0, 0.0)) is None


def test_a_replay_shows_the_path_the_recording_read() -> None:
    # GIVEN a recording with the vehicle's heartbeat and a read of its path file, later one of no path
    msgs = [heartbeat(), *file_read(PLANNED_PATH_FILE, PATH_DOC)]
    none = json.dumps({"version": 3, "kind": "", "goal_index": -1, "frame": "local_ned", "points_m": []})
    later = file_read(PLANNED_PATH_FILE, none.encode(), seq=90)
    records = [(T0 + 0.001 * i, m) for i, m in enumerate(msgs)] + [
        (T0 + 1.0 + 0.001 * i, m) for i, m in enumerate(later)
    ]
    # WHEN replayed
    pics = replay_pictures(records)
    # THEN the path is shown from the read on, and the empty one after the second read
    path = picture_at(pics, T0 + 0.5).path
    assert path is not None and path["kind"] == "goal" and len(path["points_m"]) == 121
    assert picture_at(pics, T0 + 1.5).path["points_m"] == []
