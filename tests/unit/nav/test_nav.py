"""Unit tests of navigation: dead reckoning, innovation gating, bias, ages, stale and NaN conditions."""

from __future__ import annotations

import math
import random

import pytest

from auv_common.config import ConfigError, from_table
from onboard.core.nav import (
    NAV_BLOCKING,
    Ahrs,
    Depth,
    DvlVelocity,
    NavCondition,
    NavFilterState,
    NavInputs,
    NavParams,
    NavState,
    PositionFix,
    step,
)

P = NavParams()
DT = 0.05


def ahrs(t: float, yaw: float = 0.0) -> Ahrs:
    return Ahrs(0.0, 0.0, yaw, 0.0, 0.0, 0.0, t)


def inputs(t: float, *, fix: PositionFix | None = None, yaw: float = 0.0, u: float = 1.0) -> NavInputs:
    return NavInputs(position=fix, dvl=DvlVelocity(u, 0.0, 0.0, t), ahrs=ahrs(t, yaw), depth=Depth(1.0, t))


def run(
    seconds: float,
    *,
    yaw: float = 0.0,
    u: float = 1.0,
    fix_every_s: float = 1.0,
    truth_v: tuple[float | None, float | None] = (None, None),
    noise_m: float = 0.0,
    seed: int = 1,
) -> tuple[NavState, NavFilterState]:
    """Drive the filter with a vehicle moving at u along yaw; fixes from the truth (+ optional noise)."""
    rng = random.Random(seed)
    vx = truth_v[0] if truth_v[0] is not None else u * math.cos(yaw)
    vy = truth_v[1] if truth_v[1] is not None else u * math.sin(yaw)
    state = NavFilterState.initial()
    nav: NavState | None = None
    for k in range(int(seconds / DT) + 1):
        t = k * DT
        fix = None
        if k % int(fix_every_s / DT) == 0:
            fix = PositionFix(vx * t + rng.gauss(0, noise_m), vy * t + rng.gauss(0, noise_m), t)
        nav, state, _ = step(inputs(t, fix=fix, yaw=yaw, u=u), state, P, t)
    assert nav is not None
    return nav, state


def test_no_fix_yet_is_a_typed_condition_not_a_crash() -> None:
    # GIVEN no input at all  WHEN the filter steps  THEN every input is flagged missing, position invalid
    nav, _, _ = step(NavInputs(), NavFilterState.initial(), P, 0.0)
    for c in (NavCondition.POSITION_MISSING, NavCondition.POSITION_INVALID, NavCondition.DVL_MISSING,
              NavCondition.AHRS_MISSING, NavCondition.DEPTH_MISSING):  # fmt: skip
        assert nav.conditions & c
    assert not nav.valid and math.isnan(nav.x_m)


@pytest.mark.parametrize("yaw_deg", [0.0, 90.0, 180.0, -90.0, 30.0])
def test_dvl_is_rotated_by_yaw(yaw_deg: float) -> None:
    # GIVEN a first fix at the origin and then only the DVL (1 m/s forward) at a heading
    yaw = math.radians(yaw_deg)
    state = NavFilterState.initial()
    _, state, _ = step(inputs(0.0, fix=PositionFix(0.0, 0.0, 0.0), yaw=yaw), state, P, 0.0)
    # WHEN 2 s pass
    for k in range(1, 41):
        nav, state, _ = step(inputs(k * DT, yaw=yaw), state, P, k * DT)
    # THEN the estimate moved 2 m along the heading (NED: x north, y east)
    assert nav.x_m == pytest.approx(2.0 * math.cos(yaw), abs=1e-9)
    assert nav.y_m == pytest.approx(2.0 * math.sin(yaw), abs=1e-9)
    assert nav.valid and nav.speed_mps == pytest.approx(1.0)


def test_noisy_fixes_and_dvl_track_the_truth() -> None:
    # GIVEN a vehicle at 1 m/s heading 45 deg with 0.3 m noisy fixes at 1 Hz
    nav, state = run(60.0, yaw=math.radians(45.0), noise_m=0.3)
    # THEN after 60 s the estimate is within a few decimetres of the truth and nothing was rejected
    t = 60.0
    assert math.hypot(nav.x_m - t * math.cos(math.pi / 4), nav.y_m - t * math.sin(math.pi / 4)) < 0.3
    assert state.fixes_rejected == 0 and state.fixes_accepted == 61


def test_outlier_fix_is_rejected_counted_and_does_not_move_the_estimate() -> None:
    # GIVEN a converged filter
    nav, state = run(20.0)
    t = 20.0 + DT
    # WHEN a fix 30 m off arrives, compared with the same step without it
    with_fix, s_with, dbg = step(inputs(t, fix=PositionFix(nav.x_m + 30.0, nav.y_m, t)), state, P, t)
    without, _, _ = step(inputs(t), state, P, t)
    # THEN it is rejected, counted and flagged, and the estimate is exactly the one without it
    assert dbg.fix_accepted is False and dbg.fix_d2 is not None and dbg.fix_d2 > P.gate_chi2
    assert s_with.fixes_rejected == state.fixes_rejected + 1
    assert with_fix.conditions & NavCondition.FIX_REJECTED
    assert (with_fix.x_m, with_fix.y_m) == (without.x_m, without.y_m)


def test_a_fix_is_weighted_with_the_accuracy_it_states() -> None:
    # GIVEN a converged filter and a fix 4 m off: an outlier for a 0.3 m sensor, 2 sigma for a 2 m one
    nav, state = run(20.0)
    t = 20.0 + DT
    off = (nav.x_m + 4.0, nav.y_m)
    _, _, dbg_precise = step(inputs(t, fix=PositionFix(*off, t)), state, P, t)
    coarse, _, dbg_coarse = step(inputs(t, fix=PositionFix(*off, t, 2.0)), state, P, t)
    # THEN the stated accuracy decides: rejected as precise, accepted (and trusted little) as coarse
    assert dbg_precise.fix_accepted is False
    assert dbg_coarse.fix_accepted is True and dbg_coarse.fix_d2 is not None and dbg_coarse.fix_d2 < 13.8
    assert 0.0 < coarse.x_m - nav.x_m < 1.0
    # and a stated accuracy finer than the configured one does not make the filter over-confident
    _, _, dbg_fine = step(inputs(t, fix=PositionFix(*off, t, 0.01)), state, P, t)
    assert dbg_fine.fix_accepted is False


def test_repeated_rejections_raise_a_condition() -> None:
    nav, state = run(5.0)
    for k in range(1, P.max_consecutive_rejections + 1):
        t = 5.0 + k * DT
        nav, state, _ = step(inputs(t, fix=PositionFix(100.0, 100.0, t)), state, P, t)
    assert nav.conditions & NavCondition.FIX_REJECTED_REPEATEDLY
    assert state.consecutive_rejections == P.max_consecutive_rejections


def test_a_fix_is_applied_once_even_if_the_cache_repeats_it() -> None:
    # GIVEN a converged filter and one fix passed on two consecutive steps (latest-value cache)
    _, state = run(5.0)
    t = 5.0 + DT
    fix = PositionFix(5.1, 0.0, t)
    _, state, dbg1 = step(inputs(t, fix=fix), state, P, t)
    _, state, dbg2 = step(inputs(t + DT, fix=fix), state, P, t + DT)
    # THEN only the first step used it
    assert dbg1.fix_accepted is True and dbg2.fix_accepted is None


def test_bias_estimate_learns_a_current() -> None:
    # GIVEN a DVL reading 1 m/s north but fixes showing 0.2 m/s extra towards east (a water current)
    nav, _ = run(120.0, truth_v=(1.0, 0.2))
    # THEN the estimated current is about 0.2 m/s east and the position follows the fixes
    assert nav.velocity_bias_y_mps == pytest.approx(0.2, abs=0.03)
    assert nav.velocity_bias_x_mps == pytest.approx(0.0, abs=0.03)
    assert nav.y_m == pytest.approx(0.2 * 120.0, abs=0.3)


@pytest.mark.parametrize(
    ("age_s", "stale"),
    [
        ("ahrs", NavCondition.AHRS_STALE),
        ("depth", NavCondition.DEPTH_STALE),
        ("dvl", NavCondition.DVL_STALE),
    ],
)
def test_stale_inputs_are_flagged_with_their_age(age_s: str, stale: NavCondition) -> None:
    # GIVEN every input fresh at t = 0 and then one input that stops
    state = NavFilterState.initial()
    _, state, _ = step(inputs(0.0, fix=PositionFix(0.0, 0.0, 0.0)), state, P, 0.0)
    t = 2.0
    fresh = inputs(t)
    old: dict[str, Ahrs | Depth | DvlVelocity | None] = {
        "ahrs": ahrs(0.0),
        "depth": Depth(1.0, 0.0),
        "dvl": DvlVelocity(1.0, 0.0, 0.0, 0.0),
    }
    kw: dict[str, Ahrs | Depth | DvlVelocity | None] = {
        "ahrs": fresh.ahrs,
        "depth": fresh.depth,
        "dvl": fresh.dvl,
    }
    kw[age_s] = old[age_s]
    # WHEN 2 s later the filter steps
    nav, _, _ = step(NavInputs(**kw), state, P, t)  # type: ignore[arg-type]
    # THEN exactly that input is stale, with age 2 s
    assert nav.conditions & stale
    ages = {"ahrs": nav.attitude_age_s, "depth": nav.depth_age_s, "dvl": nav.velocity_age_s}
    assert ages[age_s] == pytest.approx(2.0)
    assert bool(nav.conditions & NAV_BLOCKING) is (age_s != "dvl")  # DVL loss: dead reckoning continues


def test_position_goes_stale_then_invalid_without_fixes() -> None:
    # (issue 24: invalid when dead reckoning's sigma passes [nav] max_position_std_m, not after a fixed 60 s)
    state = NavFilterState.initial()
    _, state, _ = step(inputs(0.0, fix=PositionFix(0.0, 0.0, 0.0)), state, P, 0.0)
    nav, state, _ = step(inputs(P.fix_timeout_s + 1.0), state, P, P.fix_timeout_s + 1.0)
    assert nav.conditions & NavCondition.POSITION_STALE and nav.position_valid
    t = 1000.0  # no DVL sample since 6 s: its held velocity's error grows with its age
    nav, _, _ = step(NavInputs(ahrs=ahrs(t), depth=Depth(1.0, t)), state, P, t)
    assert nav.conditions & NavCondition.POSITION_INVALID and not nav.valid


@pytest.mark.parametrize(
    "bad",
    [
        NavInputs(dvl=DvlVelocity(math.nan, 0.0, 0.0, 1.0)),
        NavInputs(ahrs=Ahrs(0.0, 0.0, math.nan, 0.0, 0.0, 0.0, 1.0)),
        NavInputs(depth=Depth(math.inf, 1.0)),
        NavInputs(position=PositionFix(math.nan, 0.0, 1.0)),
    ],
)
def test_nan_inputs_are_rejected_counted_once_and_the_last_valid_kept(bad: NavInputs) -> None:
    # GIVEN a converged filter
    _, state = run(0.5)
    merged = NavInputs(
        position=bad.position, dvl=bad.dvl or inputs(1.0).dvl, ahrs=bad.ahrs or inputs(1.0).ahrs,
        depth=bad.depth or inputs(1.0).depth,
    )  # fmt: skip
    # WHEN a non-finite sample arrives (and is repeated by the cache on the next step)
    nav, state2, _ = step(merged, state, P, 1.0)
    _, state3, _ = step(merged, state2, P, 1.0 + DT)
    # THEN it is flagged, counted once, and the outputs stay finite
    assert nav.conditions & NavCondition.NAN_INPUT
    assert state2.nan_rejected == state.nan_rejected + 1 == state3.nan_rejected
    assert all(math.isfinite(v) for v in (nav.x_m, nav.y_m, nav.depth_m, nav.yaw_rad, nav.u_mps))


def test_time_going_backwards_does_not_predict() -> None:
    nav0, state = run(1.0)
    nav, _, dbg = step(inputs(0.5), state, P, 0.5)
    assert dbg.dt_s == 0.0 and nav.x_m == pytest.approx(nav0.x_m)


@pytest.mark.parametrize("table", [{"fix_sigma_m": 0.0}, {"gate_chi2": -1.0}, {"unknown": 1}])
def test_bad_nav_config(table: dict[str, object]) -> None:
    with pytest.raises(ConfigError):
        from_table(NavParams, table, "onboard.toml [nav]")
