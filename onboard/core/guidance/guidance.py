"""Guidance on the planner's :class:`~onboard.core.planner.path.Path`: the desired state and the
path-frame errors.

Modes (``[guidance] mode``):

- ``track`` (faithful to the paper, sections 4-5): a reference point moves along the path at the uniform speed
  ``speed_mps`` from the moment the path becomes active (time-parameterised). Desired x, y, depth, yaw, pitch
  are those of the point, their rates U*cos(yaw), U*sin(yaw), U*d(depth)/ds, U*curvature, 0. The errors fed to
  the revised PD (eqs. 8-10) are e = x_d - x_a (eq. 4) resolved in the path frame at the reference point.
- ``los``: path following. The reference point is the vehicle's projection on the path; the desired yaw is
  psi_d = psi_p + atan(e_cross / lookahead) (e_cross = cross-track error, + when the path is to starboard).
  The along-track error is 0 (speed from the controller's speed map), or with ``speed_loop_limit_m`` the
  integral of the speed error over ground along the path (a speed loop through eq. 8).
- ``ilos``: integral LOS (Borhaug, Pavlov, Pettersen 2008): psi_d = psi_p + atan((e_cross + sigma*I) / Delta),
  dI/dt = U * Delta * e_cross / ((e_cross + sigma*I)^2 + Delta^2), so a constant current is rejected with no
  steady cross-track offset. |sigma*I| is clamped to Delta*tan(``ilos_max_correction_deg``).

Steering (``steer``): ``heading`` points the bow along the desired direction (the paper); ``course`` makes
that direction the course over ground chi_d and heads where the water velocity must point for it, from the
estimated current c (:mod:`onboard.core.nav.current`): psi_d = atan2(U sin chi_d - c_e, U cos chi_d - c_n)
with U = ``speed_mps`` (the crab angle chi_d - psi_d, clamped to +-``crab_max_deg``). The speed through the
water this needs at the reference speed, |U_ref (cos chi_d, sin chi_d) - c|, goes to the controller
(``water_speed_mps``: its propeller and curvature feed-forwards). Along an arc the crab changes with the
course, so the yaw-rate feed-forward is the course rate times d psi_d / d chi_d = U (U - c_along) / |w|^2
(w the water velocity above; 1 in still water). Arrival then judges the course over ground (the DVL's,
above ``crab_min_speed_mps``), not the heading: crabbing is expected.

In every mode the yaw-rate feed-forward is r_d = U * curvature (rad/s, + = right turn) at the reference point.

Nothing is flown past the end of a path: after the last goal the autopilot runs the mission's end action
(:mod:`onboard.core.autopilot`); the extension of the path beyond its end (``sample_extended``) only keeps
the errors defined for a vehicle that has overshot the goal line.

Arrival (latched per path): the vehicle is within ``arrival_radius_m`` of the path end and its heading
within ``arrival_yaw_tol_deg`` of the final heading, or its along-track coordinate is past the end. The
distance is the mission's ``[mission] arrival_radius_m`` (MIS_ARRIVE_R_M), the one arrival threshold, handed
over by :class:`~onboard.core.config.CoreConfig` (:meth:`GuidanceParams.with_arrival_radius`).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import ClassVar, Literal

from auv_common.config import Bound, check_declared, param, require
from onboard.core.guidance.path_frame import (
    depth_rate_per_m,
    path_frame,
    project,
    sample_extended,
    yaw_error,
)
from onboard.core.mission.params import ARRIVAL_RADIUS_DEFAULT_M
from onboard.core.nav.types import NavState
from onboard.core.planner.path import Path, PathSample
from onboard.protocol.conventions import wrap_pi

GuidanceMode = Literal["track", "los", "ilos"]

#: The slowest path speed that means one, m/s: a fin's force goes with the square of the speed through the
#: water, so below 0.1 m/s it has 1 % of its force at 1 m/s and the vehicle cannot steer.
SPEED_MIN_MPS = 0.1
#: The shortest LOS lookahead that means one, m: the LOS heading is atan(e_y / Delta), and the estimate's
#: cross-track noise is decimetres, so below 0.5 m it swings through +-90 deg on the noise.
LOOKAHEAD_MIN_M = 0.5
#: The run-in's track reference falls at most this far behind the vehicle, m (:func:`step`): eq. 8 then
#: takes the propeller down while the vehicle is faster than the run-in's speed, and the reference is back
#: with the vehicle within seconds once it is not.
RUN_IN_LAG_M = 1.0
#: On the run-in a path's depth change is done before the speed reference falls below this (m/s): the
#: stern planes' lift goes with the speed squared (half of it at 0.7 m/s) and the hull is buoyant.
RUN_IN_DEPTH_SPEED_MPS = 0.7
#: The path speed's minimum: :data:`SPEED_MIN_MPS`, or the steerage way ``min_water_speed_mps`` if larger.
_SPEED_MIN = Bound(
    lambda g: max(SPEED_MIN_MPS, g.min_water_speed_mps), f"min_water_speed_mps where above {SPEED_MIN_MPS:g}"
)


@dataclass(frozen=True)
class GuidanceParams:
    """The ``[guidance]`` table. Every key is optional.

    - ``mode``: ``"track"`` (paper), ``"los"`` or ``"ilos"``.
    - ``speed_mps``: desired (uniform) speed U along the path.
    - ``lookahead_m``: LOS lookahead distance Delta; ``lookahead_time_s``:
      with > 0, Fossen's speed-dependent lookahead Delta = max(``lookahead_m``, U * this) with U the speed
      over ground (s), so a faster vehicle (a following current) converges on the path over the same time,
      not distance.
    - ``ilos_gain``: ILOS integral gain sigma (dimensionless).
    - ``ilos_max_correction_deg``: clamp on the integral's heading correction, deg.
    - ``arrival_yaw_tol_deg``: arrival's heading tolerance, deg (its distance is ``[mission]
      arrival_radius_m``: ``arrival_radius_m`` here, set by the core's configuration).
    - ``search_back_m``, ``search_ahead_m``: window of the projection around the previous one, m.
    - ``reference_accel_mps2``: the reference speed starts at rest and speeds up at this rate to
      ``speed_mps`` (0 = the paper's uniform speed from the first instant, which a vehicle starting at rest
      cannot follow: the along-track error grows at the start, paper Fig. 10); in ``los`` / ``ilos`` it is
      the speed the feed-forward and the speed loop ask for.
    - ``reference_stops_at_end``: ``track`` only: the moving reference waits at the path's end (the goal)
      instead of running on along its extension (the paper's uniform reference), so a vehicle that lags is
      drawn to the goal, not past it.
    - ``lateral``: ``track`` only: ``"reference"`` (the paper: cross-track and yaw errors at the moving
      reference point) or ``"path"`` (at the vehicle's projection on the path, with a LOS heading
      correction over ``lookahead_m``; the reference point then only sets the along-track error). When the
      vehicle lags, "reference" makes it cut corners towards a point already around the bend.
    - ``curvature_preview_s``: ``lateral = "path"``, ``los`` and ``ilos``: the yaw-rate feed-forward uses the
      curvature this many seconds (at the commanded speed ``speed_mps``) ahead of the projection, so the
      rudder moves before the arc begins (the fins and the yaw dynamics lag by a fraction of a second).
    - ``speed_loop_limit_m``: ``los`` / ``ilos`` only: with > 0, the speed over ground along the path is held
      at the reference speed through eq. 8's along-track terms: e_x is the integral of (U_ref - speed along
      the path), limited to +-this (m; anti-windup), so Kp1 integrates and KD1 is proportional on the speed
      error; 0 = the textbook LOS, speed from the controller's speed map alone.
    - ``steer``: ``"heading"`` (the paper) or ``"course"`` (course over ground, module docstring);
      ``crab_max_deg`` (deg): the clamp on the crab angle; ``crab_min_speed_mps`` (m/s): below this speed
      over ground arrival judges the heading (the DVL's course is noise at rest); ``min_water_speed_mps``
      (m/s, 0 = off): steerage way: where a following current would leave less speed through the water
      than this at ``speed_mps`` over ground, the speed over ground asked for rises until it does not
      (c_along + sqrt(min^2 - c_across^2)): the fins' force goes with the square of the water speed.
    - ``cross_error_limit_m``: where the heading reference already carries the cross-track error (LOS,
      ILOS, and ``track`` with ``lateral = "path"``), the cross-track error handed to the controller's
      eq. 9 term is limited to +-this (m; 0 = no limit). Far from the path the LOS heading must win: an
      unlimited Kp5 * e_y term saturates the rudder whatever the heading, and the vehicle circles.
    """

    #: Keys that were removed, and why (``auv_common.config.from_table`` refuses them with this reason).
    REMOVED_KEYS: ClassVar[dict[str, str]] = {
        "arrival_position_tol_m": "the arrival distance has one owner, [mission] arrival_radius_m "
        "(MIS_ARRIVE_R_M): set that instead",
    }

    mode: GuidanceMode = "track"
    speed_mps: float = param(
        1.0, unit="m/s", min=_SPEED_MIN, operator=(0.0, 5.0), mavlink="GDE_SPEED_MPS",
        desc="speed along the path",
    )  # fmt: skip
    lookahead_m: float = param(
        3.0, unit="m", min=LOOKAHEAD_MIN_M, operator=(0.0, 50.0), mavlink="GDE_LOOKAHD_M",
        desc="LOS lookahead distance",
    )  # fmt: skip
    lookahead_time_s: float = 0.0
    ilos_gain: float = param(
        0.3, min=0.0, operator=(0.0, 10.0), mavlink="GDE_ILOS_GAIN", desc="ILOS integral gain"
    )
    ilos_max_correction_deg: float = 30.0
    arrival_yaw_tol_deg: float = 10.0
    search_back_m: float = 2.0
    search_ahead_m: float = 10.0
    reference_accel_mps2: float = param(
        0.0, unit="m/s^2", min=0.0, operator=(0.0, 5.0), mavlink="GDE_ACCEL_MPS2",
        desc="track reference acceleration",
    )  # fmt: skip
    lateral: Literal["reference", "path"] = "reference"
    curvature_preview_s: float = param(
        0.0, unit="s", min=0.0, operator=(0.0, 10.0), mavlink="GDE_PREVIEW_S",
        desc="curvature feed-forward preview",
    )  # fmt: skip
    cross_error_limit_m: float = param(
        0.0, unit="m", min=0.0, operator=(0.0, 50.0), mavlink="GDE_XERR_LIM_M",
        desc="cross-track error limit (0 = none)",
    )  # fmt: skip
    speed_loop_limit_m: float = 0.0
    steer: Literal["heading", "course"] = "heading"
    crab_min_speed_mps: float = 0.3
    crab_max_deg: float = 40.0
    min_water_speed_mps: float = param(
        0.0, unit="m/s", min=0.0, desc="steerage way: least speed through the water (0 = off)"
    )
    reference_stops_at_end: bool = False
    #: The arrival distance, m: ``[mission] arrival_radius_m`` (MIS_ARRIVE_R_M), handed over by CoreConfig.
    arrival_radius_m: float = field(default=ARRIVAL_RADIUS_DEFAULT_M, init=False)
    arrival_yaw_tol_rad: float = field(init=False, repr=False)
    ilos_max_correction_rad: float = field(init=False, repr=False)
    crab_max_rad: float = field(init=False, repr=False)

    def __post_init__(self) -> None:
        check_declared(self)
        require(self.lookahead_time_s >= 0.0, f"lookahead_time_s must be >= 0, got {self.lookahead_time_s}")
        require(0.0 < self.ilos_max_correction_deg < 90.0, "ilos_max_correction_deg must be in (0, 90)")
        require(0.0 < self.arrival_yaw_tol_deg <= 180.0, "arrival_yaw_tol_deg must be in (0, 180]")
        require(self.search_back_m >= 0.0 and self.search_ahead_m > 0.0, "search window must be positive")
        require(self.speed_loop_limit_m >= 0.0, "speed_loop_limit_m must be >= 0")
        require(self.crab_min_speed_mps > 0.0, "crab_min_speed_mps must be > 0")
        require(0.0 <= self.crab_max_deg < 90.0, "crab_max_deg must be in [0, 90)")
        object.__setattr__(self, "crab_max_rad", math.radians(self.crab_max_deg))
        object.__setattr__(self, "arrival_yaw_tol_rad", math.radians(self.arrival_yaw_tol_deg))
        object.__setattr__(self, "ilos_max_correction_rad", math.radians(self.ilos_max_correction_deg))

    def with_arrival_radius(self, arrival_radius_m: float) -> GuidanceParams:
        """These parameters with the mission's arrival radius (m): MIS_ARRIVE_R_M."""
        if arrival_radius_m == self.arrival_radius_m:
            return self
        new = dataclasses.replace(self)
        object.__setattr__(new, "arrival_radius_m", arrival_radius_m)
        return new


#: Arrival within the radius needs the path left (from the vehicle's projection) within this many radii:
#: an approach's path left is its distance, or at most pi/2 of it along a half circle, so it never binds
#: there; a loop of the path near the goal (a helix circle the planner put by it: with a goal's own radius of
#: metres, within reach) is a full turn long (without it a 4 m radius arrives entering a circle 3 m off).
ARRIVAL_PATH_LEFT_FACTOR = 2.0


@dataclass(frozen=True)
class GuidanceState:
    """Guidance memory for one path; start each new path from ``GuidanceState()``.

    ``t_s``: time since the path became active, s; ``s_ref_m``: arc length of the moving reference (track);
    ``s_proj_m``: the vehicle's last projection (None before the first); ``ilos_int_m``: the ILOS integral I;
    ``speed_int_m``: the LOS speed loop's along-track error, m; ``arrived``: latched arrival.
    """

    t_s: float = 0.0
    s_ref_m: float = 0.0
    s_proj_m: float | None = None
    ilos_int_m: float = 0.0
    arrived: bool = False
    ref_speed_mps: float = 0.0
    speed_int_m: float = 0.0


@dataclass(frozen=True)
class GuidanceReference:
    """The desired state and the errors for the controller. NED, m, rad, s.

    Desired: ``x_m, y_m, depth_m, yaw_rad, pitch_rad`` and their rates; ``speed_mps`` = U (over ground),
    ``water_speed_mps`` the speed through the water that needs (= U unless ``steer = "course"``),
    ``yaw_rate_radps`` = U * ``curvature_1pm`` (the yaw-rate feed-forward).
    Vehicle on the path: ``along_track_m`` (its projection's arc length), ``cross_track_m`` (+ = vehicle to
    starboard of the path), ``distance_to_end_m``.
    Errors e = desired - actual (eq. 4): ``e_along_m``, ``e_cross_m`` (path frame at the reference point; for
    a path along +x these are the paper's e_x, e_y), ``e_depth_m`` (+ = must go deeper), ``e_yaw_rad``
    (wrapped, + = must turn right), ``e_pitch_rad`` (+ = must pitch nose up).
    ``nav_ok`` is False when the vehicle pose was not finite (the errors are then NaN).
    """

    mode: str
    s_ref_m: float
    x_m: float
    y_m: float
    depth_m: float
    yaw_rad: float
    pitch_rad: float
    x_rate_mps: float
    y_rate_mps: float
    depth_rate_mps: float
    yaw_rate_radps: float
    pitch_rate_radps: float
    speed_mps: float
    water_speed_mps: float
    curvature_1pm: float
    along_track_m: float
    cross_track_m: float
    distance_to_end_m: float
    e_along_m: float
    e_cross_m: float
    e_depth_m: float
    e_yaw_rad: float
    e_pitch_rad: float
    arrived: bool
    nav_ok: bool = True


@dataclass(frozen=True)
class GuidanceDebug:
    """Per-step numbers: the LOS heading correction (rad), the ILOS integral (m) and the crab angle (rad);
    ``run_in``: the run-in's speed limit holds the speed reference down this step (:func:`step`)."""

    los_correction_rad: float = 0.0
    ilos_int_m: float = 0.0
    crab_rad: float = 0.0
    run_in: bool = False


def step(
    nav: NavState,
    path: Path,
    state: GuidanceState,
    params: GuidanceParams,
    dt_s: float,
    *,
    arrival_speed_mps: float = 0.0,
    run_in_decel_mps2: float = 0.0,
    run_in_depth_slope: float = 0.0,
    arrival_radius_m: float | None = None,
) -> tuple[GuidanceReference, GuidanceState, GuidanceDebug]:
    """One guidance step of ``dt_s`` seconds (>= 0) on ``path`` for the vehicle state ``nav``.

    The run-in (``arrival_speed_mps`` > 0, the mission's last goal: the executive says so): the speed
    reference is at most sqrt(arrival^2 + 2 * ``run_in_decel_mps2`` * the path left from the vehicle's
    projection), so the vehicle reaches the goal at ``arrival_speed_mps`` and can stop within a few metres
    after it (:mod:`onboard.core.executive.surface`); in ``track`` the moving reference moves at that speed
    (a vehicle that lags catches it up over the run-in, not at the goal: it used to arrive at 1.3 m/s and
    glide 20 m) and falls at most :data:`RUN_IN_LAG_M` behind the vehicle. With ``run_in_depth_slope`` > 0
    the path's depth change is done before the run-in is slower than :data:`RUN_IN_DEPTH_SPEED_MPS`, at
    most that steep (:func:`run_in_depth`).

    ``arrival_radius_m``: the arrival distance of this path's end when its goal gives its own (the
    executive resolves it, :func:`onboard.core.mission.model.goal_radius_m`); None = ``params``'.
    """
    dt_s = max(0.0, dt_s) if math.isfinite(dt_s) else 0.0
    mode = params.mode
    speed = params.speed_mps
    length = path.length_m
    x_a, y_a, yaw_a = nav.x_m, nav.y_m, nav.yaw_rad
    nav_ok = math.isfinite(x_a) and math.isfinite(y_a) and math.isfinite(yaw_a)
    lateral_at_proj = mode == "track" and params.lateral == "path"

    # Vehicle projection on the (extended) path, local to the previous one.
    s_prev = state.s_proj_m
    if not nav_ok:
        s_proj = s_prev if s_prev is not None else 0.0
    elif s_prev is None:  # a new path begins where the vehicle is (planned from there): from its start
        s_proj = project(path, x_a, y_a, 0.0, params.search_ahead_m + speed * dt_s)
    else:
        s_proj = project(
            path, x_a, y_a, s_prev - params.search_back_m, s_prev + params.search_ahead_m + speed * dt_s
        )
    proj = sample_extended(path, s_proj)

    los_corr = 0.0
    ilos_int = state.ilos_int_m
    s_ref = state.s_ref_m
    if params.steer == "course" and params.min_water_speed_mps > 0.0 and nav_ok:
        speed = _steerage_speed_mps(nav, proj.yaw_rad, speed, params.min_water_speed_mps)
    ref_speed = speed
    if params.reference_accel_mps2 > 0.0:  # the speed asked for starts at rest (every mode)
        ref_speed = min(speed, state.ref_speed_mps + params.reference_accel_mps2 * dt_s)
    run_in = False
    if arrival_speed_mps > 0.0 and run_in_decel_mps2 > 0.0 and nav_ok:
        left_m = max(length - s_proj, 0.0)
        cap = math.sqrt(arrival_speed_mps**2 + 2.0 * run_in_decel_mps2 * left_m)
        # through the water: a following current adds its share (the vehicle cannot brake it away)
        c_along = nav.current_north_mps * math.cos(proj.yaw_rad) + nav.current_east_mps * math.sin(
            proj.yaw_rad
        )
        cap += max(c_along, 0.0) if math.isfinite(c_along) else 0.0
        run_in = cap < ref_speed
        ref_speed = min(ref_speed, cap)
    if mode == "track":
        s_ref += ref_speed * dt_s
        if params.reference_stops_at_end:
            s_ref = min(s_ref, length)
        if run_in:  # a vehicle faster than the run-in's speed is held back, not left behind
            s_ref = max(s_ref, s_proj - RUN_IN_LAG_M)
        ref = sample_extended(path, s_ref)
    else:
        s_ref = s_proj
        ref = proj

    yaw_d = ref.yaw_rad
    curvature = ref.curvature_1pm
    if not nav_ok:
        e_along = e_cross = cross_track = math.nan
    else:
        _, cross_track = path_frame(x_a - proj.x_m, y_a - proj.y_m, proj.yaw_rad)
        if lateral_at_proj:
            # Lateral errors at the vehicle's projection; the reference point sets only the along-track error.
            e_along = s_ref - s_proj
            e_cross = -cross_track
            los_corr = math.atan(e_cross / params.lookahead_m)
            yaw_d = wrap_pi(proj.yaw_rad + los_corr)
            curvature = sample_extended(path, s_proj + speed * params.curvature_preview_s).curvature_1pm
        else:
            e_along, e_cross = path_frame(ref.x_m - x_a, ref.y_m - y_a, ref.yaw_rad)
    speed_int = state.speed_int_m
    if mode != "track":
        e_along = 0.0
        if params.speed_loop_limit_m > 0.0 and nav_ok:
            # The speed loop: the along-track error of a reference that would move at ref_speed over
            # ground, integrated from the speed over ground along the path (limited: anti-windup)
            vn, ve, _ = nav.velocity_ned_mps
            along = vn * math.cos(proj.yaw_rad) + ve * math.sin(proj.yaw_rad)
            lim = params.speed_loop_limit_m
            speed_int = min(max(speed_int + dt_s * (ref_speed - along), -lim), lim)
            e_along = speed_int
        if nav_ok:
            curvature = sample_extended(path, s_proj + speed * params.curvature_preview_s).curvature_1pm
        delta = params.lookahead_m
        if params.lookahead_time_s > 0.0 and nav_ok:
            vn, ve, _ = nav.velocity_ned_mps
            delta = max(delta, math.hypot(vn, ve) * params.lookahead_time_s)
        sigma = params.ilos_gain if mode == "ilos" else 0.0
        if mode == "ilos" and nav_ok:
            ilos_int += dt_s * speed * delta * e_cross / ((e_cross + sigma * ilos_int) ** 2 + delta**2)
            if sigma > 0.0:
                bound = delta * math.tan(params.ilos_max_correction_rad) / sigma
                ilos_int = min(max(ilos_int, -bound), bound)
        if nav_ok:
            los_corr = math.atan((e_cross + sigma * ilos_int) / delta)
            yaw_d = wrap_pi(ref.yaw_rad + los_corr)

    crab = 0.0
    water_speed = ref_speed
    course_a = yaw_a
    turn_rate_factor = 1.0
    if params.steer == "course" and nav_ok:
        cn, ce = nav.current_north_mps, nav.current_east_mps
        cos_d, sin_d = math.cos(yaw_d), math.sin(yaw_d)
        crab_limit = params.crab_max_rad
        w_n, w_e = speed * cos_d - cn, speed * sin_d - ce  # the water velocity the course takes
        crab = wrap_pi(yaw_d - math.atan2(w_e, w_n))
        if abs(crab) < crab_limit:
            # d psi_d / d chi_d: along an arc the crab changes with the course, so the heading turns at
            # this times the course's rate (U (U - c_along) / |w|^2; the yaw-rate feed-forward takes it)
            turn_rate_factor = speed * (speed - cn * cos_d - ce * sin_d) / max(w_n * w_n + w_e * w_e, 1e-6)
        crab = min(max(crab, -crab_limit), crab_limit)
        yaw_d = wrap_pi(yaw_d - crab)
        water_speed = math.hypot(ref_speed * cos_d - cn, ref_speed * sin_d - ce)
        vn, ve, _ = nav.velocity_ned_mps
        if math.hypot(vn, ve) >= params.crab_min_speed_mps:
            course_a = math.atan2(ve, vn)

    limit = params.cross_error_limit_m
    if limit > 0.0 and (mode != "track" or params.lateral == "path") and math.isfinite(e_cross):
        e_cross = min(max(e_cross, -limit), limit)

    end = path.sample(length)  # cached by the path
    if nav_ok:
        dist_end = math.hypot(x_a - end.x_m, y_a - end.y_m)
        radius_m = params.arrival_radius_m if arrival_radius_m is None else arrival_radius_m
        # within the radius of the end along the path too: a loop that passes near the goal (a helix
        # circle, its depth still to lose) is no arrival (:data:`ARRIVAL_PATH_LEFT_FACTOR`)
        at_end = (
            dist_end <= radius_m
            and length - s_proj <= ARRIVAL_PATH_LEFT_FACTOR * radius_m
            and abs(yaw_error(end.yaw_rad, course_a)) <= params.arrival_yaw_tol_rad
        )
        arrived = state.arrived or at_end or s_proj >= length
    else:
        dist_end = math.nan
        arrived = state.arrived

    # Depth and pitch where the vehicle is (its projection) when the lateral errors are taken there too: a
    # reference point metres ahead of a lagging vehicle asks for the next depth too early.
    vert = proj if lateral_at_proj else ref
    slope = depth_rate_per_m(path, vert.s_m)
    if arrival_speed_mps > 0.0 and run_in_decel_mps2 > 0.0 and run_in_depth_slope > 0.0:
        vert, slope = run_in_depth(path, vert, arrival_speed_mps, run_in_decel_mps2, run_in_depth_slope)
    reference = GuidanceReference(
        mode=mode,
        s_ref_m=s_ref,
        x_m=ref.x_m,
        y_m=ref.y_m,
        depth_m=vert.depth_m,
        yaw_rad=yaw_d,
        pitch_rad=vert.pitch_rad,
        x_rate_mps=ref_speed * math.cos(ref.yaw_rad),
        y_rate_mps=ref_speed * math.sin(ref.yaw_rad),
        depth_rate_mps=ref_speed * slope,
        yaw_rate_radps=ref_speed * curvature * turn_rate_factor,
        pitch_rate_radps=0.0,
        speed_mps=ref_speed,
        water_speed_mps=water_speed,
        curvature_1pm=curvature,
        along_track_m=s_proj,
        cross_track_m=cross_track,
        distance_to_end_m=dist_end,
        e_along_m=e_along,
        e_cross_m=e_cross,
        e_depth_m=vert.depth_m - nav.depth_m,
        e_yaw_rad=yaw_error(yaw_d, yaw_a) if nav_ok else math.nan,
        e_pitch_rad=vert.pitch_rad - nav.pitch_rad,
        arrived=arrived,
        nav_ok=nav_ok,
    )
    new_state = GuidanceState(
        t_s=state.t_s + dt_s,
        s_ref_m=s_ref,
        s_proj_m=s_proj if nav_ok else s_prev,
        ilos_int_m=ilos_int,
        arrived=arrived,
        ref_speed_mps=ref_speed,
        speed_int_m=speed_int,
    )
    debug = GuidanceDebug(los_correction_rad=los_corr, ilos_int_m=ilos_int, crab_rad=crab, run_in=run_in)
    return reference, new_state, debug


def run_in_depth(
    path: Path, at: PathSample, arrival_speed_mps: float, decel_mps2: float, max_slope: float
) -> tuple[PathSample, float]:
    """The run-in's depth reference at ``at`` and its slope d(depth)/ds: the path's depth change done where
    the run-in's speed reference is still :data:`RUN_IN_DEPTH_SPEED_MPS` (sqrt(arrival^2 + 2 decel x the
    path left)), the path's own linear profile where that would be steeper than ``max_slope``. Slow, the
    stern planes lose their lift (it goes with the speed squared) and the buoyant hull rises: a depth
    change flown on to the goal on the slow run-in ended 0.43 m short of a 10 m goal (0.005 m at speed)."""
    length = path.length_m
    dz = path.end_depth_m - path.start_depth_m
    slow_m = max(RUN_IN_DEPTH_SPEED_MPS**2 - arrival_speed_mps**2, 0.0) / (2.0 * decel_mps2)
    done_m = min(length, max(length - slow_m, abs(dz) / max_slope))
    if not (dz != 0.0 and 0.0 < done_m < length):
        return at, depth_rate_per_m(path, at.s_m)
    slope = dz / done_m
    beyond = at.s_m >= done_m
    sample = dataclasses.replace(
        at,
        depth_m=path.start_depth_m + slope * min(max(at.s_m, 0.0), done_m),
        pitch_rad=0.0 if beyond else -math.atan(slope),
    )
    return sample, 0.0 if beyond else slope


def _steerage_speed_mps(nav: NavState, course_rad: float, speed_mps: float, min_water_mps: float) -> float:
    """The speed over ground (m/s) to ask for along ``course_rad``: ``speed_mps``, or more where the
    estimated current follows so much that less than ``min_water_mps`` would be left through the water."""
    cos_t, sin_t = math.cos(course_rad), math.sin(course_rad)
    cn, ce = nav.current_north_mps, nav.current_east_mps
    c_along, c_across = cn * cos_t + ce * sin_t, ce * cos_t - cn * sin_t
    if abs(c_across) >= min_water_mps:  # the crab alone takes the water speed: no speed-up helps
        return speed_mps
    return max(speed_mps, c_along + math.sqrt(min_water_mps**2 - c_across**2))
