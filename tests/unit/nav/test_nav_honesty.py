"""Issue 24, item 3: a filter whose sigma is honest. Dead reckoning bounded by its own covariance (not a fixed
60 s), a slow or lost DVL's held velocity counted, a sea-grade 20 m jump refused and counted, and the
covariance's NEES within its band on a simulated straight run."""

from __future__ import annotations

import dataclasses
import math
import random
from pathlib import Path

from auv_common.config import from_table, load_toml
from onboard.core.config import CoreConfig
from onboard.core.nav import (
    Ahrs,
    Depth,
    DvlVelocity,
    NavCondition,
    NavFilterState,
    NavInputs,
    NavParams,
    step,
)
from onboard.core.nav.confidence import NEES_BAND, nees
from onboard.core.nav.types import PositionFix

ONBOARD_TOML = Path(__file__).parents[3] / "onboard" / "config" / "onboard.toml"


def _packaged_nav() -> NavParams:
    """The [nav] table the vehicle flies with (the packaged onboard.toml)."""
    data = load_toml(ONBOARD_TOML)
    tables = {f.name for f in dataclasses.fields(CoreConfig)}
    return from_table(CoreConfig, {k: v for k, v in data.items() if k in tables}, "onboard.toml").nav


P = _packaged_nav()
DT = 0.05


def _inputs(t: float, *, dvl_t: float | None, u: float = 1.5, fix: PositionFix | None = None) -> NavInputs:
    dvl = None if dvl_t is None else DvlVelocity(u, 0.0, 0.0, dvl_t)
    return NavInputs(position=fix, dvl=dvl, ahrs=Ahrs(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, t), depth=Depth(1.0, t))


def _fly(seconds: float, *, dvl_period_s: float, dvl_until_s: float = math.inf):
    """1.5 m/s north, one fix at t = 0, the DVL every ``dvl_period_s`` until ``dvl_until_s``."""
    state = NavFilterState.initial()
    nav = None
    dvl_t: float | None = None
    for k in range(round(seconds / DT) + 1):
        t = k * DT
        if t <= dvl_until_s and (dvl_t is None or t - dvl_t >= dvl_period_s - 1e-9):
            dvl_t = t
        fix = PositionFix(0.0, 0.0, 0.0) if k == 0 else None
        nav, state, _ = step(_inputs(t, dvl_t=dvl_t, fix=fix), state, P, t)
    assert nav is not None
    return nav, state


def test_a_good_dvl_dead_reckons_past_the_old_60_s() -> None:
    # GIVEN one fix and then a 10 Hz DVL for 100 s (the old filter gave the position up at 60 s)
    nav, _ = _fly(100.0, dvl_period_s=0.1)
    # THEN the position is stale (no fix) but valid: its sigma is well within max_position_std_m
    assert nav.conditions & NavCondition.POSITION_STALE
    assert nav.position_valid, nav.conditions
    assert nav.position_std_max_m < P.max_position_std_m / 2


def test_a_lost_dvl_ends_dead_reckoning_by_the_covariance() -> None:
    # GIVEN the DVL lost after 10 s (its last sample held)
    nav, _ = _fly(10.0 + 30.0, dvl_period_s=0.1, dvl_until_s=10.0)
    # THEN the held velocity's error grows with its age: the position is invalid, for its sigma
    assert nav.conditions & NavCondition.DVL_STALE
    assert nav.conditions & NavCondition.POSITION_INVALID
    assert nav.position_std_max_m > P.max_position_std_m
    # and the vehicle was not stopped in the estimate: it coasted on the held velocity (1.5 m/s x 40 s)
    assert abs(nav.x_m - 60.0) < 1.0


def test_a_slow_dvl_widens_the_sigma_a_fast_one_does_not() -> None:
    fast, _ = _fly(30.0, dvl_period_s=0.1)
    slow, _ = _fly(30.0, dvl_period_s=2.0)
    # the slow DVL's samples are held 2 s: its covariance grows faster, its estimate still moves with it
    assert slow.position_std_max_m > 2.0 * fast.position_std_max_m
    assert abs(slow.x_m - 45.0) < 1.0


def test_a_20_m_jump_at_sea_does_not_move_the_vehicle_and_is_counted() -> None:
    # GIVEN a converged filter on sea-grade fixes (2 m, every 5 s)
    rng = random.Random(3)
    state = NavFilterState.initial()
    nav = None
    for k in range(round(60.0 / DT) + 1):
        t = k * DT
        fix = PositionFix(1.5 * t + rng.gauss(0, 2.0), rng.gauss(0, 2.0), t, 2.0) if k % 100 == 0 else None
        nav, state, _ = step(_inputs(t, dvl_t=t, fix=fix), state, P, t)
    assert nav is not None and nav.fixes_rejected == 0
    # WHEN a fix 20 m off arrives (stating the same 2 m)
    t = 60.0 + DT
    jump = PositionFix(nav.x_m + 20.0, nav.y_m, t, 2.0)
    with_jump, _, dbg = step(_inputs(t, dvl_t=t, fix=jump), state, P, t)
    without, _, _ = step(_inputs(t, dvl_t=t), state, P, t)
    # THEN it is refused (far outside the gate), counted for the telemetry, and moves nothing
    assert dbg.fix_accepted is False and dbg.fix_d2 is not None and dbg.fix_d2 > 3.0 * P.gate_chi2
    assert with_jump.fixes_rejected == 1 and with_jump.conditions & NavCondition.FIX_REJECTED
    assert (with_jump.x_m, with_jump.y_m) == (without.x_m, without.y_m)


def test_the_nees_of_a_simulated_run_is_within_its_band() -> None:
    # GIVEN a vehicle at 1.5 m/s with a 5 Hz DVL of the configured accuracy and 2 m fixes every 5 s
    rng = random.Random(7)
    state = NavFilterState.initial()
    x_true = 0.0
    values = []
    for k in range(round(300.0 / DT) + 1):
        t = k * DT
        x_true = 1.5 * t
        fix = None
        if k % 100 == 0:
            fix = PositionFix(x_true + rng.gauss(0, 2.0), rng.gauss(0, 2.0), t, 2.0)
        dvl_t = round(t / 0.2) * 0.2
        u = 1.5 + rng.gauss(0, P.dvl_sigma_mps) if abs(dvl_t - t) < 1e-9 else None
        if u is not None:
            last_u = u
        nav, state, _ = step(_inputs(t, dvl_t=dvl_t, u=last_u, fix=fix), state, P, t)
        if t > 30.0:
            values.append(nees(x_true - nav.x_m, -nav.y_m, nav.position_std_x_m**2, nav.position_std_y_m**2))
    lo, hi = NEES_BAND
    inside = sum(1 for v in values if lo <= v <= hi) / len(values)
    # THEN it is neither overconfident nor wildly pessimistic (a consistent filter: mean 2, 95 % inside)
    assert sum(1 for v in values if v > hi) / len(values) < 0.05
    assert inside > 0.8
    assert 0.5 < sum(values) / len(values) < 3.0


def _biased_heading_run(params: NavParams, seconds: float = 60.0) -> float:
    """1.5 m/s north with 4 mm fixes at 20 Hz while the compass reads 8 deg off: the final error, m."""
    rng = random.Random(5)
    state = NavFilterState.initial()
    nav = None
    bias = math.radians(8.0)
    for k in range(round(seconds / DT) + 1):
        t = k * DT
        fix = PositionFix(1.5 * t + rng.gauss(0, 0.003), rng.gauss(0, 0.003), t)
        inputs = NavInputs(
            position=fix, dvl=DvlVelocity(1.5, 0.0, 0.0, t), ahrs=Ahrs(0.0, 0.0, bias, 0.0, 0.0, 0.0, t),
            depth=Depth(1.0, t),
        )  # fmt: skip
        nav, state, _ = step(inputs, state, params, t)
    assert nav is not None
    return math.hypot(nav.x_m - 1.5 * seconds, nav.y_m)


def test_fixes_that_agree_with_each_other_not_with_the_estimate_restart_it() -> None:
    # GIVEN a compass 8 deg off (0.2 m/s across the track dead-reckoned) and precise fixes: the gate soon
    # refuses every fix, and without a way out the estimate runs away on the biased heading
    locked = dataclasses.replace(P, max_consecutive_rejections=10**9)
    assert _biased_heading_run(locked) > 5.0
    # THEN five refused in a row restart the estimate at the fix: it stays with the fixes
    assert _biased_heading_run(P) < 0.5
