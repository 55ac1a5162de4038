"""The bench's vehicle starts drifting with the water (issue 23 item 4: drift from rest).

A free vehicle at sea before its mission drifts with the water. The old bench started it at rest over ground
in moving water: it was set 4.4-4.9 m sideways in 0.5 m/s before its fins bit, and its DVL showed no current
before START, so the onboard's first plan ignored the current.
"""

from __future__ import annotations

import math

from hil_sim.bench_program import Bench, HilConfig, InitialConfig, WaterCurrentConfig
from hil_sim.model.sensors import DvlMeasurement, PositionFix

SPEED_MPS, TOWARDS_DEG, YAW_DEG = 0.4, 90.0, 30.0


def _bench(held: bool = False, speed_mps: float = SPEED_MPS) -> Bench:
    return Bench(
        HilConfig(
            initial=InitialConfig(2.0, -3.0, 1.5, YAW_DEG, held=held),
            current=WaterCurrentConfig(speed_mps, TOWARDS_DEG),
        )
    )


def _ned(u_mps: float, v_mps: float, yaw_deg: float) -> tuple[float, float]:
    c, s = math.cos(math.radians(yaw_deg)), math.sin(math.radians(yaw_deg))
    return c * u_mps - s * v_mps, s * u_mps + c * v_mps


def test_the_vehicle_starts_with_the_water_and_its_dvl_shows_the_drift_before_the_start() -> None:
    # GIVEN the bench in 0.4 m/s towards the east, the vehicle heading 30 deg
    bench = _bench()
    # THEN at t = 0 its velocity over ground is the current (zero through the water), no rotation
    body = bench.state.body
    vn, ve = _ned(body.u_mps, body.v_mps, YAW_DEG)
    assert (round(vn, 9), round(ve, 9), round(body.w_mps, 9)) == (0.0, SPEED_MPS, 0.0)
    assert (body.p_radps, body.q_radps, body.r_radps) == (0.0, 0.0, 0.0)
    assert (body.x_m, body.y_m, body.z_m) == (2.0, -3.0, 1.5)
    # AND the sensors sampled while the onboard waits (time stands still) show the drift at the start point
    idle = bench.idle_measurements()
    dvl = next(x for x in idle if isinstance(x, DvlMeasurement))
    fix = next(x for x in idle if isinstance(x, PositionFix))
    dvl_n, dvl_e = _ned(dvl.u_mps, dvl.v_mps, YAW_DEG)
    assert math.hypot(dvl_n - 0.0, dvl_e - SPEED_MPS) < 0.05, (dvl_n, dvl_e)
    assert math.hypot(fix.x_m - 2.0, fix.y_m + 3.0) < 0.05


def test_with_propeller_off_and_fins_neutral_it_drifts_with_the_water_not_sideways_from_rest() -> None:
    # GIVEN the drifting start and the old held start, nothing commanded (fins neutral, propeller 0)
    drifting, held = _bench(), _bench(held=True)
    for bench in (drifting, held):
        for _ in range(200):  # 10 s
            bench.period(integrate=True)
    # THEN the drifting vehicle went with the water (0.4 m/s x 10 s east), the held one lagged behind it
    assert abs(drifting.state.body.y_m - (-3.0 + SPEED_MPS * 10.0)) < 0.05, drifting.state.body.y_m
    assert abs(drifting.state.body.x_m - 2.0) < 0.05, drifting.state.body.x_m
    assert held.state.body.y_m < drifting.state.body.y_m - 0.3


def test_in_still_water_the_start_is_the_same_as_before() -> None:
    assert _bench(speed_mps=0.0).state == _bench(held=True, speed_mps=0.0).state
