"""Unit tests of the failsafes: each check, the loop late for too long, logging once, the abort command."""

from __future__ import annotations

import dataclasses
import math

import pytest

from auv_common.config import ConfigError, from_table
from onboard.core.control import ActuatorLimits, saturate
from onboard.core.nav import NavCondition, NavState, nav_state_at
from onboard.core.safety.failsafe import (
    ABORT_PITCH_MAX_RAD,
    FailsafeFlag,
    FailsafeParams,
    FailsafeState,
    abort_command,
    check,
)
from onboard.protocol.messages import ABORT_STERN_DEG

P = FailsafeParams(max_depth_m=10.0, area_x_min_m=-50, area_x_max_m=50, area_y_min_m=-20, area_y_max_m=20)
OK = nav_state_at(0.0, 0.0, 1.0)


def test_healthy_navigation_passes() -> None:
    result, _ = check(OK, 0.0, FailsafeState(), P)
    assert not result.abort and result.flags == FailsafeFlag(0) and result.reason == ""


@pytest.mark.parametrize(
    ("nav", "flag"),
    [
        (dataclasses.replace(OK, conditions=NavCondition.POSITION_INVALID), FailsafeFlag.NAV_STALE),
        (dataclasses.replace(OK, conditions=NavCondition.AHRS_STALE), FailsafeFlag.NAV_STALE),
        # stale: older than FS_NAV_TMO_S, which the estimator applies (tests/unit/nav/test_nav_timeout.py)
        (
            dataclasses.replace(OK, depth_age_s=1.5, conditions=NavCondition.DEPTH_STALE),
            FailsafeFlag.NAV_STALE,
        ),
        (
            dataclasses.replace(OK, depth_age_s=math.inf, conditions=NavCondition.DEPTH_MISSING),
            FailsafeFlag.NAV_STALE,
        ),
        (dataclasses.replace(OK, x_m=math.nan), FailsafeFlag.NAV_STALE),
        (nav_state_at(0.0, 0.0, 10.5), FailsafeFlag.DEPTH_LIMIT),
        (nav_state_at(51.0, 0.0, 1.0), FailsafeFlag.AREA_BOUND),
        (nav_state_at(0.0, -20.5, 1.0), FailsafeFlag.AREA_BOUND),
    ],
)
def test_each_check_requests_abort(nav: NavState, flag: FailsafeFlag) -> None:
    # GIVEN one failing condition  WHEN checked  THEN abort with that flag and a reason
    result, state = check(nav, 0.0, FailsafeState(), P)
    assert result.abort and result.flags == flag and result.newly == flag
    assert result.reason
    # and the next tick with the same condition does not report it as new (log once)
    again, _ = check(nav, 0.0, state, P)
    assert again.abort and again.newly == FailsafeFlag(0)


def test_dvl_loss_alone_is_not_stale_navigation() -> None:
    nav = dataclasses.replace(OK, conditions=NavCondition.DVL_STALE | NavCondition.POSITION_STALE)
    assert not check(nav, 0.0, FailsafeState(), P)[0].abort


def test_the_loop_late_for_longer_than_the_limit_aborts() -> None:
    # GIVEN max_loop_late_s = 0.3 s
    params = dataclasses.replace(P, max_loop_late_s=0.3)
    state = FailsafeState()
    # WHEN the loop reports itself behind its schedule for these times, tick by tick (0 = on time)
    aborts = []
    for late_s in [0.0, 0.12, 0.0, 0.1, 0.2, 0.3, 0.31]:
        result, state = check(OK, late_s, state, params)
        aborts.append(result.abort)
    # THEN only lateness beyond the limit aborts (a stall shorter than it, however many periods, does not)
    assert aborts == [False, False, False, False, False, False, True]
    assert (
        result.flags == FailsafeFlag.OVERRUNS
        and "behind its schedule for 0.31 s (limit 0.3 s)" in result.reason
    )


def test_abort_command_is_propeller_off_fins_to_surface() -> None:
    # GIVEN the default abort stern of 15 deg
    cmd = abort_command(FailsafeParams())
    # THEN propeller off, rudder centred, both planes NEGATIVE (nose up by the sign convention)
    assert cmd.propeller_rps == 0.0 and cmd.rudder_rad == 0.0
    assert cmd.stern_port_rad == cmd.stern_starboard_rad == pytest.approx(-math.radians(15.0))
    # and it passes the limiter unchanged
    out = saturate(cmd, cmd, ActuatorLimits(), 0.05)
    assert out.stern_rad == pytest.approx(cmd.stern_rad) and out.flags == 0


@pytest.mark.parametrize(
    "table",
    [
        {"area_x_min_m": 10.0, "area_x_max_m": 0.0},
        {"max_loop_late_s": 0.0},
        {"max_loop_late_s": math.inf},
        {"bogus": 1},
    ],
)
def test_bad_failsafe_config(table: dict[str, object]) -> None:
    with pytest.raises(ConfigError):
        from_table(FailsafeParams, table, "onboard.toml [failsafe]")


def test_abort_command_eases_off_near_the_steepest_pitch_and_never_loops() -> None:
    # GIVEN the default abort stern of 15 deg (the bus contract's ABORT_STERN_DEG)
    params = FailsafeParams()
    assert params.abort_stern_deg == ABORT_STERN_DEG
    hard = -math.radians(ABORT_STERN_DEG)
    # THEN level, or with the pitch unknown (the AHRS silent), the stern planes are hard over nose up
    assert abort_command(params, 0.0).stern_rad == pytest.approx(hard)
    assert abort_command(params, math.nan).stern_rad == pytest.approx(hard)
    # nearing ABORT_PITCH_MAX_RAD they ease off, at it they are level, beyond it nose down (no loop)
    assert hard < abort_command(params, ABORT_PITCH_MAX_RAD - 0.1).stern_rad < 0.0
    assert abort_command(params, ABORT_PITCH_MAX_RAD).stern_rad == pytest.approx(0.0)
    assert abort_command(params, ABORT_PITCH_MAX_RAD + 0.1).stern_rad > 0.0
    assert abort_command(params, math.pi).stern_rad == pytest.approx(-hard)
    # and the propeller is off, the rudder centred, whatever the pitch
    for pitch in (0.0, 1.4, 3.0):
        cmd = abort_command(params, pitch)
        assert cmd.propeller_rps == 0.0 and cmd.rudder_rad == 0.0
