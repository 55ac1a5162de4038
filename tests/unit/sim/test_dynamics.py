"""Properties of the pure derivative: signs (conventions), purity, current, free surface."""

from __future__ import annotations

import math

import pytest

from hil_sim.model.dynamics import BodyState, DynInputs, derivatives

CRUISE = BodyState(z_m=5.0, u_mps=1.5)


def test_positive_rudder_turns_to_port(params) -> None:
    d = derivatives(CRUISE, DynInputs(rudder_rad=0.1, propeller_rps=25.0), params.coeffs)
    assert d[11] < 0.0  # r_dot < 0: yaw to port


def test_positive_stern_pitches_nose_down(params) -> None:
    d = derivatives(CRUISE, DynInputs(stern_port_rad=0.1, stern_starboard_rad=0.1), params.coeffs)
    assert d[10] < 0.0


def test_differential_stern_gives_roll_moment(params) -> None:
    base = derivatives(CRUISE, DynInputs(), params.coeffs)[9]
    plus = derivatives(CRUISE, DynInputs(stern_port_rad=-0.1, stern_starboard_rad=0.1), params.coeffs)[9]
    minus = derivatives(CRUISE, DynInputs(stern_port_rad=0.1, stern_starboard_rad=-0.1), params.coeffs)[9]
    assert plus < base < minus  # starboard-minus-port positive rolls port down
    assert plus - base == pytest.approx(base - minus, rel=1e-9)


def test_propeller_torque_rolls_and_thrust_accelerates(params) -> None:
    d = derivatives(BodyState(z_m=5.0), DynInputs(propeller_rps=25.0), params.coeffs)
    assert d[6] > 0.0
    assert d[9] < 0.0


def test_positive_buoyancy_at_rest_rises(params) -> None:
    d = derivatives(BodyState(z_m=5.0), DynInputs(), params.coeffs)
    assert d[8] < 0.0
    assert all(abs(v) < 1e-12 for v in d[:6])  # at rest: no kinematic motion yet


def test_above_the_surface_weight_pulls_down(params) -> None:
    d = derivatives(BodyState(z_m=-0.2), DynInputs(), params.coeffs)
    assert d[8] > 0.0


def test_moving_with_the_current_has_no_hydrodynamic_force(params) -> None:
    # GIVEN a vehicle drifting exactly with the current, heading 30 deg WHEN evaluated THEN only statics act
    psi = math.radians(30.0)
    cn, ce = 0.3, -0.2
    u = math.cos(psi) * cn + math.sin(psi) * ce
    v = -math.sin(psi) * cn + math.cos(psi) * ce
    state = BodyState(z_m=5.0, yaw_rad=psi, u_mps=u, v_mps=v)
    d = derivatives(state, DynInputs(current_north_mps=cn, current_east_mps=ce), params.coeffs)
    still = derivatives(BodyState(z_m=5.0, yaw_rad=psi), DynInputs(), params.coeffs)
    assert d[0] == pytest.approx(cn) and d[1] == pytest.approx(ce)
    assert d[6:] == pytest.approx(still[6:], abs=1e-12)


def test_derivatives_is_pure(params) -> None:
    state = BodyState(z_m=3.0, u_mps=1.2, v_mps=0.1, r_radps=0.05)
    inputs = DynInputs(rudder_rad=0.1, propeller_rps=20.0)
    a = derivatives(state, inputs, params.coeffs)
    b = derivatives(state, inputs, params.coeffs)
    assert a == b and a is not b
    assert state == BodyState(z_m=3.0, u_mps=1.2, v_mps=0.1, r_radps=0.05)
