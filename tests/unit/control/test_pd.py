"""Unit tests of the revised PD (eqs. 8-10): terms, signs, derivatives, dt = 0, NaN, closed loop."""

from __future__ import annotations

import dataclasses
import math

import pytest

from auv_common.config import ConfigError, from_table
from onboard.core.control import (
    ActuatorFlag,
    ControllerState,
    ControlParams,
    ImprovedGains,
    PaperGains,
    step,
)
from onboard.core.guidance import GuidanceParams, GuidanceReference, GuidanceState
from onboard.core.guidance import step as guidance_step
from onboard.core.nav import nav_state_at
from onboard.core.planner.path import ArcSegment, Path, StraightSegment
from tests.unit.control.toy_plant import ToyState, toy_nav, toy_step

PAPER = ControlParams(profile="paper")
IMPROVED = ControlParams(profile="improved")
# The improved profile with eq. 10 as written for depth (its default is the depth -> pitch cascade, which
# takes no pitch error: the tests of eq. 10's terms use this one).
IMPROVED_EQ10 = ControlParams(profile="improved", improved=ImprovedGains(depth_mode="paper"))
DT = 0.05


def ref(**errors: float) -> GuidanceReference:
    """A reference with the given errors and nothing else (speed 0, straight)."""
    base = dict(
        mode="track", s_ref_m=0.0, x_m=0.0, y_m=0.0, depth_m=0.0, yaw_rad=0.0, pitch_rad=0.0,
        x_rate_mps=0.0, y_rate_mps=0.0, depth_rate_mps=0.0, yaw_rate_radps=0.0, pitch_rate_radps=0.0,
        speed_mps=0.0, curvature_1pm=0.0, along_track_m=0.0, cross_track_m=0.0, distance_to_end_m=0.0,
        e_along_m=0.0, e_cross_m=0.0, e_depth_m=0.0, e_yaw_rad=0.0, e_pitch_rad=0.0,
        arrived=False,
    )  # fmt: skip
    base.update(errors)
    base.setdefault("water_speed_mps", base["speed_mps"])  # still water unless a test says otherwise
    return GuidanceReference(**base)  # type: ignore[arg-type]


NAV = nav_state_at()


@pytest.mark.parametrize("params", [PAPER, IMPROVED_EQ10], ids=["paper", "improved"])
@pytest.mark.parametrize(
    ("error", "value", "channel", "sign"),
    [
        ("e_along_m", 0.1, "propeller_rps", +1),  # reference ahead -> more thrust
        ("e_cross_m", 0.05, "rudder_rad", -1),  # path to starboard -> right turn = negative rudder
        ("e_cross_m", -0.05, "rudder_rad", +1),
        ("e_yaw_rad", 0.05, "rudder_rad", -1),  # must turn right -> negative rudder
        ("e_yaw_rad", -0.05, "rudder_rad", +1),
        ("e_depth_m", 0.05, "stern_rad", +1),  # must go deeper -> nose down = positive stern
        ("e_pitch_rad", 0.05, "stern_rad", -1),  # must pitch up -> negative stern
    ],
)
def test_each_channel_sign_stabilises(
    params: ControlParams, error: str, value: float, channel: str, sign: int
) -> None:
    # GIVEN a vehicle at rest and a single positive or negative error
    # WHEN the controller runs one (first) step, so only the P terms act
    cmd, _, _ = step(NAV, ref(**{error: value}), ControllerState(), params, DT)
    # THEN the channel moves the way that reduces the error
    assert math.copysign(1.0, getattr(cmd, channel)) == sign
    assert getattr(cmd, channel) != 0.0


@pytest.mark.parametrize("params", [PAPER, IMPROVED_EQ10], ids=["paper", "improved"])
def test_p_and_d_terms_match_eqs_8_to_10(params: ControlParams) -> None:
    # GIVEN two consecutive steps with known error changes and difference derivatives
    params = dataclasses.replace(
        params,
        paper=dataclasses.replace(params.paper, derivative="difference"),
        improved=dataclasses.replace(params.improved, derivative="difference", feedforward=False, Ki1=0.0),
    )
    g = params.gains
    e1 = dict(e_along_m=0.1, e_cross_m=0.2, e_depth_m=0.05, e_yaw_rad=0.01, e_pitch_rad=0.02)
    e2 = dict(e_along_m=0.2, e_cross_m=0.1, e_depth_m=0.07, e_yaw_rad=0.00, e_pitch_rad=0.01)
    _, state, _ = step(NAV, ref(**e1), ControllerState(), params, DT)
    # WHEN the second step runs
    _, _, dbg = step(NAV, ref(**e2), state, params, DT)
    # THEN every term is Kp*e + Kd*(delta e / dt)
    de = {k: (e2[k] - e1[k]) / DT for k in e1}
    expect = {
        "P1": g.Kp1 * e2["e_along_m"], "D1": g.KD1 * de["e_along_m"],
        "P2": g.Kp2 * e2["e_cross_m"], "D2": g.KD2 * de["e_cross_m"],
        "P3": g.Kp3 * e2["e_depth_m"], "D3": g.KD3 * de["e_depth_m"],
        "P4": g.Kp4 * e2["e_along_m"], "D4": g.KD4 * de["e_along_m"],
        "P5": g.Kp5 * e2["e_cross_m"], "D5": g.KD5 * de["e_cross_m"],
        "P6": g.Kp6 * e2["e_yaw_rad"], "D6": g.KD6 * de["e_yaw_rad"],
        "P7": g.Kp7 * e2["e_depth_m"], "D7": g.KD7 * de["e_depth_m"],
        "P8": g.Kp8 * e2["e_pitch_rad"], "D8": g.KD8 * de["e_pitch_rad"],
    }  # fmt: skip
    for name, value in expect.items():
        assert dbg.terms[name] == pytest.approx(value, abs=1e-12), name
    assert dbg.raw.propeller_rps == pytest.approx(sum(expect[f"{p}{i}"] for p in "PD" for i in (1, 2, 3)))
    assert dbg.raw.rudder_rad == pytest.approx(sum(expect[f"{p}{i}"] for p in "PD" for i in (4, 5, 6)))
    assert dbg.raw.stern_rad == pytest.approx(sum(expect[f"{p}{i}"] for p in "PD" for i in (7, 8)))


def test_paper_profile_gains_have_the_paper_magnitudes() -> None:
    # GIVEN the paper profile  THEN every nonzero gain is |Kp| = 2, |KD| = 4 (section 5)
    g = PaperGains()
    for i in range(1, 9):
        kp, kd = getattr(g, f"Kp{i}"), getattr(g, f"KD{i}")
        assert abs(kp) in (0.0, 2.0) and abs(kd) in (0.0, 4.0)
        assert (kp == 0.0) == (kd == 0.0)
    # and the propeller held at the reference speed (eq. 7's u_T), nothing else of the improved profile
    assert g.feedforward and g.rudder_per_curvature_radm == 0.0 and g.Ki1 == 0.0
    assert (g.roll_kp, g.roll_kd, g.schedule_speed_mps, g.depth_mode) == (0.0, 0.0, 0.0, "paper")


def test_yaw_difference_is_wrapped() -> None:
    # GIVEN a yaw error that crosses +-pi between two steps (a small real change)
    params = ControlParams(profile="paper")
    _, s, _ = step(NAV, ref(e_yaw_rad=math.pi - 0.01), ControllerState(), params, DT)
    # WHEN it becomes -pi + 0.01
    _, _, dbg = step(NAV, ref(e_yaw_rad=-math.pi + 0.01), s, params, DT)
    # THEN the derivative is +0.02/dt, not -2pi/dt
    assert dbg.derivatives[3] == pytest.approx(0.02 / DT)


def test_rates_derivative_uses_measured_rates() -> None:
    # GIVEN the improved profile (derivative = rates) and a vehicle yawing right at 0.1 rad/s
    nav = nav_state_at(r_radps=0.1, q_radps=-0.05)
    # WHEN the controller runs with no errors
    _, _, dbg = step(nav, ref(), ControllerState(), IMPROVED, DT)
    # THEN de_psi/dt = r_d - r and de_theta/dt = q_d - q
    assert dbg.derivatives[3] == pytest.approx(-0.1)
    assert dbg.derivatives[4] == pytest.approx(0.05)


@pytest.mark.parametrize("params", [PAPER, IMPROVED], ids=["paper", "improved"])
def test_dt_zero_is_safe_and_holds_the_command(params: ControlParams) -> None:
    # GIVEN a controller that has run once
    cmd1, s, _ = step(NAV, ref(e_cross_m=0.05), ControllerState(), params, DT)
    # WHEN a step comes with dt_s = 0 and a different error
    cmd2, s2, dbg = step(NAV, ref(e_cross_m=0.5), s, params, 0.0)
    # THEN nothing divides by zero and the (rate-limited) command is held
    assert all(math.isfinite(v) for v in dbg.derivatives)
    assert cmd2.rudder_rad == pytest.approx(cmd1.rudder_rad)
    assert s2.errors is not None


@pytest.mark.parametrize("params", [PAPER, IMPROVED_EQ10], ids=["paper", "improved"])
@pytest.mark.parametrize("field", ["e_along_m", "e_cross_m", "e_depth_m", "e_yaw_rad", "e_pitch_rad"])
def test_nan_in_gives_neutral_out(params: ControlParams, field: str) -> None:
    # GIVEN a running controller with a nonzero command
    cmd, s, _ = step(NAV, ref(e_along_m=1.0, e_cross_m=0.3), ControllerState(), params, DT)
    assert cmd.propeller_rps > 0.0
    # WHEN one error is NaN
    cmd, s, _ = step(NAV, ref(**{field: math.nan}), s, params, DT)
    # THEN the command is neutral, flagged, and the derivative memory is reset
    assert (cmd.rudder_rad, cmd.stern_port_rad, cmd.stern_starboard_rad, cmd.propeller_rps) == (0, 0, 0, 0)
    assert cmd.flags & ActuatorFlag.NAN_INPUT
    assert s.errors is None


def test_nan_in_measured_rate_gives_neutral_for_rates_profile() -> None:
    # GIVEN the improved profile which uses measured rates  WHEN r is NaN  THEN neutral
    cmd, _, _ = step(nav_state_at(r_radps=math.nan), ref(), ControllerState(), IMPROVED, DT)
    assert cmd.flags & ActuatorFlag.NAN_INPUT and cmd.propeller_rps == 0.0


def test_improved_feedforward_speed_map_and_curvature() -> None:
    # GIVEN zero errors, a desired speed of 1.6 m/s on a right arc of radius 5 m
    r = ref(speed_mps=1.6, curvature_1pm=0.2, yaw_rate_radps=1.6 * 0.2)
    # WHEN the improved controller runs
    _, _, dbg = step(NAV, r, ControllerState(), IMPROVED, DT)
    # THEN the propeller gets the speed map's 25 rps and the rudder the steady-turn (negative = right)
    assert dbg.rps_ff == pytest.approx(25.0)
    assert dbg.rudder_ff_rad == pytest.approx(-ImprovedGains().rudder_per_curvature_radm * 0.2)
    # and the paper profile holds the propeller at the reference speed (eq. 7's u_T), with no curvature rudder
    _, _, dbg_p = step(NAV, r, ControllerState(), PAPER, DT)
    assert dbg_p.rps_ff == pytest.approx(25.0) and dbg_p.raw.propeller_rps == pytest.approx(25.0)
    assert dbg_p.rudder_ff_rad == 0.0 and dbg_p.raw.rudder_rad == 0.0


def test_paper_profile_as_written_gives_zero_thrust_at_zero_error() -> None:
    # GIVEN the paper profile without the speed map (eqs. 8-10 as written)
    as_written = ControlParams(profile="paper", paper=PaperGains(feedforward=False))
    # WHEN the vehicle is on a reference moving at 1.6 m/s  THEN the propeller gets nothing
    _, _, dbg = step(NAV, ref(speed_mps=1.6), ControllerState(), as_written, DT)
    assert dbg.rps_ff == 0.0 and dbg.raw.propeller_rps == 0.0


def waiting(e_along_m: float, speed_mps: float, s_ref_m: float = 0.0) -> GuidanceReference:
    """A reference along +x at ``speed_mps``, standing at ``s_ref_m``, ``e_along_m`` ahead of the vehicle."""
    return ref(e_along_m=e_along_m, speed_mps=speed_mps, x_rate_mps=speed_mps, s_ref_m=s_ref_m)


def _hold_e_x(params: ControlParams, e_along_m: float, seconds: float, speed_mps: float = 1.0) -> list[float]:
    """The propeller commands of ``seconds`` of a steady along-track error (the reference waiting ahead)."""
    s, out = ControllerState(), []
    for _ in range(round(seconds / DT)):
        _, s, dbg = step(NAV, waiting(e_along_m, speed_mps), s, params, DT)
        out.append(dbg.raw.propeller_rps)
    return out


def test_speed_integral_grows_a_steady_along_track_error_into_thrust() -> None:
    # GIVEN the improved profile and a vehicle held 2 m behind a reference waiting at the goal
    g = IMPROVED.improved
    raw = _hold_e_x(IMPROVED, 2.0, 10.0)
    # THEN the command grows by Ki1 * e_x per second on top of the proportional part (no parking short)
    assert raw[-1] - raw[0] == pytest.approx(g.Ki1 * 2.0 * (len(raw) - 1) * DT, rel=1e-6)
    # and the paper profile (a PD) has no integral: the command stays
    flat = _hold_e_x(PAPER, 2.0, 10.0)
    assert flat[-1] == pytest.approx(flat[1])


def test_speed_integral_acts_only_while_the_reference_stands_still() -> None:
    # GIVEN the improved profile and a vehicle 2 m behind a reference that moves on (s_ref advancing)
    s = ControllerState()
    for k in range(200):
        _, s, dbg = step(NAV, waiting(2.0, 1.0, s_ref_m=k * DT), s, IMPROVED, DT)
    # THEN no integral: the moving reference and the feed-forward carry the speed
    assert s.speed_int_rps == 0.0 and dbg.rps_int == 0.0
    # WHEN the reference stops (waits at the goal)  THEN the integral acts from the next step on
    _, s, _ = step(NAV, waiting(2.0, 1.0, s_ref_m=10.0), s, IMPROVED, DT)
    _, s, _ = step(NAV, waiting(2.0, 1.0, s_ref_m=10.0), s, IMPROVED, DT)
    assert s.speed_int_rps == pytest.approx(IMPROVED.improved.Ki1 * 2.0 * DT)


def test_speed_integral_leaves_a_vehicle_closing_on_the_goal_alone() -> None:
    # GIVEN a reference waiting 2 m ahead and a vehicle closing on it at 1 m/s over ground (an arrival the
    # proportional loop makes)
    closing = nav_state_at(u_mps=1.0)
    s = ControllerState()
    for _ in range(40):
        _, s, _ = step(closing, waiting(2.0, 1.0), s, IMPROVED, DT)
    # THEN no integral; at rest (stalled short of it) the integral acts
    assert s.speed_int_rps == 0.0
    for _ in range(2):
        _, s, _ = step(NAV, waiting(2.0, 1.0), s, IMPROVED, DT)
    assert s.speed_int_rps > 0.0


def test_speed_integral_is_clamped() -> None:
    # GIVEN a small error held for long, below the propeller limit
    params = ControlParams(improved=ImprovedGains(Ki1=1.0, Ki1_max_rps=3.0))
    raw = _hold_e_x(params, 0.5, 30.0, speed_mps=0.5)
    # THEN the integral holds at most Ki1_max_rps (the command settles 3 rps above P + feed-forward)
    p_ff = params.speed_to_rps(0.5) + params.improved.Kp1 * 0.5
    assert raw[-1] == pytest.approx(p_ff + 3.0)


def test_speed_integral_does_not_wind_up_while_the_propeller_is_saturated() -> None:
    # GIVEN a large error that saturates the propeller (30 rps) from the start, for a long time
    s = ControllerState()
    for _ in range(round(20.0 / DT)):
        _, s, _ = step(NAV, waiting(10.0, 1.5), s, IMPROVED, DT)
    # THEN the integral did not grow (conditional integration)
    assert s.speed_int_rps == 0.0
    # and with an integral held, saturated high, a negative error unwinds it (the command comes back inside)
    held = ControllerState(speed_int_rps=5.0, s_ref_m=0.0)
    _, s1, _ = step(NAV, waiting(10.0, 1.5), held, IMPROVED, DT)
    _, s2, _ = step(NAV, waiting(-0.5, 2.0), held, IMPROVED, DT)
    assert s1.speed_int_rps == 5.0
    assert s2.speed_int_rps == pytest.approx(5.0 - IMPROVED.improved.Ki1 * 0.5 * DT)


def test_speed_integral_starts_afresh_with_the_memory() -> None:
    # GIVEN a wound integral  WHEN the controller state is replaced (new path, HOLD: the pipeline's reset)
    s = ControllerState()
    for _ in range(40):
        _, s, _ = step(NAV, waiting(2.0, 1.0), s, IMPROVED, DT)
    assert s.speed_int_rps > 0.0
    # THEN the fresh state holds no integral
    assert ControllerState(command=s.command).speed_int_rps == 0.0


@pytest.mark.parametrize(("speed", "rps"), [(0.0, 0.0), (0.8, 12.5), (1.6, 25.0), (-1.0, 0.0), (3.2, 50.0)])
def test_speed_map_interpolates(speed: float, rps: float) -> None:
    assert ControlParams().speed_to_rps(speed) == pytest.approx(rps)


def test_roll_damping_sign() -> None:
    # GIVEN a vehicle rolled starboard down (+roll)
    nav = nav_state_at(roll_rad=0.1)
    # WHEN the improved controller runs
    cmd, _, _ = step(nav, ref(), ControllerState(), IMPROVED, 1.0)
    # THEN the differential is positive (starboard plane > port plane): a roll moment to port
    assert cmd.stern_starboard_rad > cmd.stern_port_rad
    assert cmd.roll_diff_rad == pytest.approx(ImprovedGains().roll_kp * 0.1)


@pytest.mark.parametrize(
    "table",
    [{"profile": "other"}, {"paper": {"Kp9": 1.0}}, {"speed_map_mps": [0.0]},
     {"limits": {"rudder_limit_deg": -1.0}}, {"improved": {"derivative": "magic"}}],
)  # fmt: skip
def test_bad_control_config_is_a_config_error(table: dict[str, object]) -> None:
    with pytest.raises(ConfigError):
        from_table(ControlParams, table, "onboard.toml [control]")


def test_partial_profile_table_keeps_that_profiles_defaults() -> None:
    p = from_table(ControlParams, {"profile": "paper", "paper": {"Kp1": 3.0}}, "[control]")
    assert p.gains.Kp1 == 3.0 and p.gains.Kp5 == -2.0 and p.improved == ImprovedGains()


def _straight_path(yaw_rad: float, length_m: float = 200.0) -> Path:
    return Path(segments=(StraightSegment(0.0, 0.0, yaw_rad, length_m),), start_depth_m=1.0, end_depth_m=1.0)


@pytest.mark.parametrize("profile", ["paper", "improved"])
@pytest.mark.parametrize("yaw_deg", [0.0, 90.0, 180.0, -90.0])
def test_closed_loop_converges_on_toy_plant_at_any_heading(profile: str, yaw_deg: float) -> None:
    # GIVEN a straight path at some heading and a toy vehicle starting 2 m to port of it, 0.5 m shallow,
    # 10 deg off heading, at rest
    yaw = math.radians(yaw_deg)
    path = _straight_path(yaw)
    port = (math.cos(yaw - math.pi / 2), math.sin(yaw - math.pi / 2))
    s = ToyState(2.0 * port[0], 2.0 * port[1], 0.5, yaw + math.radians(10.0))
    params = ControlParams(profile=profile)  # type: ignore[arg-type]
    gp = GuidanceParams(mode="track", speed_mps=1.0)
    gs, cs = GuidanceState(), ControllerState()
    # WHEN the loop runs guidance, PD and the toy plant for 60 s
    for k in range(int(60.0 / DT)):
        nav = toy_nav(s, k * DT)
        r, gs, _ = guidance_step(nav, path, gs, gp, DT)
        cmd, cs, _ = step(nav, r, cs, params, DT)
        s = toy_step(s, cmd, DT)
    # THEN the vehicle is on the path and at depth, with the same gains at every heading
    assert abs(r.cross_track_m) < 0.1
    assert abs(r.e_depth_m) < 0.1
    assert abs(r.e_yaw_rad) < math.radians(3.0)
    if profile == "improved":  # the feed-forward removes the paper's steady along-track lag
        assert abs(r.e_along_m) < 0.5


def test_closed_loop_on_an_arc_with_feedforward() -> None:
    # GIVEN a path with a 90 deg right arc of radius 5 m and the improved controller
    path = Path(
        segments=(
            StraightSegment(0.0, 0.0, 0.0, 10.0),
            ArcSegment(10.0, 5.0, 5.0, +1, 0.0, math.pi / 2),
            StraightSegment(15.0, 5.0, math.pi / 2, 20.0),
        ),
        start_depth_m=1.0,
        end_depth_m=1.0,
    )
    s = ToyState(0.0, 0.0, 1.0, 0.0, u_mps=1.0)
    gp = GuidanceParams(mode="track", speed_mps=1.0)
    gs, cs = GuidanceState(), ControllerState()
    worst = 0.0
    # WHEN it flies the path
    for k in range(int(35.0 / DT)):
        nav = toy_nav(s, k * DT)
        r, gs, _ = guidance_step(nav, path, gs, gp, DT)
        cmd, cs, _ = step(nav, r, cs, IMPROVED, DT)
        s = toy_step(s, cmd, DT)
        worst = max(worst, abs(r.cross_track_m))
    # THEN the cross-track error stays small through the turn
    assert worst < 0.3


CASCADE = ControlParams(
    profile="improved",
    improved=ImprovedGains(depth_mode="cascade", Kz_pitch=0.2, KDz_pitch=0.2, Kiz_pitch=0.02, Kp8=-1.5),
)


def _stern(cmd) -> float:  # type: ignore[no-untyped-def]
    return (cmd.stern_port_rad + cmd.stern_starboard_rad) / 2.0


def test_depth_cascade_limits_the_pitch_it_asks_for() -> None:
    lim = math.radians(CASCADE.improved.pitch_limit_deg)
    # GIVEN a vehicle 20 m too shallow: the pitch command is limited to -20 deg (nose down)
    at_limit, _, dbg = step(nav_state_at(pitch_rad=-lim), ref(e_depth_m=20.0), ControllerState(), CASCADE, DT)
    # THEN once the vehicle pitches at the limit the stern asks for no more nose-down
    assert _stern(at_limit) == pytest.approx(0.0, abs=1e-9)
    assert dbg.terms["P7"] == pytest.approx(-0.2 * 20.0)  # the unlimited pitch demand is reported
    # and short of the limit it pitches down (positive stern), beyond it back up (negative stern)
    short, _, _ = step(nav_state_at(pitch_rad=-0.1), ref(e_depth_m=20.0), ControllerState(), CASCADE, DT)
    deep = nav_state_at(pitch_rad=-lim - 0.1)
    beyond, _, _ = step(deep, ref(e_depth_m=20.0), ControllerState(), CASCADE, DT)
    assert _stern(short) > 0.0 > _stern(beyond)


def test_depth_cascade_integral_does_not_wind_up_while_limited() -> None:
    state = ControllerState()
    for _ in range(200):  # 10 s with the pitch command limited (20 m too shallow)
        _, state, _ = step(NAV, ref(e_depth_m=20.0), state, CASCADE, DT)
    assert state.depth_int_rad == 0.0
    # a small error inside the limit is integrated, up to its clamp
    for _ in range(2000):
        _, state, _ = step(NAV, ref(e_depth_m=0.5), state, CASCADE, DT)
    assert state.depth_int_rad == pytest.approx(math.radians(CASCADE.improved.depth_int_max_deg))
    # and an error of the other sign unwinds it
    _, after, _ = step(NAV, ref(e_depth_m=-0.5), state, CASCADE, DT)
    assert after.depth_int_rad < state.depth_int_rad


def test_depth_mode_paper_is_eq_10() -> None:
    _, _, dbg = step(NAV, ref(e_depth_m=0.1, e_pitch_rad=0.05), ControllerState(), IMPROVED_EQ10, DT)
    g = IMPROVED_EQ10.improved
    assert dbg.terms["P7"] == pytest.approx(g.Kp7 * 0.1) and dbg.terms["P8"] == pytest.approx(g.Kp8 * 0.05)


def test_depth_cascade_nan_depth_error_gives_neutral_out() -> None:
    cmd, state, _ = step(NAV, ref(e_depth_m=math.nan), ControllerState(), IMPROVED, DT)
    assert cmd.flags & ActuatorFlag.NAN_INPUT and _stern(cmd) == 0.0 and state.depth_int_rad == 0.0
