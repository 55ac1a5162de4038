"""Mission micro-service state machine: upload/download/clear, format codes, judging, timers, re-sent item."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pymavlink.dialects.v20 import common as mavlink

from onboard.adapters.mavlink.mission_protocol import (
    TYPE_FENCE,
    TYPE_MISSION,
    MissionItem,
    MissionLimits,
    MissionServer,
    check_item,
    goal_from_item,
    is_home_item,
    item_position,
)
from onboard.adapters.mavlink.peers import Sender

GCS = (255, 190)
OTHER = (254, 190)
LIMITS = MissionLimits()


def wp(
    x_m: float = 10.0, y_m: float = 5.0, depth_m: float = 2.0, yaw_deg: float = math.nan, **kw: float
) -> MissionItem:
    d = dict(frame=mavlink.MAV_FRAME_LOCAL_NED, command=mavlink.MAV_CMD_NAV_WAYPOINT, param1=0.0,
             param2=math.nan, param3=0.0, param4=yaw_deg, x=round(x_m * 1e4), y=round(y_m * 1e4),
             z=depth_m)  # fmt: skip
    d.update(kw)
    return MissionItem(**d)  # type: ignore[arg-type]


def item_msg(seq: int, it: MissionItem, mt: int = TYPE_MISSION) -> mavlink.MAVLink_message:
    return mavlink.MAVLink_mission_item_int_message(
        1, 1, seq, it.frame, it.command, 0, it.autocontinue, it.param1, it.param2, it.param3, it.param4,
        it.x, it.y, it.z, mt,
    )  # fmt: skip


def count_msg(n: int, mt: int = TYPE_MISSION) -> mavlink.MAVLink_message:
    return mavlink.MAVLink_mission_count_message(1, 1, n, mt)


ACCEPTED = mavlink.MAV_MISSION_ACCEPTED


def judged(srv: MissionServer, out: list, result: int) -> list:
    """``out``, or the final ACK with ``result`` when the transfer is waiting for its judgement."""
    if srv.take_candidate() is not None:
        assert out == []
        return srv.finish(result)
    return out


def upload(
    srv: MissionServer,
    items: list[MissionItem],
    mt: int = TYPE_MISSION,
    t: float = 0.0,
    result: int = ACCEPTED,
) -> list:
    """Upload ``items``; a complete transfer is judged ``result`` (what the mission service decides)."""
    out = judged(srv, srv.handle(count_msg(len(items), mt), GCS, t), result)
    for i, it in enumerate(items):
        out = judged(srv, srv.handle(item_msg(i, it, mt), GCS, t), result)
        if out and out[0].get_type() == "MISSION_ACK":
            break
    return out


def only(out: list) -> mavlink.MAVLink_message:
    assert len(out) == 1, out
    return out[0]


def test_upload_round_trip_requests_each_item_and_acks_accepted() -> None:
    # GIVEN a server and three goals WHEN uploaded THEN each item is requested with MISSION_REQUEST_INT
    srv = MissionServer(LIMITS)
    items = [wp(1, 2, 3, 90.0), wp(4, 5, 6), wp(-7, -8, 0.5, -45.0)]
    r = only(srv.handle(count_msg(3), GCS, 0.0))
    assert (
        r.get_type() == "MISSION_REQUEST_INT" and r.seq == 0 and (r.target_system, r.target_component) == GCS
    )
    for i, it in enumerate(items[:-1]):
        r = only(srv.handle(item_msg(i, it), GCS, 0.0))
        assert r.get_type() == "MISSION_REQUEST_INT" and r.seq == i + 1
    # THEN the last item leaves the transfer judging: no ACK until finish(), the stored plan unchanged
    assert srv.handle(item_msg(2, items[2]), GCS, 0.0) == [] and srv.judging and srv.mission().goals == ()
    candidate = srv.take_candidate()
    assert candidate is not None and candidate.plans == {TYPE_MISSION: tuple(items)}
    assert srv.take_candidate() is None  # taken once
    r = only(srv.finish(ACCEPTED))
    assert r.get_type() == "MISSION_ACK" and r.type == mavlink.MAV_MISSION_ACCEPTED
    assert srv.take_changed()
    goals = srv.mission().goals
    assert [(g.x_m, g.y_m, g.depth_m) for g in goals] == [(1, 2, 3), (4, 5, 6), (-7, -8, 0.5)]
    assert goals[0].yaw_rad == pytest.approx(math.pi / 2) and goals[1].yaw_rad is None
    assert goals[2].yaw_rad == pytest.approx(-math.pi / 4)


def test_download_is_stateless_and_answers_legacy_request_in_kind() -> None:
    srv = MissionServer(LIMITS)
    upload(srv, [wp(1, 2, 3), wp(4, 5, 6)])
    c = only(srv.handle(mavlink.MAVLink_mission_request_list_message(1, 1, TYPE_MISSION), GCS, 0.0))
    assert c.get_type() == "MISSION_COUNT" and c.count == 2
    it = only(srv.handle(mavlink.MAVLink_mission_request_int_message(1, 1, 1, TYPE_MISSION), GCS, 0.0))
    assert it.get_type() == "MISSION_ITEM_INT" and it.seq == 1 and it.x == 40000
    # a legacy MISSION_REQUEST gets a float MISSION_ITEM, local x/y in metres
    it = only(srv.handle(mavlink.MAVLink_mission_request_message(1, 1, 1, TYPE_MISSION), GCS, 0.0))
    assert it.get_type() == "MISSION_ITEM" and it.seq == 1 and (it.x, it.y, it.z) == (4.0, 5.0, 6.0)
    # ... and a global item in its legacy frame (stored GLOBAL_RELATIVE_ALT_INT, sent GLOBAL_RELATIVE_ALT)
    srv2 = MissionServer(LIMITS)
    glob = wp(frame=mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, x=351000000, y=1290400000, z=-2.0)
    upload(srv2, [glob])
    it = only(srv2.handle(mavlink.MAVLink_mission_request_message(1, 1, 0, TYPE_MISSION), GCS, 0.0))
    assert it.frame == mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT and it.x == pytest.approx(35.1)
    bad = only(srv.handle(mavlink.MAVLink_mission_request_int_message(1, 1, 5, TYPE_MISSION), GCS, 0.0))
    assert bad.type == mavlink.MAV_MISSION_INVALID_SEQUENCE


@pytest.mark.parametrize(
    ("item", "code"),
    [
        # format, and the validator's yaw rule (only the item has the yaw as sent, before the wrap); the
        # limits (area, depth, hold time) are the validator's
        (wp(yaw_deg=361.0), mavlink.MAV_MISSION_INVALID_PARAM4),
        (wp(yaw_deg=-999.0), mavlink.MAV_MISSION_INVALID_PARAM4),
        (wp(yaw_deg=360.0), ACCEPTED),
        (wp(yaw_deg=-360.0), ACCEPTED),
        (wp(yaw_deg=math.inf), mavlink.MAV_MISSION_INVALID_PARAM4),
        (wp(x_m=500.1), ACCEPTED),
        (wp(depth_m=-0.1), ACCEPTED),
        (wp(depth_m=math.nan), ACCEPTED),
        (wp(depth_m=math.inf), mavlink.MAV_MISSION_INVALID_PARAM7),
        (wp(param1=-1.0), ACCEPTED),
        (wp(param1=-math.inf), mavlink.MAV_MISSION_INVALID_PARAM1),
        (wp(param2=math.inf), mavlink.MAV_MISSION_INVALID_PARAM2),
        (wp(param3=math.inf), mavlink.MAV_MISSION_INVALID_PARAM3),
        (wp(command=mavlink.MAV_CMD_NAV_LOITER_UNLIM), mavlink.MAV_MISSION_UNSUPPORTED),
        (wp(frame=mavlink.MAV_FRAME_BODY_NED), mavlink.MAV_MISSION_UNSUPPORTED_FRAME),
        (wp(frame=mavlink.MAV_FRAME_GLOBAL_INT, x=900_000_001, y=0), mavlink.MAV_MISSION_INVALID_PARAM5_X),
        (wp(frame=mavlink.MAV_FRAME_GLOBAL_INT, x=0, y=1_800_000_001), mavlink.MAV_MISSION_INVALID_PARAM6_Y),
    ],
)
def test_format_checks_each_item(item: MissionItem, code: int) -> None:
    assert check_item(item, TYPE_MISSION, LIMITS) == code
    srv = MissionServer(LIMITS)
    upload(srv, [wp()])
    srv.take_changed()
    ack = upload(srv, [wp(), item, wp()]) if code else upload(srv, [item])
    assert only(ack).type == code
    if code:  # the stored plan is untouched
        assert len(srv.items(TYPE_MISSION)) == 1 and not srv.take_changed()


def test_global_frames_convert_about_origin_with_depth_minus_altitude() -> None:
    lat = round((LIMITS.origin_lat_deg + 100.0 / 111_319.49) * 1e7)
    lon = round(LIMITS.origin_lon_deg * 1e7)
    it = wp(frame=mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, x=lat, y=lon, z=-12.0)
    x_m, y_m, depth_m = item_position(it, LIMITS)
    assert x_m == pytest.approx(100.0, abs=0.05) and y_m == pytest.approx(0.0, abs=0.01) and depth_m == 12.0
    assert check_item(it, TYPE_MISSION, LIMITS) == mavlink.MAV_MISSION_ACCEPTED
    above = wp(frame=mavlink.MAV_FRAME_GLOBAL_INT, x=lat, y=lon, z=5.0)  # AMSL 5 m: depth -5 (validator's)
    assert item_position(above, LIMITS)[2] == -5.0
    assert goal_from_item(it, LIMITS).depth_m == 12.0


def test_legacy_mission_item_understood() -> None:
    srv = MissionServer(LIMITS)
    srv.handle(count_msg(1), GCS, 0.0)
    legacy = mavlink.MAVLink_mission_item_message(
        1, 1, 0, mavlink.MAV_FRAME_LOCAL_NED, 16, 0, 1, 0.0, 0.0, 0.0, 30.0, 12.5, -3.25, 4.0, TYPE_MISSION
    )
    assert only(judged(srv, srv.handle(legacy, GCS, 0.0), ACCEPTED)).type == mavlink.MAV_MISSION_ACCEPTED
    g = srv.mission().goals[0]
    assert (g.x_m, g.y_m, g.depth_m) == (12.5, -3.25, 4.0)


def test_fence_upload_gives_obstacles_and_checks_radius_format() -> None:
    srv = MissionServer(LIMITS)
    circle = wp(command=mavlink.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION, param1=3.0, x=50000, y=0, z=0.0)
    assert only(upload(srv, [circle], TYPE_FENCE)).type == mavlink.MAV_MISSION_ACCEPTED
    (o,) = srv.mission().obstacles
    assert (o.x_m, o.y_m, o.radius_m) == (5.0, 0.0, 3.0)
    bad = wp(command=mavlink.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION, param1=math.inf)
    assert only(upload(srv, [bad], TYPE_FENCE)).type == mavlink.MAV_MISSION_INVALID_PARAM1
    poly = wp(command=mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION, param1=4.0)
    assert only(upload(srv, [poly], TYPE_FENCE)).type == mavlink.MAV_MISSION_UNSUPPORTED
    assert len(srv.mission().obstacles) == 1


def test_unsupported_type_and_count_zero_clears_after_judging() -> None:
    srv = MissionServer(LIMITS)
    assert only(srv.handle(count_msg(1, mavlink.MAV_MISSION_TYPE_RALLY), GCS, 0.0)).type == (
        mavlink.MAV_MISSION_UNSUPPORTED
    )
    upload(srv, [wp()])
    assert srv.handle(count_msg(0), GCS, 0.0) == []
    c = srv.take_candidate()
    assert c is not None and c.plans == {TYPE_MISSION: ()} and c.mission_type == TYPE_MISSION
    assert only(srv.finish(ACCEPTED)).type == mavlink.MAV_MISSION_ACCEPTED
    assert srv.items(TYPE_MISSION) == ()


def test_one_uploader_at_a_time_others_denied_with_their_ids() -> None:
    srv = MissionServer(LIMITS)
    srv.handle(count_msg(2), GCS, 0.0)
    d = only(srv.handle(count_msg(1), OTHER, 0.0))
    assert d.type == mavlink.MAV_MISSION_DENIED and (d.target_system, d.target_component) == OTHER
    d = only(srv.handle(item_msg(0, wp()), OTHER, 0.0))
    assert d.type == mavlink.MAV_MISSION_DENIED
    clr = only(srv.handle(mavlink.MAVLink_mission_clear_all_message(1, 1, TYPE_MISSION), OTHER, 0.0))
    assert clr.type == mavlink.MAV_MISSION_DENIED
    assert srv.handle(item_msg(0, wp()), GCS, 0.0)[0].seq == 1  # the real uploader carries on


def test_out_of_order_items_rerequested_and_beyond_count_is_invalid_sequence() -> None:
    srv = MissionServer(LIMITS)
    srv.handle(count_msg(3), GCS, 0.0)
    r = only(srv.handle(item_msg(1, wp()), GCS, 0.0))
    assert r.get_type() == "MISSION_REQUEST_INT" and r.seq == 0
    assert srv.stats.out_of_sequence == 1
    r = only(srv.handle(item_msg(0, wp()), GCS, 0.0))
    assert r.seq == 1
    r = only(srv.handle(item_msg(0, wp()), GCS, 0.0))  # duplicate: ask for 1 again
    assert r.seq == 1
    assert only(srv.handle(item_msg(7, wp()), GCS, 0.0)).type == mavlink.MAV_MISSION_INVALID_SEQUENCE
    assert not srv.upload_in_progress


def test_rerequest_every_250ms_and_cancel_after_5s_keeps_old_plan() -> None:
    srv = MissionServer(LIMITS)
    upload(srv, [wp(1, 1, 1)])
    srv.handle(count_msg(2), GCS, 10.0)
    srv.handle(item_msg(0, wp(2, 2, 2)), GCS, 10.0)
    assert srv.poll(10.2) == []
    r = only(srv.poll(10.25))
    assert r.get_type() == "MISSION_REQUEST_INT" and r.seq == 1
    assert srv.next_deadline() == pytest.approx(10.5)
    t, n = 10.25, 0
    while srv.upload_in_progress:
        t += 0.25
        out = srv.poll(t)
        n += 1
    assert only(out).type == mavlink.MAV_MISSION_OPERATION_CANCELLED
    assert t == pytest.approx(15.0)
    assert [g.x_m for g in srv.mission().goals] == [1.0]


def test_resent_last_item_after_ack_answered_again_without_side_effects() -> None:
    srv = MissionServer(LIMITS)
    items = [wp(1, 1, 1), wp(2, 2, 2)]
    upload(srv, items)
    assert srv.take_changed()
    again = only(srv.handle(item_msg(1, items[1]), GCS, 1.0))
    assert again.type == mavlink.MAV_MISSION_ACCEPTED and srv.stats.acks_resent == 1
    assert not srv.take_changed() and srv.stats.uploads_accepted == 1
    assert srv.handle(item_msg(0, items[0]), GCS, 1.0) == []  # stray earlier item: ignored


def test_repeated_count_before_first_item_rerequests_item_zero() -> None:
    srv = MissionServer(LIMITS)
    srv.handle(count_msg(2), GCS, 0.0)
    assert only(srv.handle(count_msg(2), GCS, 0.1)).seq == 0


def test_refused_judgement_answers_its_code_and_keeps_old_plan() -> None:
    srv = MissionServer(LIMITS, stored={TYPE_MISSION: (wp(1, 1, 1),)})
    for code in (mavlink.MAV_MISSION_ERROR, mavlink.MAV_MISSION_INVALID_PARAM5_X):
        assert only(upload(srv, [wp(2, 2, 2)], result=code)).type == code
        assert [g.x_m for g in srv.mission().goals] == [1.0] and not srv.take_changed()
    assert srv.stats.uploads_rejected == 2 and not srv.upload_in_progress


def test_while_judging_resent_final_item_ignored_others_denied_then_one_final_ack() -> None:
    srv = MissionServer(LIMITS)
    items = [wp(1, 1, 1), wp(2, 2, 2)]
    srv.handle(count_msg(2), GCS, 0.0)
    srv.handle(item_msg(0, items[0]), GCS, 0.0)
    assert srv.handle(item_msg(1, items[1]), GCS, 0.0) == []
    assert srv.handle(item_msg(1, items[1]), GCS, 0.3) == []  # the GCS re-sends: still judging
    assert only(srv.handle(count_msg(1), OTHER, 0.3)).type == mavlink.MAV_MISSION_DENIED
    assert only(srv.handle(count_msg(1), GCS, 0.3)).type == mavlink.MAV_MISSION_DENIED  # busy
    clr = mavlink.MAVLink_mission_clear_all_message(1, 1, TYPE_MISSION)
    assert only(srv.handle(clr, GCS, 0.3)).type == mavlink.MAV_MISSION_DENIED
    assert srv.poll(100.0) == []  # no re-request or cancel while judging
    assert srv.take_candidate() is not None
    assert only(srv.finish(ACCEPTED)).type == mavlink.MAV_MISSION_ACCEPTED
    assert only(srv.handle(item_msg(1, items[1]), GCS, 1.0)).type == mavlink.MAV_MISSION_ACCEPTED  # lost ACK
    assert srv.finish(ACCEPTED) == []  # nothing to finish


def test_clear_all_clears_mission_and_fence() -> None:
    srv = MissionServer(LIMITS)
    upload(srv, [wp()])
    upload(srv, [wp(command=mavlink.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION, param1=1.0)], TYPE_FENCE)
    assert (
        srv.handle(mavlink.MAVLink_mission_clear_all_message(1, 1, mavlink.MAV_MISSION_TYPE_ALL), GCS, 0)
        == []
    )
    c = srv.take_candidate()  # one candidate for both: goals and fence are one unit
    assert c is not None and c.plans == {TYPE_MISSION: (), TYPE_FENCE: ()}
    assert c.mission_type == mavlink.MAV_MISSION_TYPE_ALL
    ack = only(srv.finish(ACCEPTED))
    assert ack.type == mavlink.MAV_MISSION_ACCEPTED and ack.mission_type == mavlink.MAV_MISSION_TYPE_ALL
    assert srv.mission().goals == () and srv.mission().obstacles == ()


def test_a_whole_plan_upload_is_one_candidate_and_a_refusal_keeps_both() -> None:
    ALL = mavlink.MAV_MISSION_TYPE_ALL
    circle = wp(x_m=-30.0, y_m=0.0, command=mavlink.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION, param1=2.0)
    srv = MissionServer(LIMITS)
    upload(srv, [wp(1.0)])
    upload(srv, [circle], TYPE_FENCE)
    new_circle = wp(x_m=0.0, y_m=0.0, command=mavlink.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION, param1=5.0)
    # GIVEN goals and a fence in one transfer of type ALL: every request and the final ACK are of type ALL
    out = srv.handle(count_msg(3, ALL), GCS, 0.0)
    for i, it in enumerate([wp(2.0), wp(3.0), new_circle]):
        assert only(out).get_type() == "MISSION_REQUEST_INT" and only(out).mission_type == ALL
        out = srv.handle(item_msg(i, it, ALL), GCS, 0.0)
    assert out == []
    c = srv.take_candidate()  # one candidate for both plans
    assert c is not None and c.mission_type == ALL
    assert c.plans == {TYPE_MISSION: (wp(2.0), wp(3.0)), TYPE_FENCE: (new_circle,)}
    # WHEN it is refused THEN neither plan changed
    ack = only(srv.finish(mavlink.MAV_MISSION_ERROR))
    assert ack.type == mavlink.MAV_MISSION_ERROR and ack.mission_type == ALL
    assert srv.items(TYPE_MISSION) == (wp(1.0),) and srv.items(TYPE_FENCE) == (circle,)
    # an item no plan takes ends it with the code of its plan's check; nothing changes
    poly = wp(command=mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION, param1=4.0)
    assert only(upload(srv, [wp(2.0), poly], ALL)).type == mavlink.MAV_MISSION_UNSUPPORTED
    # accepted: both replaced (goals only in it: the fence cleared); a count of 0 clears both
    assert only(upload(srv, [wp(4.0)], ALL)).type == ACCEPTED
    assert srv.items(TYPE_MISSION) == (wp(4.0),) and srv.items(TYPE_FENCE) == ()
    assert srv.handle(count_msg(0, ALL), GCS, 0.0) == []
    c = srv.take_candidate()
    assert c is not None and c.plans == {TYPE_MISSION: (), TYPE_FENCE: ()}


def test_messages_for_another_system_are_ignored() -> None:
    srv = MissionServer(LIMITS)
    assert srv.handle(mavlink.MAVLink_mission_count_message(7, 1, 1, 0), GCS, 0.0) == []


floats = st.one_of(st.floats(allow_nan=True, allow_infinity=True, width=32), st.just(math.nan))


@settings(max_examples=300, deadline=None)
@given(
    frame=st.integers(0, 21),
    command=st.sampled_from([16, 17, 5004, 0, 65535]),
    p=st.tuples(floats, floats, floats, floats),
    x=st.integers(-(2**31), 2**31 - 1),
    y=st.integers(-(2**31), 2**31 - 1),
    z=floats,
)
def test_random_items_never_crash_and_change_plan_only_when_valid(frame, command, p, x, y, z) -> None:
    srv = MissionServer(LIMITS, stored={TYPE_MISSION: (wp(1, 1, 1),)})
    it = MissionItem(frame, command, *p, x, y, z)
    ack = only(upload(srv, [it]))
    expected = check_item(it, TYPE_MISSION, LIMITS, seq=0)
    assert ack.type == expected
    goals = srv.mission().goals
    if expected == mavlink.MAV_MISSION_ACCEPTED and is_home_item(it, 0):
        assert goals == () and srv.items(TYPE_MISSION) == (it,)  # a lone home item: no goals
    elif expected == mavlink.MAV_MISSION_ACCEPTED:  # format only here: the validator judges the values
        assert len(goals) == 1 and srv.items(TYPE_MISSION) == (it,)
    else:
        assert [g.x_m for g in goals] == [1.0]


def test_the_same_ids_on_another_link_are_another_uploader() -> None:
    # GIVEN an upload from 255/190 over one link
    a = Sender(255, 190, (1, ("127.0.0.1", 40001)))
    b = Sender(255, 190, (1, ("127.0.0.1", 40002)))  # a second ground station with the stock ids
    srv = MissionServer(LIMITS)
    req = only(srv.handle(count_msg(2), a, 0.0))
    assert req.get_type() == "MISSION_REQUEST_INT" and srv.transfer_sender == a
    # WHEN the other starts its own, or answers the first one's request
    denied = only(srv.handle(count_msg(3), b, 0.0))
    stray = only(srv.handle(item_msg(0, wp(1.0)), b, 0.0))
    # THEN both are refused, with a reason for it, and the first upload goes on alone and is stored whole
    assert denied.type == stray.type == mavlink.MAV_MISSION_DENIED
    refusals = srv.take_refusals()
    assert [who for who, _ in refusals] == [b, b]
    assert "255/190 (the same ids, another link) is uploading" in refusals[0][1]
    assert only(srv.handle(item_msg(0, wp(5.0)), a, 0.0)).seq == 1
    out = judged(srv, srv.handle(item_msg(1, wp(6.0)), a, 0.0), ACCEPTED)
    assert only(out).type == ACCEPTED and [i.x for i in srv.items(TYPE_MISSION)] == [50000, 60000]
    assert srv.transfer_sender is None and srv.take_refusals() == []
