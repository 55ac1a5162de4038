"""Issue 21 rows 15 and 16, "values that mean something", on the real link over real sockets.

Row 15: a parameter whose 0 is refused refuses every value below the meaningful minimum its configuration
declares (a subnormal float32 such as 1.4e-45, or 1e-10, is no rudder limit, propeller limit or timeout):
PARAM_VALUE answers the value in force and a STATUSTEXT names the minimum.

Row 16: a goal's yaw (MISSION_ITEM_INT param4, degrees) is NaN (free) or within [-360, 360]: a MAVSDK
MissionRaw upload and a pymavlink one with yaw 999 are refused with MAV_MISSION_INVALID_PARAM4 and a
STATUSTEXT naming the goal; 360, -360 and NaN are accepted.
"""

from __future__ import annotations

import asyncio
import dataclasses
import json
import math
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from mavsdk.asyncio import ComponentType, Configuration, Mavsdk
from mavsdk.asyncio.plugins.mission_raw import MissionRawAsync, MissionRawError, MissionRawResult
from pymavlink.dialects.v20 import common as mavlink

from groundstation.mavclient import MavClient
from groundstation.mission_files import goal_item, obstacle_item
from onboard.adapters.mavlink.storage import load_plan
from onboard.app.standalone import bus_limits
from onboard.app.store import StateStore
from onboard.core.params import ParamError, apply_param
from tests.integration.mavlink.conftest import Vehicle
from tests.integration.mavlink.test_mavsdk_real import bounded, mission_items

TINY_VALUES = (1.4e-45, 1e-10)  # the smallest float32 subnormal, and a tiny normal one


def zero_refused(v: Vehicle) -> list[str]:
    """The parameters whose 0 the running core refuses (asked of the core's own rule, not listed here)."""
    config, bus = v.loop.ap.config, bus_limits()
    out = []
    for spec in v.link.params.specs:
        try:
            apply_param(config, spec.name, 0.0, bus)
        except ParamError:
            out.append(spec.name)
    return out


def wait_text(c: MavClient, name: str, t_s: float, timeout_s: float = 10.0) -> str:
    """The vehicle's first text since ``t_s`` that names ``name`` (waiting for it)."""
    deadline = time.monotonic() + timeout_s
    while True:
        texts = [t.text for t in c.texts_since(t_s) if name in t.text]
        if texts:
            return texts[0]
        if time.monotonic() > deadline:
            raise AssertionError(f"no text naming {name} within {timeout_s} s")
        c.recv(0.05)


# ---- row 15 ----------------------------------------------------------------------------------------
def test_a_tiny_value_is_refused_where_zero_is_and_the_reason_names_the_minimum(vehicle: Vehicle) -> None:
    names = zero_refused(vehicle)
    assert {"LIM_RUDDER_DEG", "LIM_RPS_MAX", "FS_NAV_TMO_S"} <= set(names)
    specs = {s.name: s for s in vehicle.link.params.specs}
    with vehicle.client() as c:
        before = c.param_list()
        for name in names:
            for tiny in TINY_VALUES:
                t_sent = time.monotonic()
                # WHEN a ground station sets the parameter to a tiny positive value
                ok, in_force = c.param_set(name, tiny)
                # THEN it is refused: PARAM_VALUE says the value in force, and a STATUSTEXT names the minimum
                assert not ok, f"{name} = {tiny} was accepted"
                assert in_force == pytest.approx(before[name]), name
                text = wait_text(c, name, t_sent)
                minimum = specs[name].min
                assert minimum > 0.0 and f"{minimum:g}" in text, (name, minimum, text)
        assert c.param_list() == pytest.approx(before)


# ---- row 16 ----------------------------------------------------------------------------------------
@pytest.fixture
def tcp_vehicle(tmp_path: Path) -> Iterator[Vehicle]:
    v = Vehicle(tmp_path / "state", endpoints=("tcpin:127.0.0.1:0",), heartbeat_rate_hz=10.0).start()
    yield v
    v.stop()


async def mavsdk_upload(v: Vehicle, yaws_deg: list[float]) -> MissionRawResult:
    """A MissionRaw upload of two local goals with these yaws (param4, deg); MAVSDK's result."""
    sdk = Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))
    mr: MissionRawAsync | None = None
    try:
        await bounded(sdk.add_any_connection(f"tcpout://127.0.0.1:{v.port}"), "add_any_connection")
        system = await bounded(sdk.first_autopilot(timeout_s=5.0), "first_autopilot")
        assert system is not None, "MAVSDK found no autopilot"
        mr = MissionRawAsync(system)
        items = mission_items(((10.0, 0.0, 1.0), (10.0, 10.0, 1.0)))
        for it, yaw in zip(items, yaws_deg, strict=True):
            it.param4 = yaw
        try:
            return await bounded(mr.upload_mission(items), "upload_mission", 15.0)
        except MissionRawError as exc:
            return exc.result
    finally:
        if mr is not None:
            mr.destroy()
        sdk.destroy()


def test_mavsdk_missionraw_upload_with_yaw_999_is_refused(tcp_vehicle: Vehicle) -> None:
    # WHEN MAVSDK uploads goal 1 with yaw 999 deg THEN the upload fails and nothing is stored
    result = asyncio.run(asyncio.wait_for(mavsdk_upload(tcp_vehicle, [0.0, 999.0]), 40.0))
    assert result != MissionRawResult.SUCCESS, result
    assert tcp_vehicle.link.mission().goals == ()
    # WHEN the yaw is 360 THEN it is accepted
    result = asyncio.run(asyncio.wait_for(mavsdk_upload(tcp_vehicle, [-360.0, 360.0]), 40.0))
    assert result == MissionRawResult.SUCCESS, result
    assert len(tcp_vehicle.link.mission().goals) == 2


@pytest.mark.parametrize("yaw_deg", [999.0, -360.5, 360.001, 1e30, -1e30])
def test_upload_with_a_yaw_outside_360_is_invalid_param4_and_names_the_goal(
    vehicle: Vehicle, yaw_deg: float
) -> None:
    with vehicle.client() as c:
        result = c.upload([goal_item(10, 0, 1, None), goal_item(10, 10, 1, yaw_deg)])
        assert not result.ok and result.result_name == "MAV_MISSION_INVALID_PARAM4", result
        assert "goal 1" in result.reason and "yaw" in result.reason and "360" in result.reason, result.reason
        assert vehicle.link.mission().goals == ()


def test_upload_with_yaw_360_minus_360_and_nan_is_accepted(vehicle: Vehicle) -> None:
    with vehicle.client() as c:
        goals = [goal_item(10, 0, 1, 360.0), goal_item(10, 10, 1, -360.0), goal_item(0, 10, 1, None)]
        result = c.upload(goals)
        assert result.ok, result
        got = c.download()
        assert [g.param4 for g in got[:2]] == [360.0, -360.0] and math.isnan(got[2].param4)
    yaws = [g.yaw_rad for g in vehicle.link.mission().goals]
    assert yaws[0] == pytest.approx(0.0, abs=1e-12) and yaws[1] == pytest.approx(0.0, abs=1e-12)
    assert yaws[2] is None


def test_mavlink_fence_items_keep_param4_free(vehicle: Vehicle) -> None:
    """The yaw rule is a goal's: a fence item's param4 is not a yaw."""
    with vehicle.client() as c:
        fence = mavlink.MAV_MISSION_TYPE_FENCE
        item = dataclasses.replace(obstacle_item(50, 50, 2), param4=999.0)
        assert c.upload([item], fence).ok


def test_a_persisted_plan_with_yaw_999_is_set_aside_with_the_reason(tmp_path: Path) -> None:
    """The persisted door: a mission file in the state directory whose goal says yaw 999 (edited, or left by
    an older version) is not flown after a restart; it is set aside and the reason names the item."""
    v = Vehicle(tmp_path / "state").start()
    try:
        with v.client() as c:
            assert c.upload([goal_item(10, 0, 1, None), goal_item(10, 10, 1, 90.0)]).ok
    finally:
        v.stop()
    saved = tmp_path / "state" / "mission.json"
    data = json.loads(saved.read_text())
    data["items"][1]["param4"] = 999.0
    saved.write_text(json.dumps(data))
    store = StateStore(tmp_path / "state")
    assert load_plan(store, mavlink.MAV_MISSION_TYPE_MISSION) is None
    (why,) = store.quarantined()
    assert "item 1" in why and "999" in why, why
    v2 = Vehicle(tmp_path / "state").start()
    try:
        assert v2.link.mission().goals == ()
    finally:
        v2.stop()
