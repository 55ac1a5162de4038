"""The revised PD controller of the paper (section 4.2, eqs. 8-10), in two profiles.

    rps = (Kp1 e_x + KD1 de_x/dt) + (Kp2 e_y + KD2 de_y/dt) + (Kp3 e_z + KD3 de_z/dt)                  (8)
    dR  = (Kp4 e_x + KD4 de_x/dt) + (Kp5 e_y + KD5 de_y/dt) + (Kp6 e_psi + KD6 de_psi/dt)              (9)
    dS  = (Kp7 e_z + KD7 de_z/dt) + (Kp8 e_theta + KD8 de_theta/dt)                                   (10)

with e = x_d - x_a (eq. 4). e_x, e_y are the along-track and cross-track errors resolved in the path frame
at the reference point (:mod:`onboard.core.guidance`), so the gains hold at any heading; for a path
along +x they
are the paper's e_x, e_y exactly. e_z = depth_d - depth_a (+ = must go deeper), e_psi = wrap(psi_d - psi_a)
(+ = must turn right), e_theta = theta_d - theta_a (+ = must pitch nose up).

Units (the paper gives none; this is our reading): errors in m and rad, their rates in m/s and rad/s; outputs
propeller speed in rev/s and fin angles in rad. So Kp1 is rps/m, KD1 rps/(m/s), Kp5 rad/m, Kp6 rad/rad,
KD6 rad/(rad/s), Kp7 rad/m, Kp8 rad/rad, and so on.

Signs, with +rudder = turn to port and +stern = nose down (``onboard/protocol/conventions.py``):

- rps from e_x: reference ahead (e_x > 0) needs more thrust: Kp1, KD1 > 0.
- rudder from e_y: path to starboard (e_y > 0) needs a right turn = negative rudder: Kp5, KD5 < 0.
- rudder from e_psi: e_psi > 0 needs a right turn = negative rudder: Kp6, KD6 < 0.
- stern from e_z: must go deeper (e_z > 0) needs nose down = positive stern: Kp7, KD7 > 0.
- stern from e_theta: must pitch up (e_theta > 0) needs nose up = negative stern: Kp8, KD8 < 0.
- rps from e_z: the vehicle is positively buoyant, so going deeper needs more speed (plane authority):
  Kp3, KD3 >= 0.
- rps from e_y (Kp2, KD2) and rudder from e_x (Kp4, KD4): the error's sign does not say which way to act
  (being left of the path needs no more or less thrust; lagging the reference needs no turn either way), so
  no sign stabilises them and both profiles set them to 0. The slots stay in the config.

Derivatives (``derivative`` key): ``difference`` = (e_k - e_{k-1}) / dt_s (yaw difference wrapped) with an
optional first-order low-pass ``derivative_tau_s``; ``rates`` = the same for e_x, e_y, but
de_psi/dt = r_d - r, de_theta/dt = q_d - q and de_z/dt = depth_rate_d - depth_rate from the measured rates
(no differentiation noise). The first step and dt_s = 0 give derivative 0 (first step) or hold the last one.

The propeller's operating point (eq. 7, our reading): eq. 7, the surge row of the dynamics, balances the
vehicle's drag at its state with the thrust a_x + b_x u_T + c_x u_T^2 + d_x u_T^3 of the "forward movement
ratio u_T (its mean forward velocity)". Eq. 8 as written gives zero thrust at zero error, so a vehicle on
the reference would slow down and could never hold it (``auv-hil scenario paper-turn`` circled, closest
14.9 m; the straight ended 0.30 m off). We read eq. 7 as the propeller held at the speed of the reference,
u_T = U_d, with eqs. 8-10 correcting around it: rps = speed_map(U_d) + eq. 8 (``feedforward``, on in both
profiles; the speed map is ``[control]``'s ``speed_map_mps`` / ``speed_map_rps``, the vehicle's steady speed
through the water, linear interpolation). With it the paper's straight ends 0.09 m off and its turn 0.21 m
(paper 0.13 / 0.2 m).

Profile ``improved`` adds: the yaw-rate feed-forward on arcs dR_ff = -rudder_per_curvature_radm * r_d / U_d
(= -K * curvature: the steady-turn rudder), roll damping with the split stern: roll differential =
roll_kp * phi + roll_kd * p (a positive differential rolls to port, see
:mod:`onboard.core.control.actuators`), and integral action in eq. 8 while the reference stands still
(waits at the goal): + Ki1 * integral(e_x dt), clamped to +-``Ki1_max_rps`` and frozen while the propeller
is saturated in the error's direction (anti-windup). The
speed map's feed-forward is only as good as the current estimate, and along a constant heading the estimate
cannot tell a head current from a slow vehicle: in a 1.5 m/s head current (top speed ~1.85 m/s) the
proportional eq. 8 parked the vehicle 4.0 m short of the goal at 24.4 rps once the reference waited there;
the integral supplies the missing thrust. The memory (``ControllerState``) starts afresh on every new path
and every state that stops the PD (:mod:`onboard.core.pipeline`), so nothing winds up across legs.

Pure: ``step(nav, reference, state, params, dt_s) -> (command, new_state, debug)``. Saturation and rate limits
happen in :func:`onboard.core.control.actuators.saturate` only. Any NaN -> neutral command with ``NAN_INPUT``.
"""

from __future__ import annotations

import bisect
import itertools
import math
from dataclasses import dataclass, field
from typing import Any, Literal

from auv_common.config import check_declared, param, require
from onboard.core.control.actuators import ActuatorCommand, ActuatorFlag, ActuatorLimits, saturate
from onboard.core.guidance.guidance import GuidanceReference
from onboard.core.nav.types import NavState
from onboard.protocol.conventions import stern_split, wrap_pi

DerivativeSource = Literal["difference", "rates"]
DepthMode = Literal["paper", "cascade"]
ProfileName = Literal["paper", "improved"]


def _gain(mavlink: str, unit: str, desc: str) -> Any:
    """A PD gain of eqs. 8-10: default 0; a PARAM_SET beyond +-100 is refused (a configured gain beyond
    widens the range)."""
    return param(0.0, unit=unit, operator=(-100.0, 100.0), mavlink=mavlink, desc=desc)


@dataclass(frozen=True)
class PdGains:
    """The 16 gains of eqs. 8-10 (named as in the paper) and the extras of the ``improved`` profile.

    Each operator parameter is declared once below (unit, range, description, MAVLink name;
    ``docs/parameters.md``). Feed-forward: ``feedforward`` turns on the propeller speed map (``[control]``'s,
    :class:`ControlParams`) and the curvature rudder ``rudder_per_curvature_radm``.
    """

    Kp1: float = _gain("PD_KP1", "rps/m", "PD rps P gain on e_x")
    KD1: float = _gain("PD_KD1", "rps.s/m", "PD rps D gain on e_x")
    Kp2: float = _gain("PD_KP2", "rps/m", "PD rps P gain on e_y")
    KD2: float = _gain("PD_KD2", "rps.s/m", "PD rps D gain on e_y")
    Kp3: float = _gain("PD_KP3", "rps/m", "PD rps P gain on e_z")
    KD3: float = _gain("PD_KD3", "rps.s/m", "PD rps D gain on e_z")
    Kp4: float = _gain("PD_KP4", "rad/m", "PD rudder P gain on e_x")
    KD4: float = _gain("PD_KD4", "rad.s/m", "PD rudder D gain on e_x")
    Kp5: float = _gain("PD_KP5", "rad/m", "PD rudder P gain on e_y")
    KD5: float = _gain("PD_KD5", "rad.s/m", "PD rudder D gain on e_y")
    Kp6: float = _gain("PD_KP6", "rad/rad", "PD rudder P gain on e_psi")
    KD6: float = _gain("PD_KD6", "rad.s/rad", "PD rudder D gain on e_psi")
    Kp7: float = _gain("PD_KP7", "rad/m", "PD stern P gain on e_z")
    KD7: float = _gain("PD_KD7", "rad.s/m", "PD stern D gain on e_z")
    Kp8: float = _gain("PD_KP8", "rad/rad", "PD stern P gain on e_theta")
    KD8: float = _gain("PD_KD8", "rad.s/rad", "PD stern D gain on e_theta")
    feedforward: bool = False
    # Integral action on eq. 8's along-track error (the speed loop), with anti-windup: the term is clamped to
    # +-Ki1_max_rps and integrates only while the propeller command is within its limits or the error unwinds
    # it; the pipeline resets it (with the rest of the memory) on every new path and every state change. The
    # clamp is the propeller's range: the feed-forward may be short by most of it (an estimate reading no
    # current in 1.5 m/s: 16 rps given, 24 needed, more on a slow run-in).
    Ki1: float = param(
        0.0, unit="rps/(m.s)", min=0.0, operator=(0.0, 10.0), mavlink="PD_KI1",
        desc="PD rps integral gain on e_x (0 = off)",
    )  # fmt: skip
    Ki1_max_rps: float = param(
        30.0, unit="rps", min=0.0, operator=(0.0, 100.0), mavlink="PD_KI1_MAX",
        desc="the most propeller speed the e_x integral may hold",
    )  # fmt: skip
    Ki1_closing_mps: float = param(
        0.3, unit="m/s", min=0.0, operator=(0.0, 2.0), mavlink="PD_KI1_CLOSE",
        desc="the e_x integral acts while the vehicle closes on a waiting reference slower than this",
    )  # fmt: skip
    rudder_per_curvature_radm: float = param(
        0.0, unit="rad.m", min=0.0, operator=(0.0, 10.0), mavlink="PD_RUD_FF_RADM",
        desc="rudder feed-forward per path curvature",
    )  # fmt: skip
    roll_kp: float = param(
        0.0, unit="rad/rad", operator=(-10.0, 10.0), mavlink="PD_ROLL_KP",
        desc="roll damping P gain (split stern)",
    )  # fmt: skip
    roll_kd: float = param(
        0.0, unit="rad.s/rad", operator=(-10.0, 10.0), mavlink="PD_ROLL_KD",
        desc="roll damping D gain (split stern)",
    )  # fmt: skip
    derivative: DerivativeSource = "difference"
    derivative_tau_s: float = param(
        0.0, unit="s", min=0.0, operator=(0.0, 10.0), mavlink="PD_DTAU_S",
        desc="derivative low-pass time constant",
    )  # fmt: skip
    # The depth channel: "paper" = eq. 10 as written; "cascade" = depth -> pitch command (limited to
    # +-pitch_limit_deg, with an integral that stops while the command is limited: anti-windup) -> stern
    # through Kp8 / KD8 on the pitch-command error and the pitch rate. Kp7 / KD7 are unused in "cascade".
    depth_mode: DepthMode = "paper"
    pitch_limit_deg: float = 20.0
    Kz_pitch: float = 0.0  # rad of pitch per m of depth error (+ error: nose down)
    KDz_pitch: float = 0.0  # rad per m/s of depth-rate error
    Kiz_pitch: float = 0.0  # rad per m*s of integrated depth error (trims the buoyancy out)
    depth_int_max_deg: float = 6.0  # the most pitch the integral may hold, deg
    # Fin-gain schedule: a fin's force grows with the square of the speed through the water, so the fin
    # feedback (eqs. 9 and 10, not the feed-forward) is scaled by (schedule_speed_mps / u_w)^2, u_w the
    # estimated speed through the water, at most schedule_max_scale (and at least 1 / it). 0 = off.
    schedule_speed_mps: float = 0.0
    schedule_max_scale: float = 2.5

    def __post_init__(self) -> None:
        check_declared(self)


@dataclass(frozen=True)
class PaperGains(PdGains):
    """``[control.paper]``: the paper's structure and gains |Kp| = 2, |KD| = 4 (section 5), each sign the one
    that stabilises its channel (module docstring), derivatives by differences, and the propeller held at the
    reference speed u_T (the speed map; our reading of eq. 7, module docstring): eqs. 8-10 correct around it.
    No curvature rudder, no integral, no roll damping, no fin schedule."""

    feedforward: bool = True
    Kp1: float = 2.0
    KD1: float = 4.0
    Kp3: float = 2.0
    KD3: float = 4.0
    Kp5: float = -2.0
    KD5: float = -4.0
    Kp6: float = -2.0
    KD6: float = -4.0
    Kp7: float = 2.0
    KD7: float = 4.0
    Kp8: float = -2.0
    KD8: float = -4.0


@dataclass(frozen=True)
class ImprovedGains(PdGains):
    """``[control.improved]``: our gains (tuned on the unit tests' toy models; retune on the simulator) with
    feed-forward, measured-rate derivatives and roll damping."""

    Kp1: float = 2.0
    KD1: float = 1.0
    Kp5: float = -0.3
    KD5: float = -0.3
    Kp6: float = -1.0
    KD6: float = -0.5
    Kp7: float = 0.5
    KD7: float = 0.5
    Kp8: float = -1.0
    KD8: float = -0.5
    feedforward: bool = True
    Ki1: float = 0.2
    # PLACEHOLDER: steady-turn rudder per curvature, rad*m (e.g. 2/3 of the rudder limit * r_min).
    rudder_per_curvature_radm: float = 1.0
    roll_kp: float = 0.3
    roll_kd: float = 0.1
    derivative: DerivativeSource = "rates"
    derivative_tau_s: float = 0.0
    # Depth through a limited pitch command (campaign hil_sim/campaigns/depth.yaml, 1 -> 5 m and 1 -> 10 m:
    # max pitch 15-17 deg within the 20 deg limit, depth error at the goal <= 0.05 m; eq. 10 pitched 29-35 deg
    # with the stern saturated 16-23 % of the run). Swept over Kz 0.2-0.5 with KDz = Kz, Kiz = Kz / 10.
    depth_mode: DepthMode = "cascade"
    Kz_pitch: float = 0.5
    KDz_pitch: float = 0.5
    Kiz_pitch: float = 0.05


@dataclass(frozen=True)
class ControlParams:
    """The ``[control]`` table: ``profile`` selects ``[control.paper]`` or ``[control.improved]`` (each
    sub-table starts from its own defaults, so a partial table changes only what it names);
    ``[control.limits]`` holds the actuator limits (:class:`ActuatorLimits`)."""

    profile: ProfileName = "improved"
    paper: PaperGains = field(default_factory=PaperGains)
    improved: ImprovedGains = field(default_factory=ImprovedGains)
    limits: ActuatorLimits = field(default_factory=ActuatorLimits)
    # The vehicle's speed map (steady speed through the water against propeller speed), for the propeller
    # feed-forward of either profile (``feedforward``). PLACEHOLDER (linear, ~1.6 m/s at 25 rps): the
    # packaged onboard.toml holds the simulator's table.
    speed_map_mps: tuple[float, ...] = (0.0, 1.6)
    speed_map_rps: tuple[float, ...] = (0.0, 25.0)

    def __post_init__(self) -> None:
        m, r = self.speed_map_mps, self.speed_map_rps
        require(len(m) >= 2 and len(m) == len(r), "speed map needs >= 2 rows of equal length")
        require(all(b > a for a, b in itertools.pairwise(m)), "speed_map_mps must be strictly increasing")
        require(all(x >= 0.0 for x in r), "speed_map_rps must be >= 0")

    def speed_to_rps(self, speed_mps: float) -> float:
        """Propeller feed-forward: linear interpolation of the speed map, clamped at its ends (rev/s)."""
        m, r = self.speed_map_mps, self.speed_map_rps
        if speed_mps <= m[0]:
            return r[0]
        if speed_mps >= m[-1]:
            # Extrapolate along the last row's slope: the map's end is not a speed limit (saturate is).
            slope = (r[-1] - r[-2]) / (m[-1] - m[-2])
            return r[-1] + slope * (speed_mps - m[-1])
        i = bisect.bisect_right(m, speed_mps) - 1
        f = (speed_mps - m[i]) / (m[i + 1] - m[i])
        return r[i] + f * (r[i + 1] - r[i])

    @property
    def gains(self) -> PdGains:
        """The gains of the selected profile."""
        return self.paper if self.profile == "paper" else self.improved


@dataclass(frozen=True)
class ControllerState:
    """The controller's memory: previous errors, filtered derivatives and the previous (sent) command."""

    errors: tuple[float, float, float, float, float] | None = None  # e_x, e_y, e_z, e_psi, e_theta
    derivatives: tuple[float, float, float, float, float] = (0.0, 0.0, 0.0, 0.0, 0.0)
    depth_int_rad: float = 0.0  # the depth cascade's integral, as pitch (rad)
    speed_int_rps: float = 0.0  # eq. 8's integral of e_x, as propeller speed (rev/s)
    s_ref_m: float | None = None  # the reference point's arc length at the last step (is it waiting?)
    command: ActuatorCommand = field(default_factory=lambda: ActuatorCommand(0.0, 0.0, 0.0, 0.0))


@dataclass(frozen=True)
class ControlDebug:
    """Per-step terms for telemetry: errors, their derivatives, each P and D term, feed-forwards, raw command.

    ``terms`` maps "P1".."P8" and "D1".."D8" to the term values (rps or rad), in the paper's numbering.
    """

    errors: tuple[float, float, float, float, float]
    derivatives: tuple[float, float, float, float, float]
    terms: dict[str, float]
    rps_ff: float
    rps_int: float
    rudder_ff_rad: float
    roll_diff_rad: float
    raw: ActuatorCommand


def _fin_scale(g: PdGains, water_speed_mps: float) -> float:
    """The fin-feedback scale (schedule_speed / u_w)^2 within [1 / max, max] (1 for a non-finite u_w)."""
    if not math.isfinite(water_speed_mps):
        return 1.0
    hi = g.schedule_max_scale
    scale = (g.schedule_speed_mps / max(water_speed_mps, 1e-3)) ** 2
    return min(max(scale, 1.0 / hi), hi)


def _depth_cascade(
    g: PdGains, reference: GuidanceReference, nav: NavState, ez: float, dz: float, integ: float, dt_s: float
) -> tuple[float, float, float, float, float]:
    """Depth -> pitch command -> stern: (P7, D7, P8, D8, new integral). P7 / D7 report the pitch command's
    depth terms (rad of pitch); P8 / D8 are the stern terms (rad of stern)."""
    lim = math.radians(g.pitch_limit_deg)
    p7, d7 = -g.Kz_pitch * ez, -g.KDz_pitch * dz
    unlimited = reference.pitch_rad + p7 + d7 - integ
    theta_cmd = min(max(unlimited, -lim), lim)
    if math.isfinite(ez) and dt_s > 0.0 and (theta_cmd == unlimited or (unlimited > lim) == (ez > 0.0)):
        # anti-windup: integrate while the command is within its limit, or when the error unwinds it
        imax = math.radians(g.depth_int_max_deg)
        integ = min(max(integ + g.Kiz_pitch * ez * dt_s, -imax), imax)
    return p7, d7, g.Kp8 * (theta_cmd - nav.pitch_rad), -g.KD8 * nav.q_radps, integ


def _stalled(g: PdGains, nav: NavState, reference: GuidanceReference, state: ControllerState) -> bool:
    """True when a proportional eq. 8 would leave the vehicle short for ever: the reference stands still (its
    arc length unchanged since the last step: it waits at the goal) and the vehicle closes on it, over ground
    along the path, slower than ``Ki1_closing_mps``. A vehicle closing faster needs no help (the packaged
    runs arrive at 1.2-1.3 m/s): the integral leaves every arrival the proportional loop makes unchanged."""
    if state.s_ref_m is None or reference.s_ref_m != state.s_ref_m:
        return False
    ux, uy = reference.x_rate_mps, reference.y_rate_mps
    norm = math.hypot(ux, uy)
    vn, ve, _ = nav.velocity_ned_mps
    if not (norm > 1e-6 and math.isfinite(vn) and math.isfinite(ve)):
        return False
    along_mps = (vn * ux + ve * uy) / norm
    closing_mps = along_mps if reference.e_along_m >= 0.0 else -along_mps
    return closing_mps < g.Ki1_closing_mps


def _speed_integral(
    g: PdGains, limits: ActuatorLimits, ex: float, rps: float, integ: float, dt_s: float
) -> float:
    """Eq. 8's integral term after ``dt_s`` of a reference standing still: + Ki1 e_x dt_s, within
    +-Ki1_max_rps, and only while the propeller command ``rps`` (with the term) is within its limits or
    ``e_x`` drives it back inside (conditional integration: a saturated propeller does not wind it up).

    Why: once the reference waits at the goal, a proportional eq. 8 against a head current settles where
    Kp1 e_x makes up the thrust the feed-forward lacks, metres short of the goal for ever; the integral
    removes that offset. The caller integrates only while the reference stands still: while it moves, its
    motion and the feed-forward carry the speed, and an integral of the start's lag only sped the vehicle
    into the goal (paper campaign, always integrating: final error median 0.018 -> 0.072 m)."""
    if not (math.isfinite(ex) and math.isfinite(rps) and math.isfinite(dt_s) and dt_s > 0.0):
        return integ
    high = rps >= limits.propeller_max_rps and ex > 0.0
    low = rps <= limits.propeller_min_rps and ex < 0.0
    if high or low:
        return integ
    return min(max(integ + g.Ki1 * ex * dt_s, -g.Ki1_max_rps), g.Ki1_max_rps)


def step(
    nav: NavState,
    reference: GuidanceReference,
    state: ControllerState,
    params: ControlParams,
    dt_s: float,
) -> tuple[ActuatorCommand, ControllerState, ControlDebug]:
    """One controller step of ``dt_s`` s: eqs. 8-10 (+ the profile's extras), then :func:`saturate`.

    Returns the limited command (flags set), the new state and the debug terms. Any NaN in the errors or
    in the measurements the profile uses gives the neutral command with ``NAN_INPUT`` and resets the
    derivative memory (so recovery does not start with a derivative kick).
    """
    g = params.gains
    dt_ok = math.isfinite(dt_s) and dt_s > 0.0
    e = (
        reference.e_along_m,
        reference.e_cross_m,
        reference.e_depth_m,
        reference.e_yaw_rad,
        reference.e_pitch_rad,
    )

    # Derivatives: differences over dt_s (optionally low-passed), or measured rates where cleaner.
    rates = g.derivative == "rates"
    prev = state.errors
    d = list(state.derivatives)
    if prev is None:
        d = [0.0] * 5
    elif dt_ok:
        alpha = dt_s / (g.derivative_tau_s + dt_s)
        for i in range(2 if rates else 5):  # with measured rates, e_z, e_psi, e_theta are not differenced
            diff = wrap_pi(e[i] - prev[i]) if i == 3 else e[i] - prev[i]
            d[i] += alpha * (diff / dt_s - d[i])
    if rates:
        d[2] = reference.depth_rate_mps - nav.velocity_ned_mps[2]
        d[3] = reference.yaw_rate_radps - nav.r_radps
        d[4] = reference.pitch_rate_radps - nav.q_radps

    ex, ey, ez, epsi, eth = e
    dx, dy, dz, dpsi, dth = derivatives = (d[0], d[1], d[2], d[3], d[4])
    p1, d1, p2, d2 = g.Kp1 * ex, g.KD1 * dx, g.Kp2 * ey, g.KD2 * dy
    p3, d3, p4, d4 = g.Kp3 * ez, g.KD3 * dz, g.Kp4 * ex, g.KD4 * dx
    p5, d5, p6, d6 = g.Kp5 * ey, g.KD5 * dy, g.Kp6 * epsi, g.KD6 * dpsi
    depth_int = state.depth_int_rad
    if g.depth_mode == "cascade":
        dt_int = dt_s if dt_ok else 0.0
        p7, d7, p8, d8, depth_int = _depth_cascade(g, reference, nav, ez, dz, depth_int, dt_int)
    else:
        p7, d7, p8, d8 = g.Kp7 * ez, g.KD7 * dz, g.Kp8 * eth, g.KD8 * dth
    # Summed left to right from 0.0, as sum() did, so the result is the same to the bit (-0.0 included).
    rps = 0.0 + p1 + d1 + p2 + d2 + p3 + d3  # eq. 8
    rudder = 0.0 + p4 + d4 + p5 + d5 + p6 + d6  # eq. 9
    if g.depth_mode == "cascade":  # P7 / D7 are pitch (rad), already inside P8 through the pitch command
        stern = 0.0 + p8 + d8
    else:
        stern = 0.0 + p7 + d7 + p8 + d8  # eq. 10
    if g.schedule_speed_mps > 0.0:  # the fin feedback, both planes alike
        scale = _fin_scale(g, nav.water_speed_mps)
        rudder *= scale
        stern *= scale

    rps_ff = rudder_ff = 0.0
    if g.feedforward:
        # Through the water: the speed it takes (over ground in a current, the guidance's water speed) and
        # the curvature relative to the water the yaw rate is (a turn flown slower through the water needs
        # more rudder for the same rate).
        speed = reference.water_speed_mps
        rps_ff = params.speed_to_rps(speed)
        kappa = reference.yaw_rate_radps / speed if speed > 1e-6 else reference.curvature_1pm
        rudder_ff = -g.rudder_per_curvature_radm * kappa  # right turn (kappa > 0) = negative rudder
    speed_int = state.speed_int_rps
    if g.Ki1 > 0.0 and _stalled(g, nav, reference, state):
        speed_int = _speed_integral(g, params.limits, ex, rps + rps_ff + speed_int, speed_int, dt_s)
    roll_diff = g.roll_kp * nav.roll_rad + g.roll_kd * nav.p_radps if (g.roll_kp or g.roll_kd) else 0.0

    port, stbd = stern_split(stern, roll_diff)
    raw = ActuatorCommand(rudder + rudder_ff, port, stbd, rps + rps_ff + speed_int)
    command = saturate(raw, state.command, params.limits, dt_s)
    if command.flags & ActuatorFlag.NAN_INPUT:
        new_state = ControllerState(errors=None, command=command)
    else:
        new_state = ControllerState(
            errors=e,
            derivatives=derivatives,
            depth_int_rad=depth_int,
            speed_int_rps=speed_int,
            s_ref_m=reference.s_ref_m,
            command=command,
        )
    terms = {
        "P1": p1, "D1": d1, "P2": p2, "D2": d2, "P3": p3, "D3": d3, "P4": p4, "D4": d4,
        "P5": p5, "D5": d5, "P6": p6, "D6": d6, "P7": p7, "D7": d7, "P8": p8, "D8": d8,
    }  # fmt: skip
    debug = ControlDebug(
        errors=e,
        derivatives=derivatives,
        terms=terms,
        rps_ff=rps_ff,
        rps_int=speed_int,
        rudder_ff_rad=rudder_ff,
        roll_diff_rad=roll_diff,
        raw=raw,
    )
    return command, new_state, debug
