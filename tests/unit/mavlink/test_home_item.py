"""ArduPilot's home convention (mission seq 0 = home, as MAVProxy ``wp load`` sends it): check, convert,
persist, and the MAVLink seq <-> goal index mapping of the endpoint (home present and absent)."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from pymavlink.dialects.v20 import common as mavlink

from onboard.adapters.mavlink.api import VehicleSnapshot
from onboard.adapters.mavlink.mission_protocol import (
    TYPE_FENCE,
    TYPE_MISSION,
    MissionItem,
    MissionServer,
    check_item,
    goal_items,
    goal_of_seq,
    home_offset,
    is_home_item,
    mission_from_items,
    seq_of_goal,
)
from onboard.adapters.mavlink.storage import load_plan
from onboard.app.store import StateStore
from onboard.core import commands as core
from onboard.core.mission.state import MissionState

from .linkkit import Captured
from .test_mission_protocol import GCS, LIMITS, count_msg, item_msg, only, upload, wp

ACCEPTED = mavlink.MAV_MISSION_ACCEPTED
ORIGIN = (LIMITS.origin_lat_deg, LIMITS.origin_lon_deg)


def home(
    frame: int = mavlink.MAV_FRAME_GLOBAL, lat: float = 0.0, lon: float = 0.0, **kw: float
) -> MissionItem:
    """The home line of a QGC WPL 110 file as MAVProxy sends it (frame 0, command 16, lat/lon 0/0)."""
    d = dict(frame=frame, command=mavlink.MAV_CMD_NAV_WAYPOINT, param1=0.0, param2=0.0, param3=0.0,
             param4=0.0, x=round(lat * 1e7), y=round(lon * 1e7), z=0.0)  # fmt: skip
    d.update(kw)
    return MissionItem(**d)  # type: ignore[arg-type]


def rel(north_m: float, east_m: float, depth_m: float) -> MissionItem:
    """A GLOBAL_RELATIVE_ALT goal ``north_m`` / ``east_m`` from the origin (altitude = -depth)."""
    lat = ORIGIN[0] + math.degrees(north_m / 6_378_137.0)
    lon = ORIGIN[1] + math.degrees(east_m / (6_378_137.0 * math.cos(math.radians(ORIGIN[0]))))
    return MissionItem(mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT, 16, 0.0, 0.0, 0.0, math.nan,
                       round(lat * 1e7), round(lon * 1e7), -depth_m)  # fmt: skip


# ---- check --------------------------------------------------------------------------------------
@pytest.mark.parametrize("frame", [mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_FRAME_GLOBAL_INT])
def test_home_at_seq0_is_accepted_without_area_or_depth_check(frame: int) -> None:
    # GIVEN MAVProxy's home line (lat/lon 0/0, thousands of km from the origin; AMSL altitude 584 m)
    h = home(frame, z=584.0)
    # THEN at seq 0 it is the home placeholder and accepted, anywhere else it is a goal (well formed: the
    # validator refuses it for its position)
    assert is_home_item(h, 0) and check_item(h, TYPE_MISSION, LIMITS, seq=0) == ACCEPTED
    assert not is_home_item(h, 1)
    assert check_item(home(frame, lat=-89.9, lon=179.9), TYPE_MISSION, LIMITS, seq=0) == ACCEPTED
    assert check_item(home(frame, param1=math.nan, param4=math.nan), TYPE_MISSION, LIMITS, seq=0) == ACCEPTED


def test_only_absolute_global_waypoints_of_the_mission_type_are_home() -> None:
    for frame in (mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT):
        assert not is_home_item(home(frame), 0)  # a goal
    assert not is_home_item(wp(), 0)  # our ground station's local-frame goals are never home
    loiter = home(command=mavlink.MAV_CMD_NAV_LOITER_UNLIM)
    assert not is_home_item(loiter, 0)
    assert check_item(loiter, TYPE_MISSION, LIMITS, seq=0) == mavlink.MAV_MISSION_UNSUPPORTED
    assert not is_home_item(home(), 0, TYPE_FENCE)


@pytest.mark.parametrize(
    ("kw", "code"),
    [
        ({"z": math.nan}, mavlink.MAV_MISSION_INVALID_PARAM7),
        ({"z": math.inf}, mavlink.MAV_MISSION_INVALID_PARAM7),
        ({"param1": math.inf}, mavlink.MAV_MISSION_INVALID_PARAM1),
        ({"param2": -math.inf}, mavlink.MAV_MISSION_INVALID_PARAM2),
        ({"param3": math.inf}, mavlink.MAV_MISSION_INVALID_PARAM3),
        ({"param4": math.inf}, mavlink.MAV_MISSION_INVALID_PARAM4),
        ({"x": 900_000_001}, mavlink.MAV_MISSION_INVALID_PARAM5_X),
        ({"y": -1_800_000_001}, mavlink.MAV_MISSION_INVALID_PARAM6_Y),
    ],
)
def test_home_with_invalid_values_is_rejected(kw: dict[str, float], code: int) -> None:
    assert check_item(home(**kw), TYPE_MISSION, LIMITS, seq=0) == code


# ---- convert and index mapping -----------------------------------------------------------------
def test_goals_are_the_items_after_home() -> None:
    goals = (rel(10.0, 0.0, 1.0), rel(10.0, 10.0, 2.0))
    with_home, without = (home(), *goals), goals
    assert home_offset(with_home) == 1 and goal_items(with_home) == goals
    assert home_offset(without) == 0 and goal_items(without) == goals
    assert home_offset(()) == 0 and home_offset((home(),)) == 1 and goal_items((home(),)) == ()
    for items in (with_home, without):
        m = mission_from_items(items, (), LIMITS)
        assert [(round(g.x_m, 2), round(g.y_m, 2), g.depth_m) for g in m.goals] == [
            (10.0, 0.0, 1.0),
            (10.0, 10.0, 2.0),
        ]


@pytest.mark.parametrize(
    ("seq", "offset", "n", "goal"),
    [
        (0, 0, 3, 0),
        (2, 0, 3, 2),
        (3, 0, 3, None),
        (-1, 0, 3, None),
        (0, 1, 3, 0),  # the home seq selects the first goal
        (1, 1, 3, 0),
        (3, 1, 3, 2),
        (4, 1, 3, None),
        (0, 1, 0, None),  # only a home item: no goal to select
    ],
)
def test_goal_of_seq(seq: int, offset: int, n: int, goal: int | None) -> None:
    assert goal_of_seq(seq, offset, n) == goal
    if goal is not None and seq >= offset:
        assert seq_of_goal(goal, offset) == seq


# ---- server and persistence --------------------------------------------------------------------
def test_upload_with_home_stores_all_items_and_downloads_them_unchanged(tmp_path: Path) -> None:
    store = StateStore(tmp_path)
    srv = MissionServer(LIMITS)
    items = [home(z=584.0), rel(10.0, 0.0, 1.0), rel(10.0, 10.0, 2.0)]
    ack = only(upload(srv, items))
    assert ack.type == ACCEPTED and srv.items(TYPE_MISSION) == tuple(items)
    store.save_plan("mission", srv.items(TYPE_MISSION))
    assert srv.goal_count() == 2 and srv.home_offset() == 1 and len(srv.mission().goals) == 2
    down = mavlink.MAVLink_mission_request_int_message(1, 1, 0, TYPE_MISSION)
    r = only(srv.handle(down, GCS, 0.0))
    assert (r.seq, r.frame, r.command, r.x, r.y, r.z) == (0, mavlink.MAV_FRAME_GLOBAL, 16, 0, 0, 584.0)
    # persistence round trip: the reloaded plan is the same, with the same goals
    loaded = load_plan(store, TYPE_MISSION)
    assert loaded is not None and [i.key() for i in loaded] == [i.key() for i in items]
    again = MissionServer(LIMITS, stored={TYPE_MISSION: loaded})
    assert again.mission() == srv.mission() and again.home_offset() == 1


def test_home_only_upload_is_zero_goals_like_a_clear() -> None:
    srv = MissionServer(LIMITS, stored={TYPE_MISSION: (wp(),)})
    assert only(upload(srv, [home()])).type == ACCEPTED
    assert srv.take_changed() and srv.mission().goals == () and srv.goal_count() == 0
    assert srv.items(TYPE_MISSION) == (home(),)


def test_home_at_a_later_seq_is_a_goal_for_the_validator() -> None:
    srv = MissionServer(LIMITS)
    assert only(srv.handle(count_msg(2), GCS, 0.0)).seq == 0
    assert only(srv.handle(item_msg(0, rel(1, 1, 1)), GCS, 0.0)).seq == 1
    assert srv.handle(item_msg(1, home()), GCS, 0.0) == []
    c = srv.take_candidate()
    assert c is not None
    far = srv.candidate_mission(c).goals[1]  # lat/lon 0/0: thousands of km away, the validator refuses it
    assert abs(far.x_m) > 1e6


# ---- the link: seq <-> goal index (no sockets) --------------------------------------------------
GOALS3 = (rel(10.0, 0.0, 1.0), rel(20.0, 0.0, 1.0), rel(30.0, 0.0, 1.0))


def accept_all(cmd: core.Command) -> core.Verdict:
    return core.accepted("ok")


@pytest.mark.parametrize("with_home", [True, False])
def test_link_maps_goal_indices_to_seq(tmp_path: Path, with_home: bool) -> None:
    off = 1 if with_home else 0
    c = Captured(tmp_path, items=((home(),) if with_home else ()) + GOALS3)
    link = c.link
    # MISSION_CURRENT: seq = goal index + offset, total = goals only
    link.publish(VehicleSnapshot(state=MissionState.RUNNING, current_goal=0))
    link.telemetry.send_message(mavlink.MAVLINK_MSG_ID_MISSION_CURRENT)
    (cur,) = c.sent("MISSION_CURRENT")
    assert (cur.seq, cur.total, cur.mission_state) == (off, 3, mavlink.MISSION_STATE_ACTIVE)
    # MISSION_ITEM_REACHED: the seq of the reached goal(s)
    link.publish(VehicleSnapshot(state=MissionState.RUNNING, current_goal=2, goals_reached=2))
    c.poll()
    assert [m.seq for m in c.sent("MISSION_ITEM_REACHED")] == [off, off + 1]
    c.out.clear()
    # MISSION_SET_CURRENT / DO_SET_MISSION_CURRENT: seq -> goal index (home seq 0 -> goal 0)
    c.rx(mavlink.MAVLink_mission_set_current_message(1, 1, 2))
    assert [r.command for r in link.take_requests()] == [core.SetCurrent(2 - off, "MAVLink 255/190")]
    c.command(mavlink.MAV_CMD_DO_SET_MISSION_CURRENT, 0)
    (req,) = link.take_requests()
    assert req.command == core.SetCurrent(0, "MAVLink 255/190")
    c.poll()
    c.out.clear()
    link.answer(req.id, core.accepted("current goal 0"))
    c.poll()
    assert c.ack() == mavlink.MAV_RESULT_ACCEPTED
    assert [m.seq for m in c.sent("MISSION_CURRENT")] == [off]  # the goal actually selected
    last = 3 + off  # one past the last item
    c.command(mavlink.MAV_CMD_DO_SET_MISSION_CURRENT, last)
    assert c.ack() == mavlink.MAV_RESULT_DENIED and link.take_requests() == []
    assert c.texts() == [f"no mission item {last} (the mission has {last} items)"]
    # MISSION_START first_item is a seq too; <= 0 is the current goal (None)
    for first, goal in ((2, 2 - off), (0, None)):
        c.command(mavlink.MAV_CMD_MISSION_START, first)
        (req,) = link.take_requests()
        assert req.command == core.Start(goal, "MAVLink 255/190")
        link.answer(req.id, core.accepted("started"))
        c.poll()
        assert c.ack() == mavlink.MAV_RESULT_ACCEPTED


def test_link_home_only_mission_is_a_clear_handed_to_the_core(tmp_path: Path) -> None:
    c = Captured(tmp_path, items=GOALS3)
    c.upload([home()])
    c.settle()
    (req,) = c.link.take_requests()
    assert isinstance(req.command, core.ReplaceMission) and req.command.mission.goals == ()
    assert req.command.goals_changed and c.link.mission().goals != ()  # nothing changes before the core
    c.link.answer(req.id, core.accepted("mission replaced (0 goals)"))
    c.poll()
    assert c.mission_ack() == ACCEPTED and c.link.missions.shape() == (1, 0)
    c.out.clear()
    c.link.telemetry.send_message(mavlink.MAVLINK_MSG_ID_MISSION_CURRENT)
    (cur,) = c.sent("MISSION_CURRENT")
    assert cur.total == 0 and cur.mission_state == mavlink.MISSION_STATE_NO_MISSION
    # a restart reloads the home-only plan: no goals
    again = Captured(tmp_path)
    assert again.link.missions.server.items(TYPE_MISSION) == (home(),) and again.link.mission().goals == ()
