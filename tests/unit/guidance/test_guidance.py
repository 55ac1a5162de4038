"""Unit tests of guidance: path-frame errors, the moving reference, feed-forward, arrival, LOS and ILOS."""

from __future__ import annotations

import math

import pytest

from onboard.core.guidance import GuidanceParams, GuidanceState, path_frame, project, step
from onboard.core.nav import nav_state_at
from onboard.core.planner.path import ArcSegment, Path, StraightSegment
from onboard.protocol.conventions import wrap_pi

DT = 0.05


def straight(yaw_rad: float, length_m: float = 50.0, x0: float = 0.0, y0: float = 0.0) -> Path:
    return Path(segments=(StraightSegment(x0, y0, yaw_rad, length_m),), start_depth_m=1.0, end_depth_m=1.0)


def s_then_right_arc() -> Path:
    """10 m north, then a 90 deg right arc of radius 5 m (centre (10, 5)), then 10 m east."""
    return Path(
        segments=(
            StraightSegment(0.0, 0.0, 0.0, 10.0),
            ArcSegment(10.0, 5.0, 5.0, +1, 0.0, math.pi / 2),
            StraightSegment(15.0, 5.0, math.pi / 2, 10.0),
        ),
        start_depth_m=1.0,
        end_depth_m=2.0,
    )


def rotate(x: float, y: float, yaw: float) -> tuple[float, float]:
    """A vector given in the path frame (along, cross) expressed in NED."""
    return x * math.cos(yaw) - y * math.sin(yaw), x * math.sin(yaw) + y * math.cos(yaw)


@pytest.mark.parametrize("yaw_deg", [0.0, 90.0, 180.0, -90.0, 179.0, -179.0, 45.0])
def test_path_frame_errors_at_any_heading(yaw_deg: float) -> None:
    # GIVEN a straight path at some heading and a vehicle 2 m behind the reference point and 1 m to port
    # of it, heading 0.1 rad left of the path (placed so that its yaw may cross +-pi)
    yaw = math.radians(yaw_deg)
    path = straight(yaw)
    dx, dy = rotate(-2.0, -1.0, yaw)
    ref_x, ref_y = rotate(10.0, 0.0, yaw)
    nav = nav_state_at(ref_x + dx, ref_y + dy, 1.0, wrap_pi(yaw - 0.1))
    # WHEN guidance runs with the reference 10 m along the path
    state = GuidanceState(s_ref_m=10.0, s_proj_m=8.0)
    r, _, _ = step(nav, path, state, GuidanceParams(), 0.0)
    # THEN the path-frame errors are the same at every heading: e_x = +2, e_y = +1, e_psi = +0.1
    assert r.e_along_m == pytest.approx(2.0)
    assert r.e_cross_m == pytest.approx(1.0)
    assert r.e_yaw_rad == pytest.approx(0.1)
    assert r.cross_track_m == pytest.approx(-1.0)  # the vehicle is to port of the path
    assert r.along_track_m == pytest.approx(8.0)


def test_path_along_x_gives_the_papers_errors() -> None:
    # GIVEN the paper's straight line (-13, 0) -> (15, 0) and any vehicle position
    path = straight(0.0, 28.0, x0=-13.0)
    nav = nav_state_at(-5.3, 0.4, 1.0, 0.0)
    r, _, _ = step(nav, path, GuidanceState(s_ref_m=9.0), GuidanceParams(), 0.0)
    # THEN e_x = x_d - x_a and e_y = y_d - y_a (eq. 4)
    assert r.e_along_m == pytest.approx(r.x_m - nav.x_m)
    assert r.e_cross_m == pytest.approx(r.y_m - nav.y_m)


@pytest.mark.parametrize(("x", "y", "expected"), [(1.0, 0.0, (1.0, 0.0)), (0.0, 1.0, (0.0, 1.0))])
def test_path_frame_identity_at_north(x: float, y: float, expected: tuple[float, float]) -> None:
    assert path_frame(x, y, 0.0) == pytest.approx(expected)


def test_track_reference_moves_at_uniform_speed() -> None:
    # GIVEN the track mode at 1.2 m/s and a vehicle that does not move
    path = s_then_right_arc()
    params = GuidanceParams(mode="track", speed_mps=1.2)
    nav = nav_state_at(0.0, 0.0, 1.0, 0.0)
    state = GuidanceState()
    # WHEN 10 s pass in 0.05 s steps
    for _ in range(200):
        r, state, _ = step(nav, path, state, params, DT)
    # THEN the reference has moved 12 m of arc length, with the path's pose and the rates U*(...)
    assert r.s_ref_m == pytest.approx(12.0)
    p = path.sample(12.0)
    assert (r.x_m, r.y_m, r.yaw_rad, r.depth_m) == pytest.approx((p.x_m, p.y_m, p.yaw_rad, p.depth_m))
    assert r.x_rate_mps == pytest.approx(1.2 * math.cos(p.yaw_rad))
    assert r.y_rate_mps == pytest.approx(1.2 * math.sin(p.yaw_rad))
    assert r.depth_rate_mps == pytest.approx(1.2 * path.depth_slope)
    assert r.pitch_rad == pytest.approx(p.pitch_rad) and r.pitch_rad < 0.0  # diving: nose down
    assert state.t_s == pytest.approx(10.0)


@pytest.mark.parametrize(
    ("s_m", "curvature"), [(5.0, 0.0), (12.0, 0.2), (22.0, 0.0)]
)  # on the first straight, the right arc (R = 5 m), the last straight
def test_yaw_rate_feedforward_is_u_times_curvature(s_m: float, curvature: float) -> None:
    # GIVEN the reference at arc length s_m
    r, _, _ = step(nav_state_at(), s_then_right_arc(), GuidanceState(s_ref_m=s_m), GuidanceParams(), 0.0)
    # THEN r_d = U * curvature (+ = right turn)
    assert r.curvature_1pm == pytest.approx(curvature)
    assert r.yaw_rate_radps == pytest.approx(GuidanceParams().speed_mps * curvature)


def test_left_arc_feedforward_is_negative() -> None:
    path = Path(segments=(ArcSegment(0.0, -4.0, 4.0, -1, 0.0, math.pi),), start_depth_m=1.0, end_depth_m=1.0)
    r, _, _ = step(nav_state_at(), path, GuidanceState(s_ref_m=2.0), GuidanceParams(speed_mps=2.0), 0.0)
    assert r.yaw_rate_radps == pytest.approx(-0.5)


@pytest.mark.parametrize(
    ("offset_to_centre_m", "sign"), [(1.0, +1), (-1.0, -1)]
)  # inside the right turn = to starboard of the path; outside = to port
def test_cross_track_on_an_arc(offset_to_centre_m: float, sign: int) -> None:
    # GIVEN a vehicle on the arc's 45 deg radius, moved towards (or away from) the centre
    path = s_then_right_arc()
    a = math.pi / 4  # path yaw at the middle of the arc
    px, py = 10.0 + 5.0 * math.sin(a), 5.0 - 5.0 * math.cos(a)
    ux, uy = (10.0 - px) / 5.0, (5.0 - py) / 5.0
    nav = nav_state_at(px + offset_to_centre_m * ux, py + offset_to_centre_m * uy, 1.0, a)
    # WHEN guidance projects it
    r, _, _ = step(nav, path, GuidanceState(s_proj_m=13.0), GuidanceParams(mode="los"), 0.0)
    # THEN the along-track is the arc length of that radius and the cross-track is +-1 m
    assert r.along_track_m == pytest.approx(10.0 + 5.0 * a)
    assert r.cross_track_m == pytest.approx(sign * 1.0)
    assert r.e_cross_m == pytest.approx(-sign * 1.0)


def test_projection_is_local_on_a_path_that_passes_near_itself() -> None:
    # GIVEN a U-turn path whose two legs are 10 m apart
    path = Path(
        segments=(
            StraightSegment(0.0, 0.0, 0.0, 20.0),
            ArcSegment(20.0, 5.0, 5.0, +1, 0.0, math.pi),
            StraightSegment(20.0, 10.0, math.pi, 20.0),
        )
    )
    # WHEN the vehicle is 5.1 m to starboard of leg 1 (4.9 m from leg 2) and was last on leg 1
    s = project(path, 10.0, 5.1, 8.0, 20.0)
    # THEN it stays on leg 1; a global search would jump to leg 2
    assert s == pytest.approx(10.0)
    assert project(path, 10.0, 5.1) > 20.0


@pytest.mark.parametrize(
    ("dx_m", "dyaw_deg", "arrived"),
    [
        (-0.3, 5.0, True),  # within 0.5 m and 10 deg
        (-0.3, 30.0, False),  # position ok, heading not
        (-0.8, 0.0, False),  # too far before the end
        (0.05, 30.0, True),  # along-track past the end counts whatever the heading
        (3.0, 90.0, True),
    ],
)
def test_arrival_tolerance(dx_m: float, dyaw_deg: float, arrived: bool) -> None:
    # GIVEN a straight path ending at (20, 0) heading north, a vehicle dx_m along it from the end
    path = straight(0.0, 20.0)
    nav = nav_state_at(20.0 + dx_m, 0.0, 1.0, math.radians(dyaw_deg))
    # WHEN guidance runs
    params = GuidanceParams(arrival_yaw_tol_deg=10.0).with_arrival_radius(0.5)  # MIS_ARRIVE_R_M
    r, state, _ = step(nav, path, GuidanceState(s_proj_m=19.0), params, DT)
    # THEN arrival follows the tolerance and latches
    assert r.arrived is arrived
    if arrived:
        r2, _, _ = step(nav_state_at(0.0, 0.0, 1.0, 0.0), path, state, params, DT)
        assert r2.arrived


def test_nan_nav_gives_nan_errors_and_keeps_state() -> None:
    path = straight(0.0)
    nav = nav_state_at(float("nan"), 0.0, 1.0, 0.0)
    r, s, _ = step(nav, path, GuidanceState(s_proj_m=3.0), GuidanceParams(mode="ilos"), DT)
    assert not r.nav_ok and math.isnan(r.e_cross_m) and math.isnan(r.e_yaw_rad)
    assert s.s_proj_m == 3.0 and s.ilos_int_m == 0.0


def _fly(
    path: Path, params: GuidanceParams, current: tuple[float, float], t_s: float, y0: float
) -> tuple[float, float]:
    """Kinematic vehicle at speed U whose heading follows psi_d with a 0.5 s lag; returns (final |cross|,
    max |cross| over the last 10 s)."""
    x, y, yaw = 0.0, y0, 0.0
    state = GuidanceState()
    tail = 0.0
    n = int(t_s / DT)
    r = None
    for k in range(n):
        nav = nav_state_at(x, y, 1.0, wrap_pi(yaw))
        r, state, _ = step(nav, path, state, params, DT)
        yaw += DT * wrap_pi(r.yaw_rad - yaw) / 0.5
        x += DT * (params.speed_mps * math.cos(yaw) + current[0])
        y += DT * (params.speed_mps * math.sin(yaw) + current[1])
        if k > n - int(10.0 / DT):
            tail = max(tail, abs(r.cross_track_m))
    assert r is not None
    return abs(r.cross_track_m), tail


@pytest.mark.parametrize("y0", [5.0, -5.0])
def test_los_converges_to_the_path(y0: float) -> None:
    # GIVEN a vehicle 5 m off a straight path, no current  WHEN LOS guides it for 60 s  THEN it is on the path
    final, tail = _fly(straight(0.0, 500.0), GuidanceParams(mode="los", speed_mps=1.0), (0.0, 0.0), 60.0, y0)
    assert final < 0.02 and tail < 0.05


def test_ilos_removes_a_constant_current_offset_that_los_keeps() -> None:
    # GIVEN a 0.3 m/s current across a northbound path
    path = straight(0.0, 500.0)
    current = (0.0, 0.3)
    # WHEN plain LOS and integral LOS guide the vehicle for 150 s
    los_final, _ = _fly(path, GuidanceParams(mode="los", speed_mps=1.0), current, 150.0, 0.0)
    ilos_final, ilos_tail = _fly(path, GuidanceParams(mode="ilos", speed_mps=1.0), current, 150.0, 0.0)
    # THEN LOS keeps the steady offset Delta * tan(crab) and ILOS removes it
    crab = math.asin(0.3 / 1.0)
    assert los_final == pytest.approx(3.0 * math.tan(crab), rel=0.1)
    assert ilos_final < 0.05 and ilos_tail < 0.1


def test_reference_accelerates_from_rest_when_configured() -> None:
    # GIVEN a track reference that speeds up at 0.2 m/s^2 to 1.0 m/s
    params = GuidanceParams(mode="track", speed_mps=1.0, reference_accel_mps2=0.2)
    nav = nav_state_at(0.0, 0.0, 1.0, 0.0)
    state = GuidanceState()
    # WHEN 10 s pass
    for _ in range(200):
        r, state, _ = step(nav, straight(0.0), state, params, DT)
    # THEN it took 5 s to reach full speed (2.5 m + 5 m) and now moves at U
    assert r.speed_mps == pytest.approx(1.0)
    assert r.s_ref_m == pytest.approx(7.5, abs=0.06)


@pytest.mark.parametrize("mode", ["los", "ilos", "track"])
def test_cross_error_to_the_controller_is_limited_where_los_carries_it(mode: str) -> None:
    # GIVEN a vehicle 4 m to port of a northbound path (the path is to starboard: e_y > 0)
    params = GuidanceParams(mode=mode, lateral="path", lookahead_m=2.0, cross_error_limit_m=0.5)
    r, _, _ = step(nav_state_at(0.0, -4.0, 1.0, 0.0), straight(0.0), GuidanceState(), params, DT)
    # THEN the heading reference turns towards the path by the LOS angle, the eq. 9 error is limited
    assert r.e_cross_m == pytest.approx(0.5)
    assert r.yaw_rad == pytest.approx(
        math.atan(4.0 / 2.0), abs=0.05 if mode == "ilos" else 1e-6
    )  # + integral
    assert r.cross_track_m == pytest.approx(-4.0)  # the telemetry keeps the true cross-track


def test_paper_reference_lateral_is_not_limited() -> None:
    params = GuidanceParams(mode="track", lateral="reference", cross_error_limit_m=0.5)
    r, _, _ = step(nav_state_at(0.0, -4.0, 1.0, 0.0), straight(0.0), GuidanceState(), params, DT)
    assert r.e_cross_m == pytest.approx(4.0)


def test_the_track_reference_can_wait_at_the_goal() -> None:
    # GIVEN a vehicle that does not move and a reference that would pass the path's end after a minute
    path = s_then_right_arc()
    nav = nav_state_at(0.0, 0.0, 1.0, 0.0)
    runs_on = GuidanceParams(mode="track", speed_mps=1.2)
    waits = GuidanceParams(mode="track", speed_mps=1.2, reference_stops_at_end=True)
    s_on, s_wait = GuidanceState(), GuidanceState()
    for _ in range(1200):
        r_on, s_on, _ = step(nav, path, s_on, runs_on, DT)
        r_wait, s_wait, _ = step(nav, path, s_wait, waits, DT)
    # THEN the paper's reference runs on along the extension, the other waits at the goal
    assert r_on.s_ref_m == pytest.approx(72.0) and path.length_m < 72.0
    assert r_wait.s_ref_m == pytest.approx(path.length_m)
    end = path.sample(path.length_m)
    assert (r_wait.x_m, r_wait.y_m) == pytest.approx((end.x_m, end.y_m))
