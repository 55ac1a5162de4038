"""SYS_STATUS says only what is known (issue 13, item 3): the geofence bits follow the mission's fence."""

from __future__ import annotations

from typing import Any

from pymavlink.dialects.v20 import common as mavlink

from onboard.adapters.mavlink.api import VehicleSnapshot
from onboard.adapters.mavlink.config import MavlinkConfig
from onboard.adapters.mavlink.telemetry import Telemetry
from onboard.core.mission.model import Obstacle

FENCE = mavlink.MAV_SYS_STATUS_GEOFENCE


def _bits(circles: tuple[Obstacle, ...], x_m: float, y_m: float) -> tuple[int, int, int]:
    transport: Any = None  # the bits are computed, not sent
    tel = Telemetry(MavlinkConfig(), transport, lambda: 0.0, lambda: (0, 0), fence_circles=lambda: circles)
    return tel._sensor_bits(VehicleSnapshot(x_m=x_m, y_m=y_m))


def test_no_fence_is_not_present_and_reads_healthy_so_no_station_sees_a_breach() -> None:
    assert _bits((), 0.0, 0.0) == (0, 0, FENCE)


def test_a_fence_is_present_enabled_and_healthy_until_the_vehicle_is_inside_a_circle() -> None:
    circle = (Obstacle(10.0, 0.0, 2.0),)
    assert _bits(circle, 0.0, 0.0) == (FENCE, FENCE, FENCE)
    assert _bits(circle, 9.0, 0.5) == (FENCE, FENCE, 0)  # breached
    assert _bits(circle, float("nan"), float("nan")) == (FENCE, FENCE, FENCE)  # position unknown
