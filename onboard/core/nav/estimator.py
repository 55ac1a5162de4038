"""Horizontal-position Kalman filter with DVL dead reckoning and innovation-gated position fixes.

Model (per NED axis, independent because the process and fix noises are isotropic, so two 2-state filters are
exact and need no matrix library)::

    state   [p, b]         p = position (m), b = velocity bias / water current (m/s)
    predict p += (v_ned + b) * dt,  b += random walk
            v_ned = R(roll, pitch, yaw) [u v w]_body, its x and y rows
    update  z = p + noise  (position fix, sigma ``fix_sigma_m``)

A fix is applied only if its squared Mahalanobis distance d^2 = i_x^2 / S_x + i_y^2 / S_y (2 degrees of
freedom) is at most ``gate_chi2``; otherwise it is rejected and counted (``NavState.fixes_rejected``, the
telemetry's ``fixes_rejected``), so an outlier never moves the estimate. The first valid fix initialises the
position (before it: ``POSITION_MISSING``).

The covariance is meant to be honest (the campaign's NEES columns measure it against the simulator's truth):
dead reckoning grows it as the sensors' stated accuracies say (:func:`dead_reckoning_q`), a fix shrinks it
by the accuracy it states, and the position is ``POSITION_INVALID`` when its 1-sigma exceeds
``max_position_std_m`` (not after a fixed time: a good DVL dead-reckons longer than a poor one).
Fix latency is ignored (a fix is applied at the step that sees it); the loop runs at 20 Hz and fixes are slow.

The water current (and the speed through the water) is estimated apart, from the DVL's velocity over ground
and the heading (:mod:`onboard.core.nav.current`), on every new DVL sample.

Attitude, rates, depth and body velocity are passed through from the latest valid sample, with their ages.
A non-finite sample is rejected, counted and flagged ``NAN_INPUT``; the previous valid sample stays in use.
Attitude and depth older than ``stale_after_s`` are ``AHRS_STALE`` / ``DEPTH_STALE`` (the navigation is not
valid: the failsafe aborts, START waits). That timeout has one owner, the operator's FS_NAV_TMO_S
(``[failsafe] nav_timeout_s``): :class:`onboard.core.config.CoreConfig` hands it to the estimator
(:meth:`NavParams.with_stale_after`), so no second, shorter timeout decides before it.

Pure: ``step(inputs, state, params, now_s)``. The filter needs the absolute time ``now_s`` (not only ``dt_s``)
because it ages time-stamped samples; ``now_s`` comes from the loop's injected clock, nothing here reads one.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from math import isfinite
from typing import ClassVar, NamedTuple

from auv_common.config import require
from onboard.core.nav.current import CurrentFilter
from onboard.core.nav.types import (
    Ahrs,
    Depth,
    DvlVelocity,
    NavCondition,
    NavInputs,
    NavState,
    PositionFix,
)
from onboard.protocol.conventions import body_to_ned

#: The navigation staleness timeout's default, s: FS_NAV_TMO_S (``[failsafe] nav_timeout_s``) declares it
#: with this value; an estimator built without a configuration (tests, replays) uses it too.
NAV_TIMEOUT_DEFAULT_S = 1.0
_MOVED_TO_FS_NAV_TMO_S = (
    "attitude and depth staleness has one timeout, [failsafe] nav_timeout_s (FS_NAV_TMO_S): set that instead"
)


@dataclass(frozen=True)
class NavParams:
    """The ``[nav]`` table of the onboard TOML. Every key is optional.

    - ``fix_sigma_m``: position-fix standard deviation, m; a fix that states a coarser accuracy of its own
      (POSITION_FIX ``std_m``) is weighted with that (the filter follows the sensor actually in use).
    - Dead reckoning's covariance grows as the sensors' stated accuracies say (:func:`dead_reckoning_q`):
      ``dvl_sigma_mps`` (a DVL sample's 1-sigma, held until the next: sigma^2 x the interval between
      samples), ``heading_sigma_deg`` (the AHRS yaw's 1-sigma, rotating the velocity: (speed x sigma)^2 x
      the tick), ``velocity_change_mps2`` (how fast the vehicle's velocity may change while a DVL sample
      ages: a^2 x age^3, so a slow or lost DVL is honest about its held velocity), at most
      ``held_velocity_sigma_max_mps`` (the held velocity's error stops growing there: a cruising vehicle
      does not speed up for ever; cap^2 x age beyond) and
      ``dvl_noise_m_per_sqrt_s``, the density of what none of them models (a floor), m/sqrt(s).
    - ``stale_dvl_noise_m_per_sqrt_s``: the density without any DVL velocity (or attitude) to dead-reckon on
      (coasting on the bias).
    - ``max_position_std_m``: dead reckoning ends (``POSITION_INVALID``) when the position's 1-sigma major
      semi-axis exceeds this, m: the filter's own covariance, not a fixed time, says when the position is
      no longer worth steering by (``max_dead_reckoning_s``, a fixed 60 s, is gone).
    - ``start_position_95_m``: START waits (the commander's readiness, "not now" with the figure) until the
      position's 95 % region (2.448 sigma_max) is within this, m: the first plan starts from the estimate.
    - ``estimate_bias``: estimate a constant NED velocity bias (water current / DVL bias).
    - ``bias_walk_mps_per_sqrt_s``: random-walk density of that bias, (m/s)/sqrt(s).
    - ``initial_bias_sigma_mps``: its initial standard deviation, m/s (0.05: the bias of a bottom-track
      DVL, with margin; with a water-track DVL, whose "bias" is the current, raise it to the current
      expected). A wide prior hurts with coarse, rare fixes: 2 m fixes every 5 s cannot pin a velocity in a
      30 s mission, and a 0.2 m/s prior let the estimate drift up to 6 m (the ``sea`` campaign).
      ``max_bias_mps``: clamp on it, m/s.
    - ``current_sigma_mps``: the water current's prior 1-sigma, m/s; ``current_walk_mps_per_sqrt_s``,
      ``water_speed_walk_mps_per_sqrt_s``: random-walk densities of the current and of the speed through
      the water, (m/s)/sqrt(s); ``dvl_sigma_mps``: the DVL velocity's 1-sigma, m/s; ``water_sway_sigma_mps``
      and ``sway_per_yaw_rate_mps_per_radps``: the sideslip through the water counted as noise across the
      heading, m/s + (m/s)/(rad/s) * |r|; ``max_current_mps``: its clamp (:mod:`onboard.core.nav.current`).
    - ``gate_chi2``: innovation gate on d^2 (2 dof; 13.8 = 99.9 %).
    - ``max_consecutive_rejections``: this many rejected fixes in a row raise ``FIX_REJECTED_REPEATEDLY``
      and the estimate restarts at the last of them (the fixes agree with each other, not with it: a gate
      that locked the fixes out while a heading error was dead-reckoned); one outlier never moves it.
    - ``fix_timeout_s``: a fix older than this raises ``POSITION_STALE`` (dead reckoning, still valid).
    - ``dvl_timeout_s``: a DVL velocity older than this is ``DVL_STALE`` (dead reckoning coasts), s.

    Attitude and depth have no timeout of their own here: ``stale_after_s`` is FS_NAV_TMO_S, set by
    :class:`~onboard.core.config.CoreConfig` (the old ``ahrs_timeout_s`` / ``depth_timeout_s`` keys, 0.5 s,
    aborted before the operator's timeout could: a config that sets them is refused with the reason).
    """

    #: Keys that were removed, and why (``auv_common.config.from_table`` refuses them with this reason).
    REMOVED_KEYS: ClassVar[dict[str, str]] = {
        "ahrs_timeout_s": _MOVED_TO_FS_NAV_TMO_S,
        "depth_timeout_s": _MOVED_TO_FS_NAV_TMO_S,
        "max_dead_reckoning_s": (
            "dead reckoning is bounded by its covariance, not a time: set [nav] max_position_std_m instead"
        ),
    }

    fix_sigma_m: float = 0.3
    dvl_noise_m_per_sqrt_s: float = 0.005
    heading_sigma_deg: float = 1.0
    velocity_change_mps2: float = 0.3
    held_velocity_sigma_max_mps: float = 0.5
    stale_dvl_noise_m_per_sqrt_s: float = 0.5
    estimate_bias: bool = True
    bias_walk_mps_per_sqrt_s: float = 0.005
    initial_bias_sigma_mps: float = 0.05
    max_bias_mps: float = 2.0
    current_sigma_mps: float = 1.0
    current_walk_mps_per_sqrt_s: float = 0.002
    water_speed_walk_mps_per_sqrt_s: float = 0.3
    dvl_sigma_mps: float = 0.02
    water_sway_sigma_mps: float = 0.05
    sway_per_yaw_rate_mps_per_radps: float = 1.0
    max_current_mps: float = 3.0
    gate_chi2: float = 13.8
    max_consecutive_rejections: int = 5
    fix_timeout_s: float = 5.0
    max_position_std_m: float = 5.0
    start_position_95_m: float = 10.0
    dvl_timeout_s: float = 1.0
    #: Attitude and depth older than this are stale (s): FS_NAV_TMO_S, handed over by CoreConfig.
    stale_after_s: float = field(default=NAV_TIMEOUT_DEFAULT_S, init=False)
    # Derived once (the step reads them every tick): variances and squared densities.
    fix_var_m2: float = field(init=False, repr=False)
    q_pos_floor: float = field(init=False, repr=False)
    q_dvl_white: float = field(init=False, repr=False)
    q_heading: float = field(init=False, repr=False)
    q_velocity_change: float = field(init=False, repr=False)
    q_held_max: float = field(init=False, repr=False)
    q_pos_stale: float = field(init=False, repr=False)
    q_bias: float = field(init=False, repr=False)
    initial_bias_var: float = field(init=False, repr=False)

    def __post_init__(self) -> None:
        require(self.fix_sigma_m > 0.0, f"fix_sigma_m must be > 0, got {self.fix_sigma_m}")
        for name in (
            "dvl_noise_m_per_sqrt_s",
            "stale_dvl_noise_m_per_sqrt_s",
            "bias_walk_mps_per_sqrt_s",
            "initial_bias_sigma_mps",
            "max_bias_mps",
            "current_walk_mps_per_sqrt_s",
            "water_speed_walk_mps_per_sqrt_s",
            "sway_per_yaw_rate_mps_per_radps",
            "heading_sigma_deg",
            "velocity_change_mps2",
            "held_velocity_sigma_max_mps",
        ):
            require(getattr(self, name) >= 0.0, f"{name} must be >= 0, got {getattr(self, name)}")
        for name in ("current_sigma_mps", "dvl_sigma_mps", "water_sway_sigma_mps", "max_current_mps"):
            require(getattr(self, name) > 0.0, f"{name} must be > 0, got {getattr(self, name)}")
        require(self.gate_chi2 > 0.0, f"gate_chi2 must be > 0, got {self.gate_chi2}")
        require(self.max_consecutive_rejections >= 1, "max_consecutive_rejections must be >= 1")
        timeouts = ("fix_timeout_s", "max_position_std_m", "start_position_95_m", "dvl_timeout_s")
        for name in timeouts:
            require(getattr(self, name) > 0.0, f"{name} must be > 0, got {getattr(self, name)}")
        object.__setattr__(self, "fix_var_m2", self.fix_sigma_m**2)
        object.__setattr__(self, "q_pos_floor", self.dvl_noise_m_per_sqrt_s**2)
        object.__setattr__(self, "q_dvl_white", self.dvl_sigma_mps**2)
        object.__setattr__(self, "q_heading", math.radians(self.heading_sigma_deg) ** 2)
        object.__setattr__(self, "q_velocity_change", self.velocity_change_mps2**2)
        object.__setattr__(self, "q_held_max", self.held_velocity_sigma_max_mps**2)
        object.__setattr__(self, "q_pos_stale", self.stale_dvl_noise_m_per_sqrt_s**2)
        object.__setattr__(self, "q_bias", self.bias_walk_mps_per_sqrt_s**2)
        initial_bias_var = self.initial_bias_sigma_mps**2 if self.estimate_bias else 0.0
        object.__setattr__(self, "initial_bias_var", initial_bias_var)

    def with_stale_after(self, stale_after_s: float) -> NavParams:
        """These parameters with attitude and depth stale after ``stale_after_s`` (s): FS_NAV_TMO_S."""
        if stale_after_s == self.stale_after_s:
            return self
        new = dataclasses.replace(self)
        object.__setattr__(new, "stale_after_s", stale_after_s)
        return new


class AxisFilter(NamedTuple):
    """One axis: position p (m), bias b (m/s) and the symmetric covariance [[p00, p01], [p01, p11]].

    Immutable; a named tuple rather than a frozen dataclass because two to four are built per tick and a
    tuple is built ~4x faster.
    """

    p_m: float
    b_mps: float
    p00: float
    p01: float
    p11: float

    def predict(self, v_mps: float, dt_s: float, q_pos: float, q_bias: float, bias_on: bool) -> AxisFilter:
        """Propagate by ``dt_s`` with the measured velocity ``v_mps`` (NED, m/s); q_*: squared densities."""
        b = self.b_mps if bias_on else 0.0
        p00 = self.p00 + 2.0 * dt_s * self.p01 + dt_s * dt_s * self.p11 + q_pos * dt_s
        p01 = self.p01 + dt_s * self.p11
        p11 = self.p11
        if bias_on:
            p00 += q_bias * dt_s**3 / 3.0
            p01 += q_bias * dt_s**2 / 2.0
            p11 += q_bias * dt_s
        return AxisFilter(self.p_m + (v_mps + b) * dt_s, b, p00, p01, p11)

    def update(self, z_m: float, r_m2: float, max_bias_mps: float) -> AxisFilter:
        """Kalman update with a position measurement ``z_m`` of variance ``r_m2``."""
        s = self.p00 + r_m2
        k0 = self.p00 / s
        k1 = self.p01 / s
        innovation = z_m - self.p_m
        b = min(max(self.b_mps + k1 * innovation, -max_bias_mps), max_bias_mps)
        return AxisFilter(
            self.p_m + k0 * innovation,
            b,
            (1.0 - k0) * self.p00,
            (1.0 - k0) * self.p01,
            self.p11 - k1 * self.p01,
        )


@dataclass(frozen=True)
class NavFilterState:
    """Everything the navigation step carries between calls. Start from :meth:`initial`."""

    t_s: float | None = None
    x: AxisFilter | None = None
    y: AxisFilter | None = None
    last_fix_t_s: float = -math.inf  # t_sample_s of the latest fix looked at (accepted, rejected or NaN)
    seen_dvl_t_s: float = -math.inf  # t_sample_s of the latest sample looked at, per input
    seen_ahrs_t_s: float = -math.inf
    seen_depth_t_s: float = -math.inf
    accepted_fix_t_s: float = -math.inf
    dvl_interval_s: float = 0.0  # between the latest two DVL samples (0: one or none yet)
    dvl: DvlVelocity | None = None
    ahrs: Ahrs | None = None
    depth: Depth | None = None
    fixes_accepted: int = 0
    fixes_rejected: int = 0
    consecutive_rejections: int = 0
    nan_rejected: int = 0
    current: CurrentFilter | None = None

    @classmethod
    def initial(cls) -> NavFilterState:
        return cls()


@dataclass(frozen=True)
class NavDebug:
    """Per-step numbers for telemetry: the last fix's squared Mahalanobis distance and what happened to it."""

    dt_s: float
    fix_d2: float | None = None
    fix_accepted: bool | None = None
    used_dvl: bool = False


def _horizontal_velocity(dvl: DvlVelocity, ahrs: Ahrs) -> tuple[float, float]:
    """Body velocity (FRD) rotated to NED x and y (m/s), with the ZYX Euler angles."""
    vx, vy, _ = body_to_ned(ahrs.roll_rad, ahrs.pitch_rad, ahrs.yaw_rad, dvl.u_mps, dvl.v_mps, dvl.w_mps)
    return vx, vy


def _current_step(
    current: CurrentFilter | None,
    dvl: DvlVelocity,
    ahrs: Ahrs,
    v_ned: tuple[float, float],
    params: NavParams,
) -> CurrentFilter:
    """The current filter after one DVL sample, whose NED velocity is ``v_ned`` (started at rest on the
    first)."""
    if current is None:
        current = CurrentFilter.at_rest(dvl.t_sample_s, params.current_sigma_mps, params.dvl_sigma_mps)
    vx, vy = v_ned
    sway = params.water_sway_sigma_mps + params.sway_per_yaw_rate_mps_per_radps * abs(ahrs.r_radps)
    along = params.dvl_sigma_mps**2
    return current.update(
        dvl.t_sample_s,
        vx,
        vy,
        ahrs.yaw_rad,
        params.current_walk_mps_per_sqrt_s**2,
        params.water_speed_walk_mps_per_sqrt_s**2,
        along,
        along + sway * sway,
        params.max_current_mps,
    )


def dead_reckoning_q(
    params: NavParams, speed_mps: float, dvl_interval_s: float, dvl_age_s: float, dt_s: float
) -> float:
    """How fast the dead-reckoned position's variance grows per axis, m^2/s, as the sensors' stated
    accuracies say: a DVL sample's noise held until the next (``dvl_sigma_mps``^2 x the interval, or its
    age when older), the
    heading's noise rotating the velocity each tick ((speed x ``heading_sigma_deg``)^2 x dt), the velocity's
    change while the sample ages (``velocity_change_mps2``^2 x age^3: the held velocity's error a x age,
    integrated over the age; at most ``held_velocity_sigma_max_mps``^2 x age, where a x age reaches it: the
    two agree there) and the unmodelled floor (``dvl_noise_m_per_sqrt_s``^2)."""
    held_s = max(dvl_interval_s, dvl_age_s, dt_s)  # a stale sample's noise is held for its whole age
    return (
        params.q_pos_floor
        + params.q_dvl_white * held_s
        + params.q_heading * speed_mps * speed_mps * dt_s
        + min(params.q_velocity_change * dvl_age_s**3, params.q_held_max * dvl_age_s)
    )


def _age(now_s: float, t_sample_s: float | None) -> float:
    return math.inf if t_sample_s is None else max(0.0, now_s - t_sample_s)


def step(
    inputs: NavInputs, state: NavFilterState, params: NavParams, now_s: float
) -> tuple[NavState, NavFilterState, NavDebug]:
    """One navigation step at time ``now_s`` (s, the loop's time base).

    Inputs: the latest sample of each sensor (repeats are ignored by their ``t_sample_s``). Output: the
    navigation solution, the new filter state and per-step debug numbers. Never raises on bad
    data: NaN, stale or missing inputs become :class:`NavCondition` flags.
    """
    conditions = NavCondition(0)
    nan_rejected = state.nan_rejected
    dt_s = 0.0 if state.t_s is None else max(0.0, now_s - state.t_s)

    # 1. Take the new samples (newer than the last one looked at); reject non-finite ones, once each.
    dvl, ahrs, depth = state.dvl, state.ahrs, state.depth
    seen_dvl_t_s, seen_ahrs_t_s = state.seen_dvl_t_s, state.seen_ahrs_t_s
    seen_depth_t_s = state.seen_depth_t_s
    dvl_interval_s = state.dvl_interval_s
    d = inputs.dvl
    if d is not None and not d.t_sample_s <= seen_dvl_t_s:
        seen_dvl_t_s = d.t_sample_s if isfinite(d.t_sample_s) else seen_dvl_t_s
        if isfinite(d.u_mps) and isfinite(d.v_mps) and isfinite(d.w_mps) and isfinite(d.t_sample_s):
            if dvl is not None:
                dvl_interval_s = d.t_sample_s - dvl.t_sample_s
            dvl = d
        else:
            conditions |= NavCondition.NAN_INPUT
            nan_rejected += 1
    a = inputs.ahrs
    if a is not None and not a.t_sample_s <= seen_ahrs_t_s:
        seen_ahrs_t_s = a.t_sample_s if isfinite(a.t_sample_s) else seen_ahrs_t_s
        if (
            isfinite(a.roll_rad)
            and isfinite(a.pitch_rad)
            and isfinite(a.yaw_rad)
            and isfinite(a.p_radps)
            and isfinite(a.q_radps)
            and isfinite(a.r_radps)
            and isfinite(a.t_sample_s)
        ):
            ahrs = a
        else:
            conditions |= NavCondition.NAN_INPUT
            nan_rejected += 1
    z = inputs.depth
    if z is not None and not z.t_sample_s <= seen_depth_t_s:
        seen_depth_t_s = z.t_sample_s if isfinite(z.t_sample_s) else seen_depth_t_s
        if isfinite(z.depth_m) and isfinite(z.t_sample_s):
            depth = z
        else:
            conditions |= NavCondition.NAN_INPUT
            nan_rejected += 1

    dvl_age = _age(now_s, dvl.t_sample_s if dvl else None)
    ahrs_age = _age(now_s, ahrs.t_sample_s if ahrs else None)
    depth_age = _age(now_s, depth.t_sample_s if depth else None)
    dvl_fresh = dvl is not None and dvl_age <= params.dvl_timeout_s
    ahrs_fresh = ahrs is not None and ahrs_age <= params.stale_after_s

    # 2. Predict with the DVL velocity rotated to NED, the latest sample held (a stale one too: the vehicle
    # does not stop when its DVL does; the covariance grows with the sample's age); coast on the bias with
    # more noise without any.
    fx, fy = state.x, state.y
    used_dvl = False
    # The DVL velocity in NED, once a tick: the position predict and the current filter both take it.
    v_ned = _horizontal_velocity(dvl, ahrs) if dvl is not None and ahrs is not None and ahrs_fresh else None
    if fx is not None and fy is not None and dt_s > 0.0:
        if v_ned is not None:
            vx, vy = v_ned
            q_pos = dead_reckoning_q(params, math.hypot(vx, vy), dvl_interval_s, dvl_age, dt_s)
            used_dvl = dvl_fresh
        else:
            vx = vy = 0.0
            q_pos = params.q_pos_stale
        fx = fx.predict(vx, dt_s, q_pos, params.q_bias, params.estimate_bias)
        fy = fy.predict(vy, dt_s, q_pos, params.q_bias, params.estimate_bias)

    # 2b. The water current, on each new DVL sample seen with a fresh attitude.
    current = state.current
    if v_ned is not None and dvl is not None and ahrs is not None and dvl.t_sample_s > state.seen_dvl_t_s:
        current = _current_step(current, dvl, ahrs, v_ned, params)

    # 3. Gate and apply a new position fix.
    last_fix_t_s = state.last_fix_t_s
    accepted_fix_t_s = state.accepted_fix_t_s
    fixes_accepted, fixes_rejected = state.fixes_accepted, state.fixes_rejected
    consecutive = state.consecutive_rejections
    fix: PositionFix | None = inputs.position
    fix_d2: float | None = None
    fix_accepted: bool | None = None
    if fix is not None and not fix.t_sample_s <= last_fix_t_s:
        last_fix_t_s = fix.t_sample_s if isfinite(fix.t_sample_s) else last_fix_t_s
        # The fix's own stated accuracy when coarser than the configured one (a sea-grade fix says so).
        r_m2 = max(params.fix_var_m2, fix.std_m * fix.std_m) if isfinite(fix.std_m) else params.fix_var_m2
        if not (isfinite(fix.x_m) and isfinite(fix.y_m) and isfinite(fix.t_sample_s)):
            conditions |= NavCondition.NAN_INPUT
            nan_rejected += 1
        elif fx is None or fy is None:
            p_b = params.initial_bias_var
            fx = AxisFilter(fix.x_m, 0.0, r_m2, 0.0, p_b)
            fy = AxisFilter(fix.y_m, 0.0, r_m2, 0.0, p_b)
            accepted_fix_t_s = fix.t_sample_s
            fixes_accepted += 1
            fix_accepted = True
        else:
            sx, sy = fx.p00 + r_m2, fy.p00 + r_m2
            fix_d2 = (fix.x_m - fx.p_m) ** 2 / sx + (fix.y_m - fy.p_m) ** 2 / sy
            if fix_d2 <= params.gate_chi2:
                fx = fx.update(fix.x_m, r_m2, params.max_bias_mps)
                fy = fy.update(fix.y_m, r_m2, params.max_bias_mps)
                accepted_fix_t_s = fix.t_sample_s
                fixes_accepted += 1
                consecutive = 0
                fix_accepted = True
            else:
                fixes_rejected += 1
                consecutive += 1
                conditions |= NavCondition.FIX_REJECTED
                fix_accepted = False
                if consecutive >= params.max_consecutive_rejections:
                    # So many fixes in a row disagree with the estimate that the estimate is what is wrong
                    # (a heading error dead-reckoned, a lost gate): it restarts at this fix, the bias kept.
                    fx = AxisFilter(fix.x_m, fx.b_mps, r_m2, 0.0, fx.p11)
                    fy = AxisFilter(fix.y_m, fy.b_mps, r_m2, 0.0, fy.p11)
                    accepted_fix_t_s = fix.t_sample_s
    if consecutive >= params.max_consecutive_rejections:
        conditions |= NavCondition.FIX_REJECTED_REPEATEDLY

    # 4. Conditions.
    fix_age = _age(now_s, accepted_fix_t_s if isfinite(accepted_fix_t_s) else None)
    if fx is None or fy is None:
        conditions |= NavCondition.POSITION_MISSING | NavCondition.POSITION_INVALID
    else:
        if fix_age > params.fix_timeout_s:
            conditions |= NavCondition.POSITION_STALE
        if not max(fx.p00, fy.p00) <= params.max_position_std_m**2:  # dead reckoning's sigma is too wide
            conditions |= NavCondition.POSITION_INVALID
    if dvl is None:
        conditions |= NavCondition.DVL_MISSING
    elif not dvl_fresh:
        conditions |= NavCondition.DVL_STALE
    if ahrs is None:
        conditions |= NavCondition.AHRS_MISSING
    elif not ahrs_fresh:
        conditions |= NavCondition.AHRS_STALE
    if depth is None:
        conditions |= NavCondition.DEPTH_MISSING
    elif depth_age > params.stale_after_s:
        conditions |= NavCondition.DEPTH_STALE

    u = dvl.u_mps if dvl else 0.0
    v = dvl.v_mps if dvl else 0.0
    nav = NavState(
        t_s=now_s,
        x_m=fx.p_m if fx else math.nan,
        y_m=fy.p_m if fy else math.nan,
        depth_m=depth.depth_m if depth else math.nan,
        roll_rad=ahrs.roll_rad if ahrs else math.nan,
        pitch_rad=ahrs.pitch_rad if ahrs else math.nan,
        yaw_rad=ahrs.yaw_rad if ahrs else math.nan,
        u_mps=u,
        v_mps=v,
        w_mps=dvl.w_mps if dvl else 0.0,
        p_radps=ahrs.p_radps if ahrs else math.nan,
        q_radps=ahrs.q_radps if ahrs else math.nan,
        r_radps=ahrs.r_radps if ahrs else math.nan,
        speed_mps=math.hypot(u, v),
        velocity_bias_x_mps=fx.b_mps if fx else 0.0,
        velocity_bias_y_mps=fy.b_mps if fy else 0.0,
        current_north_mps=current.c_n if current else 0.0,
        current_east_mps=current.c_e if current else 0.0,
        current_std_mps=current.current_std_mps if current else math.inf,
        water_speed_mps=current.u_w if current else 0.0,
        position_std_m=math.sqrt(max(fx.p00, 0.0) + max(fy.p00, 0.0)) if fx and fy else math.inf,
        position_std_x_m=math.sqrt(max(fx.p00, 0.0)) if fx else math.inf,
        position_std_y_m=math.sqrt(max(fy.p00, 0.0)) if fy else math.inf,
        position_age_s=fix_age,
        fixes_rejected=fixes_rejected,
        velocity_age_s=dvl_age,
        attitude_age_s=ahrs_age,
        depth_age_s=depth_age,
        conditions=conditions,
    )
    new_state = NavFilterState(
        t_s=now_s,
        x=fx,
        y=fy,
        last_fix_t_s=last_fix_t_s,
        accepted_fix_t_s=accepted_fix_t_s,
        dvl_interval_s=dvl_interval_s,
        dvl=dvl,
        ahrs=ahrs,
        depth=depth,
        seen_dvl_t_s=seen_dvl_t_s,
        seen_ahrs_t_s=seen_ahrs_t_s,
        seen_depth_t_s=seen_depth_t_s,
        fixes_accepted=fixes_accepted,
        fixes_rejected=fixes_rejected,
        consecutive_rejections=consecutive,
        nan_rejected=nan_rejected,
        current=current,
    )
    return nav, new_state, NavDebug(dt_s=dt_s, fix_d2=fix_d2, fix_accepted=fix_accepted, used_dvl=used_dvl)
