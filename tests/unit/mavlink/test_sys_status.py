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


def test_the_judged_sensors_are_present_and_a_named_fault_makes_its_bit_unhealthy() -> None:
    """Issue 24 item 5: each fault the vehicle names has its SYS_STATUS health bit (compass 3D_MAG, depth
    ABSOLUTE_PRESSURE, fixes GPS, DVL VISION_POSITION, propeller PROPULSION)."""
    from onboard.adapters.mavlink.telemetry import fault_bits
    from onboard.core.safety.diagnosis import FaultFlag

    present, unhealthy = fault_bits(0)
    mag = mavlink.MAV_SYS_STATUS_SENSOR_3D_MAG
    assert present & mag and present & mavlink.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE and unhealthy == 0
    assert fault_bits(FaultFlag.COMPASS_BIAS)[1] == mag
    assert fault_bits(FaultFlag.DEPTH_STUCK | FaultFlag.FIX_OUTAGE)[1] == (
        mavlink.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE | mavlink.MAV_SYS_STATUS_SENSOR_GPS
    )
    assert fault_bits(FaultFlag.THRUST_LOSS)[1] == mavlink.MAV_SYS_STATUS_SENSOR_PROPULSION
