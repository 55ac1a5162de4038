"""Unit tests of the one limiter: angle/speed limits, rate limits, roll priority, NaN, dt = 0, flags."""

from __future__ import annotations

import math

import pytest

from onboard.core.control import NEUTRAL, ActuatorCommand, ActuatorFlag, ActuatorLimits, saturate

LIM = ActuatorLimits(fin_rate_limit_degps=0.0, propeller_rate_limit_rps_per_s=0.0)  # no rate limits
DEG = math.radians(1.0)


@pytest.mark.parametrize(
    ("desired", "expected", "flag"),
    [
        (ActuatorCommand(30 * DEG, 0, 0, 10), ActuatorCommand(20 * DEG, 0, 0, 10), ActuatorFlag.RUDDER_LIMIT),
        (ActuatorCommand(-30 * DEG, 0, 0, 10), ActuatorCommand(-20 * DEG, 0, 0, 10),
         ActuatorFlag.RUDDER_LIMIT),
        (ActuatorCommand(0, 25 * DEG, 25 * DEG, 10), ActuatorCommand(0, 20 * DEG, 20 * DEG, 10),
         ActuatorFlag.STERN_LIMIT),
        (ActuatorCommand(0, -25 * DEG, -25 * DEG, 10), ActuatorCommand(0, -20 * DEG, -20 * DEG, 10),
         ActuatorFlag.STERN_LIMIT),
        (ActuatorCommand(0, 0, 0, 40), ActuatorCommand(0, 0, 0, 30), ActuatorFlag.PROPELLER_LIMIT),
        (ActuatorCommand(0, 0, 0, -5), ActuatorCommand(0, 0, 0, 0), ActuatorFlag.PROPELLER_LIMIT),
        (ActuatorCommand(5 * DEG, 2 * DEG, 2 * DEG, 10), ActuatorCommand(5 * DEG, 2 * DEG, 2 * DEG, 10),
         ActuatorFlag(0)),
    ],
)  # fmt: skip
def test_angle_and_speed_limits_set_flags(
    desired: ActuatorCommand, expected: ActuatorCommand, flag: ActuatorFlag
) -> None:
    # GIVEN a desired command  WHEN it is saturated  THEN it is clamped and exactly that limit is flagged
    out = saturate(desired, NEUTRAL, LIM, 0.05)
    assert out.rudder_rad == pytest.approx(expected.rudder_rad)
    assert out.stern_port_rad == pytest.approx(expected.stern_port_rad)
    assert out.stern_starboard_rad == pytest.approx(expected.stern_starboard_rad)
    assert out.propeller_rps == pytest.approx(expected.propeller_rps)
    assert out.flags == flag


def test_pitch_has_priority_over_roll_on_the_split_stern() -> None:
    # GIVEN a stern command of 15 deg plus a roll differential of 10 deg (planes would be 5 and 25 deg)
    desired = ActuatorCommand(0.0, 5 * DEG, 25 * DEG, 0.0)
    # WHEN saturated
    out = saturate(desired, NEUTRAL, LIM, 0.05)
    # THEN the common stays 15 deg, the differential shrinks to 5 deg, no plane beyond 20 deg
    assert out.stern_rad == pytest.approx(15 * DEG)
    assert out.roll_diff_rad == pytest.approx(5 * DEG)
    assert max(abs(out.stern_port_rad), abs(out.stern_starboard_rad)) <= 20 * DEG + 1e-12
    assert out.flags == ActuatorFlag.ROLL_LIMIT


@pytest.mark.parametrize(
    ("desired", "expected", "flag"),
    [
        (ActuatorCommand(20 * DEG, 0, 0, 0), ActuatorCommand(3 * DEG, 0, 0, 0), ActuatorFlag.RUDDER_RATE),
        (ActuatorCommand(0, -10 * DEG, 10 * DEG, 0), ActuatorCommand(0, -3 * DEG, 3 * DEG, 0),
         ActuatorFlag.STERN_RATE),
        (ActuatorCommand(0, 0, 0, 25), ActuatorCommand(0, 0, 0, 1), ActuatorFlag.PROPELLER_RATE),
        (ActuatorCommand(2 * DEG, 0, 0, 0.5), ActuatorCommand(2 * DEG, 0, 0, 0.5), ActuatorFlag(0)),
    ],
)  # fmt: skip
def test_rate_limits(desired: ActuatorCommand, expected: ActuatorCommand, flag: ActuatorFlag) -> None:
    # GIVEN 60 deg/s fin and 20 rps/s propeller rate limits, from neutral, dt = 0.05 s
    limits = ActuatorLimits(fin_rate_limit_degps=60.0, propeller_rate_limit_rps_per_s=20.0)
    # WHEN a step is commanded
    out = saturate(desired, NEUTRAL, limits, 0.05)
    # THEN each actuator moves at most rate * dt, flagged
    assert out.rudder_rad == pytest.approx(expected.rudder_rad)
    assert out.stern_port_rad == pytest.approx(expected.stern_port_rad)
    assert out.stern_starboard_rad == pytest.approx(expected.stern_starboard_rad)
    assert out.propeller_rps == pytest.approx(expected.propeller_rps)
    assert out.flags == flag


@pytest.mark.parametrize("dt_s", [0.0, -0.1, math.nan])
def test_dt_zero_or_bad_holds_previous(dt_s: float) -> None:
    # GIVEN a previous command  WHEN dt_s is 0 / negative / NaN  THEN the previous command is held
    prev = ActuatorCommand(5 * DEG, 1 * DEG, 1 * DEG, 10.0)
    out = saturate(ActuatorCommand(10 * DEG, 0, 0, 20.0), prev, ActuatorLimits(), dt_s)
    assert (out.rudder_rad, out.stern_port_rad, out.propeller_rps) == pytest.approx(
        (prev.rudder_rad, prev.stern_port_rad, prev.propeller_rps)
    )


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
@pytest.mark.parametrize("field", range(4))
def test_nan_in_neutral_out(bad: float, field: int) -> None:
    # GIVEN a desired command with one non-finite value
    values = [1 * DEG, 1 * DEG, 1 * DEG, 10.0]
    values[field] = bad
    # WHEN saturated  THEN neutral (immediately, no rate limit) with NAN_INPUT
    out = saturate(
        ActuatorCommand(values[0], values[1], values[2], values[3]),
        ActuatorCommand(0.1, 0.1, 0.1, 20.0),
        ActuatorLimits(),
        0.05,
    )
    assert (out.rudder_rad, out.stern_port_rad, out.stern_starboard_rad, out.propeller_rps) == (0, 0, 0, 0)
    assert out.flags == ActuatorFlag.NAN_INPUT
