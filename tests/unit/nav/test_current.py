"""Unit tests of the water-current estimate (onboard.core.nav.current) and its place in the nav step."""

from __future__ import annotations

import math
import random

import pytest

from onboard.core.nav import Ahrs, Depth, DvlVelocity, NavFilterState, NavInputs, NavParams, step
from onboard.core.nav.current import CurrentFilter

P = NavParams()
DT = 0.1


def fly(
    legs: list[tuple[float, float, float]],
    current: tuple[float, float],
    *,
    noise_mps: float = 0.0,
    seed: int = 3,
) -> list[tuple[float, float, float, float]]:
    """Drive the nav step with a DVL over ground = current + u_w along the heading, leg by leg
    (seconds, heading rad, speed through the water m/s); returns (t, c_n, c_e, u_w) after each leg."""
    rng = random.Random(seed)
    state = NavFilterState.initial()
    out = []
    t = 0.0
    for seconds, yaw, u_w in legs:
        for _ in range(int(seconds / DT)):
            t += DT
            vn = current[0] + u_w * math.cos(yaw) + rng.gauss(0.0, noise_mps)
            ve = current[1] + u_w * math.sin(yaw) + rng.gauss(0.0, noise_mps)
            # body frame (level): u along the heading, v to starboard
            u = vn * math.cos(yaw) + ve * math.sin(yaw)
            v = -vn * math.sin(yaw) + ve * math.cos(yaw)
            inputs = NavInputs(
                position=None,
                dvl=DvlVelocity(u, v, 0.0, t),
                ahrs=Ahrs(0.0, 0.0, yaw, 0.0, 0.0, 0.0, t),
                depth=Depth(1.0, t),
            )
            nav, state, _ = step(inputs, state, P, t)
        out.append((t, nav.current_north_mps, nav.current_east_mps, nav.water_speed_mps))
    return out


def test_at_rest_the_drift_is_the_current() -> None:
    # GIVEN a vehicle at rest in the water, drifting with a 0.3 m/s current towards the south-east
    ((_, cn, ce, uw),) = fly([(5.0, 0.0, 0.0)], (-0.2, 0.22))
    # THEN the estimate is the drift, and the speed through the water is 0
    assert (cn, ce) == pytest.approx((-0.2, 0.22), abs=0.01)
    assert uw == pytest.approx(0.0, abs=0.01)


def test_the_current_learnt_at_rest_survives_speeding_up_along_a_heading() -> None:
    # GIVEN the drift seen at rest, then 20 s at 1 m/s through the water heading north-east
    out = fly([(5.0, 0.0, 0.0), (20.0, math.radians(45.0), 1.0)], (0.3, -0.1), noise_mps=0.02)
    _, cn, ce, uw = out[-1]
    # THEN the current stays known (the speed up goes to the water speed, not to the current)
    assert (cn, ce) == pytest.approx((0.3, -0.1), abs=0.05)
    assert uw == pytest.approx(1.0, abs=0.05)


def test_a_change_of_heading_separates_current_and_water_speed_without_a_rest() -> None:
    # GIVEN a vehicle already under way (no rest: the prior wrongly says it is still), a leg north then east
    out = fly([(0.2, 0.0, 1.0), (30.0, 0.0, 1.0), (30.0, math.pi / 2, 1.0)], (0.0, 0.4), noise_mps=0.02)
    _, cn, ce, uw = out[-1]
    # THEN after the turn both are right
    assert (cn, ce) == pytest.approx((0.0, 0.4), abs=0.08)
    assert uw == pytest.approx(1.0, abs=0.08)


def test_the_estimate_is_clamped_and_the_uncertainty_shrinks() -> None:
    f = CurrentFilter.at_rest(0.0, 1.0, 0.02)
    assert f.current_std_mps == pytest.approx(math.sqrt(2.0))
    g = f.update(0.1, 9.0, 0.0, 0.0, 0.0, 0.0, 1e-4, 1e-4, 3.0)
    assert math.hypot(g.c_n, g.c_e) <= 3.0 + 1e-12
    assert g.current_std_mps < f.current_std_mps


def test_without_dvl_there_is_no_estimate() -> None:
    nav, _, _ = step(
        NavInputs(None, None, Ahrs(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0), None), NavFilterState(), P, 0.0
    )
    assert nav.current_std_mps == math.inf and (nav.current_north_mps, nav.current_east_mps) == (0.0, 0.0)
