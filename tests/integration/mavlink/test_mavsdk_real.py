"""MAVSDK-Python itself (the native binding, its asyncio API) against the in-process vehicle over TCP, checked
the way a MAVSDK user sees it: connect, telemetry, MissionRaw upload / download, Action.arm, MissionRaw
start / pause / start, Action.return_to_launch.

One known limit is asserted on purpose, so that a change on either side is noticed: Telemetry.flight_mode is
always ``FlightMode.UNKNOWN``. The HEARTBEAT says MAV_AUTOPILOT_GENERIC with ArduSub's mode numbers in
``custom_mode`` (:mod:`onboard.adapters.mavlink.modes`); MAVSDK decodes every autopilot that is not ArduPilot
as PX4 (``to_flight_mode_from_custom_mode``, cpp/src/mavsdk/core/flight_mode.cpp), and ArduSub's small numbers
have no PX4 main mode. The vehicle's own state is read from its core (``loop.ap.status.state``) and from the
snapshot its link publishes (what its HEARTBEAT says).

MAVSDK runs in this process: ``asyncio.run`` in the test, every await bounded by ``asyncio.wait_for``, the
plugins and the Mavsdk instance destroyed at the end, and the test checks that none of MAVSDK's threads
(native or executor) is left.
"""

from __future__ import annotations

import asyncio
import math
import os
import threading
import time
from collections.abc import AsyncGenerator, AsyncIterator, Awaitable, Callable, Iterator
from pathlib import Path
from typing import Any, TypeVar

import pytest

# A plain import, not importorskip: mavsdk is a dev dependency, so without it this module fails to collect.
from mavsdk.asyncio import Autopilot, ComponentType, Configuration, Mavsdk, System
from mavsdk.asyncio import Vehicle as MavsdkVehicle
from mavsdk.asyncio.plugins.action import ActionAsync, ActionResult
from mavsdk.asyncio.plugins.mission_raw import MissionItem, MissionProgress, MissionRawAsync, MissionRawResult
from mavsdk.asyncio.plugins.telemetry import FlightMode, TelemetryAsync

from onboard.core.mission.state import MissionState
from tests.integration.mavlink.conftest import Vehicle

T = TypeVar("T")

ORIGIN_LAT_DEG, ORIGIN_LON_DEG = 35.1, 129.04  # MavlinkConfig's default origin
MAV_FRAME_LOCAL_NED, MAV_CMD_NAV_WAYPOINT = 1, 16
#: (north_m, east_m, depth_m): 300 m legs, so the mission is still on its first goal when the test ends.
GOALS = ((300.0, 0.0, 2.0), (300.0, 300.0, 2.0))
STEP_S = 10.0  # bound of one MAVSDK call or one wait
WHOLE_S = 40.0  # bound of the whole MAVSDK session


def native_threads() -> int:
    """Threads of this process that Python did not start (MAVSDK's io and callback threads are such). The
    vehicle's own threads (the link, the loop, its planner and mission-check workers) are Python threads."""
    return len(os.listdir("/proc/self/task")) - threading.active_count()


def executor_threads() -> list[str]:
    return [t.name for t in threading.enumerate() if t.name.startswith("asyncio_")]


@pytest.fixture
def vehicle(tmp_path: Path) -> Iterator[Vehicle]:
    # tcpin on port 0: the listening port is the vehicle's own (v.port), no window for another process.
    # A 10 Hz heartbeat so that MAVSDK sees each state change (armed, flight mode) within ~0.1 s.
    v = Vehicle(tmp_path / "state", endpoints=("tcpin:127.0.0.1:0",), heartbeat_rate_hz=10.0).start()
    yield v
    v.stop()


def mission_items(goals: tuple[tuple[float, float, float], ...] = GOALS) -> list[MissionItem]:
    """MISSION_ITEM_INT in MAV_FRAME_LOCAL_NED as MAVSDK sends it: x, y in metres * 1e4, z the depth in m."""
    return [
        MissionItem(
            seq=i,
            frame=MAV_FRAME_LOCAL_NED,
            command=MAV_CMD_NAV_WAYPOINT,
            current=1 if i == 0 else 0,
            autocontinue=1,
            param1=0.0,
            param2=math.nan,
            param3=0.0,
            param4=math.nan,
            x=round(north_m * 1e4),
            y=round(east_m * 1e4),
            z=depth_m,
            mission_type=0,
        )
        for i, (north_m, east_m, depth_m) in enumerate(goals)
    ]


def item_key(it: MissionItem) -> tuple[int, int, int, int, int, float]:
    return (it.seq, it.frame, it.command, it.x, it.y, it.z)


async def bounded(aw: Awaitable[T], what: str, timeout_s: float = STEP_S) -> T:
    try:
        return await asyncio.wait_for(aw, timeout_s)
    except TimeoutError:
        raise AssertionError(f"{what}: nothing within {timeout_s} s") from None


async def first(
    agen: AsyncGenerator[T, None], pred: Callable[[T], bool], what: str, timeout_s: float = STEP_S
) -> T:
    """The first value of a MAVSDK subscription that satisfies ``pred``; the subscription is closed after."""

    async def scan() -> T:
        async for x in agen:
            if pred(x):
                return x
        raise AssertionError(f"{what}: the subscription ended")

    try:
        return await bounded(scan(), what, timeout_s)
    finally:
        await agen.aclose()


async def poll(get: Callable[[], Awaitable[T]], pred: Callable[[T], bool], what: str) -> T:
    """Call a getter until ``pred`` holds; fails with the last value."""
    last: list[T] = []

    async def loop() -> T:
        while True:
            last[:] = [await get()]
            if pred(last[0]):
                return last[0]
            await asyncio.sleep(0.05)

    try:
        return await asyncio.wait_for(loop(), STEP_S)
    except TimeoutError:
        raise AssertionError(f"{what}: still {last} after {STEP_S} s") from None


class FlightModes:
    """Every flight mode MAVSDK reports (one per HEARTBEAT), from a background subscription."""

    def __init__(self, telemetry: TelemetryAsync) -> None:
        self.seen: list[FlightMode] = []
        self._task = asyncio.create_task(self._watch(telemetry.subscribe_flight_mode()))

    async def _watch(self, agen: AsyncIterator[FlightMode]) -> None:
        async for mode in agen:
            self.seen.append(mode)

    async def after(self, n: int) -> list[FlightMode]:
        """The next ``n`` reports (from heartbeats sent after the caller's moment)."""
        k = len(self.seen)

        async def wait() -> None:
            while len(self.seen) < k + n:
                await asyncio.sleep(0.02)

        await bounded(wait(), f"{n} flight-mode reports")
        return self.seen[k:]

    async def close(self) -> None:
        self._task.cancel()  # the generator's finally unsubscribes
        await asyncio.gather(self._task, return_exceptions=True)


async def vehicle_state(v: Vehicle, state: MissionState) -> None:
    """Wait until the core is in ``state`` and the link publishes it (its HEARTBEATs say it from then on)."""

    async def now() -> tuple[MissionState, MissionState]:
        return v.loop.ap.status.state, v.link.telemetry.snapshot().state

    await poll(now, lambda s: s == (state, state), f"vehicle state {state.name}")


async def session(v: Vehicle) -> None:
    sdk = Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))
    plugins: list[Any] = []
    modes: FlightModes | None = None
    try:
        await bounded(sdk.add_any_connection(f"tcpout://127.0.0.1:{v.port}"), "add_any_connection")
        found = await bounded(sdk.first_autopilot(timeout_s=5.0), "first_autopilot")
        assert found is not None, "MAVSDK found no autopilot"
        system: System = found
        assert await bounded(system.is_connected(), "is_connected")
        assert await bounded(system.autopilot_type(), "autopilot_type") == Autopilot.GENERIC
        assert await bounded(system.vehicle_type(), "vehicle_type") == MavsdkVehicle.SUBMARINE

        tel, act, mr = TelemetryAsync(system), ActionAsync(system), MissionRawAsync(system)
        plugins += [tel, act, mr]
        modes = FlightModes(tel)

        # GIVEN the vehicle at rest at the origin, disarmed
        pos = await first(tel.subscribe_position(), lambda p: True, "position")
        assert pos.latitude_deg == pytest.approx(ORIGIN_LAT_DEG, abs=1e-6)
        assert pos.longitude_deg == pytest.approx(ORIGIN_LON_DEG, abs=1e-6)
        assert pos.relative_altitude_m == pytest.approx(0.0, abs=0.01)
        assert await first(tel.subscribe_armed(), lambda a: True, "armed") is False
        assert set(await modes.after(3)) == {FlightMode.UNKNOWN}  # IDLE

        # WHEN a 2-goal local-NED mission is uploaded THEN it is accepted and reads back the same
        items = mission_items()
        assert await bounded(mr.upload_mission(items), "upload_mission", 15.0) == MissionRawResult.SUCCESS
        back = await bounded(mr.download_mission(), "download_mission", 15.0)
        assert [item_key(it) for it in back] == [item_key(it) for it in items]

        # WHEN armed THEN MAVSDK sees armed, the vehicle is ARMED
        assert await bounded(act.arm(), "arm") == ActionResult.SUCCESS
        assert await first(tel.subscribe_armed(), lambda a: a, "armed True")
        await vehicle_state(v, MissionState.ARMED)
        assert set(await modes.after(3)) == {FlightMode.UNKNOWN}

        # WHEN started THEN the vehicle RUNS goal 0 of 2
        assert await bounded(mr.start_mission(), "start_mission") == MissionRawResult.SUCCESS
        await vehicle_state(v, MissionState.RUNNING)
        progress = await poll(mr.mission_progress, lambda p: p.current == 0, "mission progress at goal 0")
        assert (progress.current, progress.total) == (0, 2)
        assert set(await modes.after(3)) == {FlightMode.UNKNOWN}

        # WHEN paused THEN HOLD, still armed; WHEN started again THEN RUNNING
        assert await bounded(mr.pause_mission(), "pause_mission") == MissionRawResult.SUCCESS
        await vehicle_state(v, MissionState.HOLD)
        assert await bounded(tel.armed(), "armed")
        assert set(await modes.after(3)) == {FlightMode.UNKNOWN}
        assert await bounded(mr.start_mission(), "start_mission again") == MissionRawResult.SUCCESS
        await vehicle_state(v, MissionState.RUNNING)
        assert set(await modes.after(3)) == {FlightMode.UNKNOWN}

        # WHEN return to launch THEN ABORT (back to the surface) and disarmed
        assert await bounded(act.return_to_launch(), "return_to_launch") == ActionResult.SUCCESS
        await vehicle_state(v, MissionState.ABORT)
        assert await first(tel.subscribe_armed(), lambda a: not a, "armed False") is False
        assert set(await modes.after(3)) == {FlightMode.UNKNOWN}
        still: MissionProgress = await bounded(mr.mission_progress(), "mission_progress")
        assert (still.current, still.total) == (0, 2)  # aborted on the first leg

        # THEN over the whole session MAVSDK never decoded a flight mode (the documented limit)
        assert len(modes.seen) >= 18 and set(modes.seen) == {FlightMode.UNKNOWN}, modes.seen
    finally:
        if modes is not None:
            await modes.close()
        for p in plugins:
            p.destroy()
        sdk.destroy()


def test_mavsdk_flies_the_vehicle_as_a_mavsdk_user_sees_it(vehicle: Vehicle) -> None:
    native_before = native_threads()
    asyncio.run(asyncio.wait_for(session(vehicle), WHOLE_S))
    # THEN nothing of MAVSDK is left: its native threads end in Mavsdk.destroy, asyncio.run joins the
    # executor threads that ran its blocking calls
    t_end = time.monotonic() + 2.0
    while native_threads() > native_before and time.monotonic() < t_end:
        time.sleep(0.05)
    assert native_threads() <= native_before
    assert executor_threads() == []


async def to_the_end(v: Vehicle) -> bool:
    """A short mission flown to COMPLETE; what MAVSDK's is_mission_finished says after its last progress."""
    sdk = Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))
    plugins: list[Any] = []
    try:
        await bounded(sdk.add_any_connection(f"tcpout://127.0.0.1:{v.port}"), "add_any_connection")
        found = await bounded(sdk.first_autopilot(timeout_s=5.0), "first_autopilot")
        assert found is not None, "MAVSDK found no autopilot"
        act, mr = ActionAsync(found), MissionRawAsync(found)
        plugins += [act, mr]
        items = mission_items(((20.0, 0.0, 2.0), (20.0, 20.0, 2.0)))
        assert await bounded(mr.upload_mission(items), "upload_mission", 15.0) == MissionRawResult.SUCCESS
        assert await bounded(act.arm(), "arm") == ActionResult.SUCCESS
        await vehicle_state(v, MissionState.ARMED)
        assert await bounded(mr.start_mission(), "start_mission") == MissionRawResult.SUCCESS
        done = await first(
            mr.subscribe_mission_progress(), lambda p: p.current >= p.total > 0, "last goal", 25.0
        )
        assert (done.current, done.total) == (2, 2)
        return await poll(mr.is_mission_finished, bool, "is_mission_finished")
    finally:
        for p in plugins:
            p.destroy()
        sdk.destroy()


def test_mavsdk_hears_the_mission_finish_when_it_does(tmp_path: Path) -> None:
    """MAVSDK says the mission is finished once it has heard the last goal reached, without waiting for a
    periodic MISSION_CURRENT: the stream is off here (``mission_current_rate_hz`` 0), so what MAVSDK learns
    comes from what the vehicle sends on the change (MISSION_ITEM_REACHED, then HEARTBEAT and
    MISSION_CURRENT). Checked by state, not by how many seconds it took (that was a wall-clock assert)."""
    vehicle = Vehicle(
        tmp_path / "state",
        endpoints=("tcpin:127.0.0.1:0",),
        heartbeat_rate_hz=10.0,
        mission_current_rate_hz=0.0,
    ).start()
    try:
        assert asyncio.run(asyncio.wait_for(to_the_end(vehicle), WHOLE_S))
        assert vehicle.loop.ap.status.state is MissionState.COMPLETE
    finally:
        vehicle.stop()
