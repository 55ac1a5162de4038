"""The actuator node's own ABORT: when its command watchdog fires (the onboard, or the bus to it, is what
failed) it does what the bus contract's ABORT does, by itself: propeller off, rudder centred, stern planes
nose up by ``messages.ABORT_STERN_DEG``, so the vehicle climbs and stops ahead. Before it held the fins
neutral: from 1.2 m/s the vehicle glided 22 m on and sank 0.17 m (tests/e2e/test_abort_stop.py). Never
commanded, or last told SAFE (nothing moves), its failsafe stays neutral."""

from __future__ import annotations

import math

import pytest

from hil_sim.bench_program import ActuatorNode
from onboard.protocol import messages as m


def _armed_node(timeout_periods: int) -> ActuatorNode:
    """A node following an ARMED command of 16 rps, rudder 0.1, stern 0.05 (one period commanded)."""
    node = ActuatorNode(timeout_periods=timeout_periods)
    node.take(m.OnboardHeartbeat(m.MissionStateCode.RUNNING, 1.0))
    node.take(m.FinCmd(0.1, 0.05, 0.05))
    node.take(m.PropCmd(16.0, m.ActuatorMode.ARMED))
    out = node.end_period()
    assert out.propeller_rps == 16.0 and out.rudder_rad == 0.1 and node.armed
    return node


def test_the_watchdog_failsafe_is_the_contracts_abort_stern_planes_nose_up() -> None:
    # GIVEN a node following 16 rps ahead
    node = _armed_node(timeout_periods=3)
    # WHEN its commands stop (the onboard died) until the watchdog fires, and on
    outs = [node.end_period() for _ in range(6)]
    # THEN the last command is held until the timeout, then: propeller off, rudder centred, stern nose up
    assert [o.propeller_rps for o in outs[:2]] == [16.0, 16.0]
    assert node.watchdog.failsafe and not node.armed
    nose_up = -math.radians(m.ABORT_STERN_DEG)
    for out in outs[2:]:
        assert out.propeller_rps == 0.0 and out.rudder_rad == 0.0
        assert out.stern_port_rad == out.stern_starboard_rad == pytest.approx(nose_up)
    # and a SAFE command from the onboard (it acknowledges the failsafe) clears it: everything neutral
    node.take(m.FinCmd(0.0, 0.0, 0.0))
    node.take(m.PropCmd(0.0, m.ActuatorMode.SAFE))
    out = node.end_period()
    assert not node.watchdog.failsafe and out.stern_port_rad == 0.0 and out.propeller_rps == 0.0


def test_a_commanded_abort_is_propeller_off_with_the_fins_as_commanded() -> None:
    # GIVEN a node following 16 rps ahead; WHEN the onboard commands ABORT with its stern planes nose up
    node = _armed_node(timeout_periods=3)
    node.take(m.FinCmd(0.0, -0.2, -0.2))
    node.take(m.PropCmd(0.0, m.ActuatorMode.ABORT))
    out = node.end_period()
    # THEN propeller off and the fins as the onboard commands them (it knows the pitch: it eases off)
    assert out.propeller_rps == 0.0 and out.stern_port_rad == out.stern_starboard_rad == -0.2
    assert not node.watchdog.failsafe


def test_a_node_never_commanded_or_told_safe_keeps_its_failsafe_neutral() -> None:
    # GIVEN a node that never had a command (the bench before the firmware), WHEN its watchdog fires
    node = ActuatorNode(timeout_periods=3)
    outs = [node.end_period() for _ in range(5)]
    # THEN nothing moves: the vehicle is not under way
    assert node.watchdog.failsafe and outs[-1] == outs[0] and outs[-1].stern_port_rad == 0.0
    # and the same after the onboard last said SAFE (disarmed: still)
    node = _armed_node(timeout_periods=3)
    node.take(m.FinCmd(0.0, 0.0, 0.0))
    node.take(m.PropCmd(0.0, m.ActuatorMode.SAFE))
    node.end_period()
    outs = [node.end_period() for _ in range(5)]
    assert node.watchdog.failsafe and outs[-1].stern_port_rad == 0.0 and outs[-1].propeller_rps == 0.0
