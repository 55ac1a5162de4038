"""Actuator limits, rates, lag, and the command watchdog."""

from __future__ import annotations

import math

import pytest

from hil_sim.model.actuators import (
    NEUTRAL_COMMAND,
    ActuatorCommand,
    ActuatorState,
    WatchdogState,
    actuators_after,
    saturate_command,
    watchdog_output,
    watchdog_rearm,
    watchdog_tick,
)


def test_saturation_clips_and_flags(params) -> None:
    ap = params.actuators
    cmd, flags = saturate_command(ActuatorCommand(1.0, -1.0, 0.1, 99.0), ap)
    assert cmd == ActuatorCommand(ap.fin_limit_rad, -ap.fin_limit_rad, 0.1, ap.propeller_max_rps)
    assert flags.rudder and flags.stern_port and not flags.stern_starboard and flags.propeller


def test_nan_command_fields_become_neutral(params) -> None:
    cmd, flags = saturate_command(ActuatorCommand(math.nan, 0.1, math.inf, math.nan), params.actuators)
    assert cmd == ActuatorCommand(0.0, 0.1, 0.0, 0.0)
    assert flags.any


def test_fin_rate_limit(params) -> None:
    ap = params.actuators
    target = ActuatorCommand(ap.fin_limit_rad, 0.0, 0.0, 0.0)
    after = actuators_after(ActuatorState(), target, 0.1, ap)
    assert after.rudder_rad == pytest.approx(ap.fin_rate_radps * 0.1)
    done = actuators_after(ActuatorState(), target, 10.0, ap)
    assert done.rudder_rad == ap.fin_limit_rad


def test_propeller_first_order_lag_is_exact_and_composes(params) -> None:
    ap = params.actuators
    cmd = ActuatorCommand(propeller_rps=25.0)
    tau = ap.propeller_time_constant_s
    one = actuators_after(ActuatorState(), cmd, tau, ap)
    assert one.propeller_rps == pytest.approx(25.0 * (1.0 - math.exp(-1.0)))
    half = actuators_after(actuators_after(ActuatorState(), cmd, 0.5 * tau, ap), cmd, 0.5 * tau, ap)
    assert half.propeller_rps == pytest.approx(one.propeller_rps, rel=1e-12)


def test_zero_dt_changes_nothing(params) -> None:
    state = ActuatorState(0.1, 0.2, -0.1, 10.0)
    assert actuators_after(state, ActuatorCommand(0.0, 0.0, 0.0, 25.0), 0.0, params.actuators) == state


def test_watchdog_holds_last_command_then_fails_safe_within_timeout() -> None:
    # GIVEN a valid command WHEN commands stop THEN it is held for N-1 periods and neutral from the N-th on
    n = 5
    cmd = ActuatorCommand(0.1, 0.05, 0.05, 20.0)
    wd = watchdog_tick(WatchdogState(), cmd, n)
    outputs = []
    for _ in range(n):
        wd = watchdog_tick(wd, None, n)
        outputs.append(watchdog_output(wd))
    assert outputs[: n - 1] == [cmd] * (n - 1)
    assert outputs[n - 1] == NEUTRAL_COMMAND
    assert wd.failsafe and wd.timeouts == 1


def test_watchdog_failsafe_is_latched_until_rearmed() -> None:
    wd = WatchdogState()
    for _ in range(5):
        wd = watchdog_tick(wd, None, 5)
    assert wd.failsafe
    cmd = ActuatorCommand(0.1, 0.0, 0.0, 20.0)
    wd = watchdog_tick(wd, cmd, 5)
    assert watchdog_output(wd) == NEUTRAL_COMMAND  # latched
    wd = watchdog_rearm(wd)
    assert not wd.failsafe
    wd = watchdog_tick(wd, cmd, 5)
    assert watchdog_output(wd) == cmd


def test_corrupt_stream_counts_as_missing() -> None:
    # a stream of commands with NaN (a corrupt frame that slipped past the CRC) fails safe too
    bad = ActuatorCommand(math.nan, 0.0, 0.0, 20.0)
    wd = watchdog_tick(WatchdogState(), ActuatorCommand(0.0, 0.0, 0.0, 20.0), 5)
    for _ in range(5):
        wd = watchdog_tick(wd, bad, 5)
    assert wd.failsafe and watchdog_output(wd) == NEUTRAL_COMMAND
