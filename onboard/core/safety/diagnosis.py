"""Fault diagnosis: pure detectors that name a sensor or actuator fault, and the vehicle's reaction to each.

The failsafes (:mod:`onboard.core.safety.failsafe`) judge the navigation solution against hard limits; the
detectors here judge whether the sensors and actuators still agree with each other, and name what does
not (issue 24 item 5). One step per tick, :func:`step`, fed by the tick's inputs: the navigation solution
and its filter (ages, the fixes it took), the actuator node's feedback (FIN_STATUS, PROP_STATUS, copied at
the bus edge, :func:`onboard.core.bus_inputs.actuator_feedback`) and the command sent the tick before.

Each kind, its detector and the reaction (thresholds in ``[diagnosis]``, :class:`DiagnosisParams`; the
table with the measured detection times is in ``docs/control.md``):

- ``dvl_dropout``: no DVL velocity for ``overdue_factor`` x its usual interval (at least
  ``dvl_overdue_s``). Continue: dead reckoning on the held velocity, the position's sigma growing (the 95 %
  arrival and ``[nav] max_position_std_m`` bound it).
- ``fix_outage``: no position fix for ``overdue_factor`` x its usual interval (at least ``fix_overdue_s``;
  before three gaps were seen, ``overdue_factor`` x ``[nav] fix_timeout_s``).
  Continue: the sigma grows; a goal that cannot be confirmed HOLDs, its reason naming the outage.
- ``compass_bias``: over the accepted fixes of the last ``compass_window_s``, the direction of the fixes'
  displacement against the dead-reckoned one (DVL x heading, no fixes): their angle is the heading's error
  (a current does not enter: the DVL measures over ground), judged only where the fixes' noise leaves it
  better than ``compass_max_sigma_deg`` (frequent, accurate fixes). Beyond ``compass_bias_deg`` for
  ``compass_bias_s``. HOLD: dead reckoning steers by the heading, and a position filter that refuses the
  fixes it drifts from would claim a goal it has not reached (faults.yaml: COMPLETE 1.3-2.0 m off the goal
  while continuing); the operator decides (recalibrate, RESUME, ABORT).
- ``depth_stuck``: the depth sensor against the depth the vertical motion predicts (the DVL velocity
  rotated by the attitude: w and pitch x speed; a complementary filter pulled to the sensor over
  ``depth_time_constant_s``), its innovation beyond ``depth_innovation_m`` for ``depth_stuck_s``. ABORT
  (surface): the depth and its limit can no longer be watched.
- ``fin_stuck``: a fin's FIN_STATUS angle more than ``fin_error_deg`` from its command for ``fin_stuck_s``,
  while it does not move towards the command (at least :data:`FIN_SLEW_MIN_DPS`, measured over
  :data:`FIN_RATE_BASE_S`): a slow fin chasing its command is no stuck one (campaign margins.yaml, actuators
  x 4 and x 6: the rudder at +8.7 deg slewing to +20 deg was named stuck and the turn HELD).
  A rudder: HOLD (it would circle; depth control is intact; the operator decides); a stern plane: ABORT
  (depth control lost: surface).
- ``thrust_loss``: PROP_STATUS's rps over the rps the speed map gives for the steady speed the motion
  shows (the speed through the water u and its rate, both low-passed over ``thrust_filter_s``: U =
  sqrt(u^2 + ``surge_length_m`` du/dt), quadratic drag; not in a turn, whose drag the map does not know:
  yaw rate within ``thrust_max_yaw_rate_degps``), beyond ``thrust_rps_ratio`` for ``thrust_loss_s``.
  Continue: the speed loop turns the propeller faster; the leg monitors judge the progress.

A condition must hold its persistence time to be named and be absent ``clear_s`` to clear (each once, a
note). Every named fault is kept for the mission (since its START) with the mission time it was named at
(:attr:`DiagnosisState.named`): the end of a mission (COMPLETE, HOLD, ABORT) carries them in its reason
(:func:`onboard.core.commander.apply`), so a campaign's ``final_reason`` does.

Pure: no clock, no bus; ``now_s`` is the loop's time base.
"""

from __future__ import annotations

import enum
import math
import statistics
from dataclasses import dataclass, field, replace

from auv_common.config import check_declared, param
from onboard.core.control.actuators import ActuatorCommand
from onboard.core.nav.current import CURRENT_BELIEVED_STD_MPS
from onboard.core.nav.estimator import NavDebug, NavFilterState
from onboard.core.nav.types import NavState, PositionFix
from onboard.protocol.conventions import wrap_pi


class FaultFlag(enum.IntFlag):
    """The faults the vehicle names (bit flags; 0 = none). The names are the bench's fault kinds
    (``hil_sim/model/faults.py``), lower case."""

    DVL_DROPOUT = enum.auto()
    FIX_OUTAGE = enum.auto()
    COMPASS_BIAS = enum.auto()
    DEPTH_STUCK = enum.auto()
    FIN_STUCK = enum.auto()
    THRUST_LOSS = enum.auto()


def kind_of(flag: FaultFlag) -> str:
    """The fault's name as the operator reads it: ``dvl_dropout``, ..."""
    return (flag.name or "").lower()


class Reaction(enum.Enum):
    """What the vehicle does about a fault it names."""

    CONTINUE = "continue"  # say it and go on (the sigma grows; the monitors and the 95 % arrival judge)
    HOLD = "hold"  # stop and wait for the operator (RESUME or ABORT)
    ABORT = "abort"  # surface


#: The reaction to each kind (a stuck fin: :func:`fin_reaction`).
REACTIONS: dict[FaultFlag, Reaction] = {
    FaultFlag.DVL_DROPOUT: Reaction.CONTINUE,
    FaultFlag.FIX_OUTAGE: Reaction.CONTINUE,
    FaultFlag.COMPASS_BIAS: Reaction.HOLD,
    FaultFlag.DEPTH_STUCK: Reaction.ABORT,
    FaultFlag.FIN_STUCK: Reaction.ABORT,
    FaultFlag.THRUST_LOSS: Reaction.CONTINUE,
}
#: What each reaction does, said to the operator.
_SAID = {
    Reaction.CONTINUE: "continuing",
    Reaction.HOLD: "HOLD",
    Reaction.ABORT: "ABORT (surface)",
}
FINS = ("rudder", "stern_port", "stern_starboard")
#: The actuator node's feedback older than this (s) is not judged: a silent node (a stalled bench, a lost bus)
#: is the bus watchdogs' to name, not a stuck fin's or a lost thrust's.
FEEDBACK_MAX_AGE_S = 0.5
#: A fin moving towards its command at least this fast (deg/s) is slewing, not stuck; its rate is measured
#: over FIN_STATUS samples at least FIN_RATE_BASE_S (s) apart (a stuck fin: 0 deg/s).
FIN_SLEW_MIN_DPS = 1.0
FIN_RATE_BASE_S = 0.2
#: A sensor's interval is the median of its last GAPS_KEPT gaps, known once GAPS_KNOWN were seen.
GAPS_KEPT = 5
GAPS_KNOWN = 3


def fin_reaction(fin: str) -> Reaction:
    """A stuck rudder HOLDs (the vehicle would circle; depth control is intact and the operator decides); a
    stuck stern plane ABORTs (depth control is lost: surface)."""
    return Reaction.HOLD if fin == "rudder" else Reaction.ABORT


@dataclass(frozen=True)
class DiagnosisParams:
    """The ``[diagnosis]`` table: the detectors' thresholds and times (module docstring's table)."""

    overdue_factor: float = param(
        3.0, min=1.5, max=20.0,
        desc="a DVL sample or a fix is overdue after this many of its usual intervals",
    )  # fmt: skip
    dvl_overdue_s: float = param(
        2.0, unit="s", min=0.1, max=60.0, desc="no DVL velocity for at least this long is a dvl_dropout"
    )
    fix_overdue_s: float = param(
        2.0, unit="s", min=0.1, max=600.0, desc="no position fix for at least this long is a fix_outage"
    )
    compass_bias_deg: float = param(
        4.0, unit="deg", min=0.5, max=90.0,
        desc="the heading's error measured by the fixes beyond this is a compass_bias",
    )  # fmt: skip
    compass_bias_s: float = param(
        3.0,
        unit="s",
        min=0.0,
        max=60.0,
        desc="the heading's error beyond compass_bias_deg this long is named",
    )
    compass_window_s: float = param(
        4.0, unit="s", min=0.5, max=60.0, desc="the fixes' window the heading's error is measured over"
    )
    compass_min_travel_m: float = param(
        2.0,
        unit="m",
        min=0.1,
        max=100.0,
        desc="the least dead-reckoned travel over the window that is judged",
    )
    compass_max_sigma_deg: float = param(
        1.0, unit="deg", min=0.01, max=30.0,
        desc="judged only where the fixes' noise leaves the measured heading error this good (1-sigma)",
    )  # fmt: skip
    depth_innovation_m: float = param(
        0.3, unit="m", min=0.05, max=10.0,
        desc="the depth sensor this far from the depth the vertical motion predicts is a depth_stuck",
    )  # fmt: skip
    depth_time_constant_s: float = param(
        5.0, unit="s", min=0.5, max=120.0, desc="the depth predictor's pull towards the sensor"
    )
    depth_stuck_s: float = param(
        1.0,
        unit="s",
        min=0.0,
        max=60.0,
        desc="the depth innovation beyond depth_innovation_m this long is named",
    )
    depth_min_m: float = param(
        0.3, unit="m", min=0.0, max=10.0, desc="the depth detector judges only deeper than this (the surface)"
    )
    fin_error_deg: float = param(
        4.0, unit="deg", min=0.5, max=45.0,
        desc="a fin's FIN_STATUS angle this far from its command is a fin_stuck",
    )  # fmt: skip
    fin_stuck_s: float = param(
        2.0,
        unit="s",
        min=0.1,
        max=60.0,
        desc="a fin beyond fin_error_deg from its command this long is named",
    )
    thrust_rps_ratio: float = param(
        1.25, min=1.05, max=5.0,
        desc="PROP_STATUS rps over the speed map's rps for the steady speed the motion shows, beyond this: "
        "a thrust_loss",
    )  # fmt: skip
    thrust_loss_s: float = param(
        3.0, unit="s", min=0.0, max=120.0, desc="the rps ratio beyond thrust_rps_ratio this long is named"
    )
    thrust_filter_s: float = param(
        2.0, unit="s", min=0.1, max=60.0, desc="the low-pass of the rps and the speed the ratio is taken of"
    )
    surge_length_m: float = param(
        20.0, unit="m", min=1.0, max=1000.0,
        desc="the vehicle's surge: du/dt = (U^2 - u^2) / this, U the speed map's speed for the rps "
        "(mass over drag; the simulated vehicle's, measured accelerating from rest)",
    )  # fmt: skip
    thrust_max_yaw_rate_degps: float = param(
        3.0, unit="deg/s", min=0.1, max=90.0, desc="the thrust detector judges only turning slower than this"
    )
    thrust_min_speed_mps: float = param(
        0.5, unit="m/s", min=0.0, max=5.0, desc="the thrust detector judges only faster than this"
    )
    clear_s: float = param(
        3.0, unit="s", min=0.0, max=120.0, desc="a named fault clears when its condition is absent this long"
    )

    def __post_init__(self) -> None:
        check_declared(self)


@dataclass(frozen=True)
class ActuatorFeedback:
    """What the actuator node reports: FIN_STATUS's angles (rad, None: never received) and PROP_STATUS's
    propeller speed (rev/s, None: never received), with their sample times (s, the loop's time base)."""

    fins_rad: tuple[float, float, float] | None = None
    fins_t_s: float = -math.inf
    propeller_rps: float | None = None
    propeller_t_s: float = -math.inf


@dataclass(frozen=True)
class Named:
    """A fault named during the mission: its flag, what was measured, the reaction, and when (s after the
    mission's START); ``cleared_s`` when it cleared (None: still on)."""

    flag: FaultFlag
    text: str
    reaction: Reaction
    t_s: float
    cleared_s: float | None = None

    @property
    def kind(self) -> str:
        return kind_of(self.flag)


@dataclass(frozen=True)
class _Arrivals:
    """A sensor's usual interval between samples: the median of its last :data:`GAPS_KEPT` gaps (an outage's
    one long gap, or a burst's short one, does not move it)."""

    last_t_s: float = -math.inf
    gaps_s: tuple[float, ...] = ()

    @property
    def interval_s(self) -> float:
        """The usual interval (s); 0 while fewer than :data:`GAPS_KNOWN` gaps were seen."""
        if len(self.gaps_s) < GAPS_KNOWN:
            return 0.0
        return statistics.median(self.gaps_s)

    def seen(self, t_s: float) -> _Arrivals:
        if not math.isfinite(t_s) or t_s <= self.last_t_s:
            return self
        if not math.isfinite(self.last_t_s):
            return _Arrivals(t_s, ())
        return _Arrivals(t_s, (*self.gaps_s, t_s - self.last_t_s)[-GAPS_KEPT:])

    def overdue(self, now_s: float, factor: float, min_s: float, unknown_s: float) -> float | None:
        """The silence (s) when it is overdue, else None: after ``factor`` usual intervals, at least
        ``min_s``; while the interval is not known, after ``factor`` x ``unknown_s`` (the configured
        timeout); never before a first sample."""
        if not math.isfinite(self.last_t_s):
            return None
        interval = self.interval_s if self.interval_s > 0.0 else unknown_s
        silent = now_s - self.last_t_s
        return silent if silent > max(min_s, factor * interval) else None


@dataclass(frozen=True)
class DiagnosisState:
    """The detectors' memory between ticks."""

    flags: FaultFlag = FaultFlag(0)  # noqa: RUF009 (an immutable IntFlag value)
    #: per kind (its flag's value): when its condition began holding (set pending) or stopped (clear pending)
    since_s: tuple[tuple[int, float], ...] = ()
    dvl: _Arrivals = field(default_factory=_Arrivals)
    fix: _Arrivals = field(default_factory=_Arrivals)
    # compass: the dead-reckoned position (DVL x heading, no fixes) and the accepted fixes' window
    dr_xy: tuple[float, float] | None = None
    window: tuple[tuple[float, float, float, float, float], ...] = ()  # (t, fix x, fix y, dr x, dr y)
    # depth: the predicted depth
    depth_pred_m: float | None = None
    # thrust: the low-passed rps and speed through the water
    rps_lp: float | None = None
    speed_lp_mps: float | None = None
    thrust_since_s: float | None = None  # the propeller ahead, the DVL fresh, since (s)
    # fins: a FIN_STATUS sample (t, angles) as the base of their rates, and their last rates (rad/s)
    fins_base: tuple[float, tuple[float, float, float]] | None = None
    fins_rate_radps: tuple[float, float, float] = (0.0, 0.0, 0.0)
    #: the mission's faults, in the order named; the mission's START (s, the loop's time base)
    named: tuple[Named, ...] = ()
    mission_start_s: float = 0.0

    def named_text(self) -> str:
        """The mission's faults for a reason: ``dvl_dropout at 12.1 s (cleared 31.0 s); ...`` ("" if none)."""
        parts = []
        for n in self.named:
            cleared = f", cleared {n.cleared_s:.1f} s" if n.cleared_s is not None else ""
            parts.append(f"{n.kind} at {n.t_s:.1f} s{cleared}")
        return "; ".join(parts)


@dataclass(frozen=True)
class Measured:
    """This tick's figures (telemetry; NaN when not judged): the fin with the largest tracking error (deg),
    the heading error the fixes measure (deg), the depth innovation (m), the thrust ratio."""

    fin_error_deg: float = math.nan
    heading_error_deg: float = math.nan
    depth_innovation_m: float = math.nan
    thrust_ratio: float = math.nan


@dataclass(frozen=True)
class Finding:
    """A fault named this tick: the flag, one line naming it and what was measured, and the reaction."""

    flag: FaultFlag
    text: str
    reaction: Reaction


@dataclass(frozen=True)
class DiagnosisResult:
    """``flags``: the faults on now; ``found``: those named this tick (each a note, its reaction);
    ``cleared``: one line per fault that cleared this tick; ``measured``: the tick's figures."""

    flags: FaultFlag
    found: tuple[Finding, ...] = ()
    cleared: tuple[str, ...] = ()
    measured: Measured = field(default_factory=Measured)


@dataclass(frozen=True)
class DiagnosisInputs:
    """One tick's inputs: the navigation solution, its filter and debug, the latest position fix (the one
    the filter took this tick when ``nav_debug.fix_accepted``), the actuator node's feedback, the command
    sent the tick before (what the actuators follow now), the speed map (``(speeds m/s, rps)``), the
    configured fix sigma (m), whether the actuators follow commands (the fins are judged only then), and
    ``[nav]``'s fix and DVL timeouts (s: a sensor overdue while its interval is not known yet)."""

    nav: NavState
    filter: NavFilterState
    nav_debug: NavDebug | None
    fix: PositionFix | None
    feedback: ActuatorFeedback
    command: ActuatorCommand
    speed_to_rps: tuple[tuple[float, ...], tuple[float, ...]]
    fix_sigma_m: float
    actuators_follow: bool
    fix_timeout_s: float = 5.0
    dvl_timeout_s: float = 1.0


def start_mission(state: DiagnosisState, now_s: float) -> DiagnosisState:
    """A START: the mission's faults start afresh (the faults on stay on, named again at once)."""
    return replace(state, named=(), mission_start_s=now_s, flags=FaultFlag(0), since_s=())


def _usually(arrivals: _Arrivals) -> str:
    return f" (usually every {arrivals.interval_s:.2f} s)" if arrivals.interval_s > 0.0 else ""


def _interp(x: float, xs: tuple[float, ...], ys: tuple[float, ...]) -> float:
    """The speed map: ys at x, linear, extrapolated along the last row (as the feed-forward)."""
    if x <= xs[0]:
        return ys[0]
    for i in range(len(xs) - 1):
        if x <= xs[i + 1]:
            f = (x - xs[i]) / (xs[i + 1] - xs[i])
            return ys[i] + f * (ys[i + 1] - ys[i])
    slope = (ys[-1] - ys[-2]) / (xs[-1] - xs[-2])
    return ys[-1] + slope * (x - xs[-1])


def _lowpass(prev: float | None, value: float, dt_s: float, tau_s: float) -> float:
    if prev is None or not math.isfinite(prev):
        return value
    a = min(1.0, dt_s / tau_s) if tau_s > 0.0 else 1.0
    return prev + a * (value - prev)


def step(
    inputs: DiagnosisInputs, state: DiagnosisState, params: DiagnosisParams, now_s: float, dt_s: float
) -> tuple[DiagnosisResult, DiagnosisState]:
    """One tick of every detector at ``now_s`` (s) of period ``dt_s`` (s)."""
    nav, filt = inputs.nav, inputs.filter
    conditions: dict[FaultFlag, str] = {}
    reactions: dict[FaultFlag, Reaction] = {}

    # 1. Dropped sensors: staleness against the sensor's own usual interval.
    dvl = state.dvl.seen(filt.dvl.t_sample_s if filt.dvl is not None else -math.inf)
    dvl_silent = dvl.overdue(now_s, params.overdue_factor, params.dvl_overdue_s, inputs.dvl_timeout_s)
    if dvl_silent is not None:
        conditions[FaultFlag.DVL_DROPOUT] = (
            f"no DVL velocity for {dvl_silent:.1f} s{_usually(dvl)}: dead "
            "reckoning on the last, the position's sigma growing"
        )
    fix = state.fix.seen(filt.last_fix_t_s)
    fix_silent = fix.overdue(now_s, params.overdue_factor, params.fix_overdue_s, inputs.fix_timeout_s)
    if fix_silent is not None:
        conditions[FaultFlag.FIX_OUTAGE] = (
            f"no position fix for {fix_silent:.1f} s{_usually(fix)}: dead reckoning, "
            f"the position's 1-sigma {nav.position_std_max_m:.2f} m and growing"
        )
    # the DVL's velocity is this tick's (not a held one): dead reckoning may be judged
    dvl_fresh = dvl.interval_s > 0.0 and nav.velocity_age_s <= max(2.0 * dvl.interval_s, 0.2)

    # 2. Compass bias: the fixes' displacement against the dead-reckoned one, over a window.
    heading_error = math.nan
    dr_xy, window = state.dr_xy, state.window
    vn, ve, vd = nav.velocity_ned_mps if nav.attitude_valid else (math.nan, math.nan, math.nan)
    if not (dvl_fresh and math.isfinite(vn) and math.isfinite(ve)):
        dr_xy, window = None, ()  # no dead reckoning to judge the heading by: start again
    else:
        dr_xy = (0.0, 0.0) if dr_xy is None else (dr_xy[0] + vn * dt_s, dr_xy[1] + ve * dt_s)
        dbg, fx = inputs.nav_debug, inputs.fix
        if dbg is not None and dbg.fix_accepted and fx is not None:  # a fix the filter took this tick
            window = (*window, (now_s, fx.x_m, fx.y_m, dr_xy[0], dr_xy[1]))
        window = tuple(w for w in window if now_s - w[0] <= params.compass_window_s)
        if len(window) >= 2 and window[-1][0] - window[0][0] >= 0.5 * params.compass_window_s:
            (_, fx0, fy0, dx0, dy0), (_, fx1, fy1, dx1, dy1) = window[0], window[-1]
            travel = math.hypot(dx1 - dx0, dy1 - dy0)
            fix_sigma_m = max(inputs.fix_sigma_m, inputs.fix.std_m if inputs.fix is not None else 0.0, 1e-3)
            sigma_rad = math.sqrt(2.0) * fix_sigma_m / travel if travel > 0 else math.inf
            if travel >= params.compass_min_travel_m and sigma_rad <= math.radians(
                params.compass_max_sigma_deg
            ):
                ang_dr = math.atan2(dy1 - dy0, dx1 - dx0)
                ang_fix = math.atan2(fy1 - fy0, fx1 - fx0)
                heading_error = math.degrees(wrap_pi(ang_dr - ang_fix))
                if abs(heading_error) > params.compass_bias_deg:
                    conditions[FaultFlag.COMPASS_BIAS] = (
                        f"the heading reads {heading_error:+.1f} deg off the fixes' track over {travel:.1f} m"
                    )

    # 3. Depth stuck: the sensor against the depth the vertical motion predicts.
    innovation = math.nan
    pred = state.depth_pred_m
    z = nav.depth_m
    if (
        not (dvl_fresh and nav.depth_valid and math.isfinite(vd) and math.isfinite(z))
        or z < params.depth_min_m
    ):
        pred = None
    else:
        pred = z if pred is None else pred + vd * dt_s
        innovation = z - pred
        pred += (z - pred) * min(1.0, dt_s / params.depth_time_constant_s)
        if abs(innovation) > params.depth_innovation_m:
            conditions[FaultFlag.DEPTH_STUCK] = (
                f"the depth sensor reads {z:.2f} m, {abs(innovation):.2f} m "
                f"{'above' if innovation < 0 else 'below'} what the vertical motion predicts"
            )

    # 4. Stuck fin: FIN_STATUS against the command the actuators follow.
    fin_error = math.nan
    fb = inputs.feedback
    fins_fresh = now_s - fb.fins_t_s <= FEEDBACK_MAX_AGE_S
    fins_base, fins_rate = state.fins_base, state.fins_rate_radps
    if fb.fins_rad is not None and fins_fresh:
        if fins_base is None or fb.fins_t_s < fins_base[0]:
            fins_base = (fb.fins_t_s, fb.fins_rad)
        elif fb.fins_t_s - fins_base[0] >= FIN_RATE_BASE_S:
            span_s = fb.fins_t_s - fins_base[0]
            fins_rate = (
                (fb.fins_rad[0] - fins_base[1][0]) / span_s,
                (fb.fins_rad[1] - fins_base[1][1]) / span_s,
                (fb.fins_rad[2] - fins_base[1][2]) / span_s,
            )
            fins_base = (fb.fins_t_s, fb.fins_rad)
    else:
        fins_base, fins_rate = None, (0.0, 0.0, 0.0)
    if inputs.actuators_follow and fb.fins_rad is not None and fins_fresh:
        cmd = inputs.command
        commanded = (cmd.rudder_rad, cmd.stern_port_rad, cmd.stern_starboard_rad)
        errors = [math.degrees(a - c) for a, c in zip(fb.fins_rad, commanded, strict=True)]
        worst = max(range(3), key=lambda i: abs(errors[i]))
        fin_error = errors[worst]
        # towards the command (deg/s): the fin's rate along the sign of what is left to go
        towards_dps = -math.degrees(fins_rate[worst]) * math.copysign(1.0, fin_error)
        if abs(fin_error) > params.fin_error_deg and towards_dps < FIN_SLEW_MIN_DPS:
            fin = FINS[worst]
            reaction = fin_reaction(fin)
            conditions[FaultFlag.FIN_STUCK] = (
                f"the {fin.replace('_', ' ')} is at {math.degrees(fb.fins_rad[worst]):+.1f} deg, commanded "
                f"{math.degrees(commanded[worst]):+.1f} deg"
            )
            reactions[FaultFlag.FIN_STUCK] = reaction

    # 5. Thrust loss: the propeller's rps against the speed map's for the speed through the water.
    ratio = math.nan
    rps_lp, speed_lp = state.rps_lp, state.speed_lp_mps
    speed = nav.water_speed_mps if nav.current_std_mps < CURRENT_BELIEVED_STD_MPS else nav.speed_mps
    prop = fb.propeller_rps
    thrust_since = state.thrust_since_s
    prop_fresh = now_s - fb.propeller_t_s <= FEEDBACK_MAX_AGE_S
    if prop is not None and prop > 0.0 and prop_fresh and dvl_fresh and math.isfinite(speed) and dt_s > 0.0:
        # judged once the propeller has turned ahead, with the DVL, for two filter times (the run-in's
        # braking reverses it: the low-pass starts again after)
        thrust_since = now_s if thrust_since is None else thrust_since
        settled = now_s - thrust_since >= 2.0 * params.thrust_filter_s
        rps_lp = _lowpass(rps_lp, prop, dt_s, params.thrust_filter_s)
        before = speed_lp
        speed_lp = _lowpass(speed_lp, speed, dt_s, params.thrust_filter_s)
        straight = abs(nav.r_radps) <= math.radians(params.thrust_max_yaw_rate_degps)
        if before is not None and settled and speed_lp >= params.thrust_min_speed_mps and straight:
            # the steady speed this thrust would give: du/dt = (U^2 - u^2) / surge_length_m, so
            # U = sqrt(u^2 + L du/dt) (the low-passed speed's rate is the low-passed acceleration)
            accel = (speed_lp - before) / dt_s
            steady = math.sqrt(max(0.0, speed_lp * speed_lp + params.surge_length_m * accel))
            expected = _interp(steady, *inputs.speed_to_rps)
            # the propeller drives the vehicle (not the run-in's coast and brake, where the map says little):
            # both the steady speed and the rps at least the map's at thrust_min_speed_mps
            floor_rps = _interp(params.thrust_min_speed_mps, *inputs.speed_to_rps)
            if steady >= params.thrust_min_speed_mps and rps_lp >= floor_rps and expected > 0.0:
                ratio = rps_lp / expected
                if ratio > params.thrust_rps_ratio:
                    conditions[FaultFlag.THRUST_LOSS] = (
                        f"the propeller turns {rps_lp:.1f} rps for {speed_lp:.2f} m/s (steady {steady:.2f} "
                        f"m/s), {ratio:.2f} x what the speed map says: thrust lost"
                    )
    else:
        rps_lp = speed_lp = thrust_since = None

    # 6. Persistence: named after its time, cleared after clear_s.
    persist = {
        FaultFlag.DVL_DROPOUT: 0.0,
        FaultFlag.FIX_OUTAGE: 0.0,
        FaultFlag.COMPASS_BIAS: params.compass_bias_s,
        FaultFlag.DEPTH_STUCK: params.depth_stuck_s,
        FaultFlag.FIN_STUCK: params.fin_stuck_s,
        FaultFlag.THRUST_LOSS: params.thrust_loss_s,
    }
    # a detector that could not judge this tick (too slow, no fixes good enough, not under way, turning)
    # leaves its fault as it was, and what was pending starts again: no evidence either way
    judged = {
        FaultFlag.DVL_DROPOUT: True,
        FaultFlag.FIX_OUTAGE: True,
        FaultFlag.COMPASS_BIAS: math.isfinite(heading_error),
        FaultFlag.DEPTH_STUCK: math.isfinite(innovation),
        FaultFlag.FIN_STUCK: math.isfinite(fin_error),
        FaultFlag.THRUST_LOSS: math.isfinite(ratio),
    }
    since = dict(state.since_s)
    flags = state.flags
    found: list[Finding] = []
    cleared: list[str] = []
    named = list(state.named)
    t_mission = now_s - state.mission_start_s
    for flag, hold_s in persist.items():
        on = bool(flags & flag)
        if not judged[flag]:
            since.pop(flag.value, None)  # a condition must hold over judged ticks without a break
            continue
        if (flag in conditions) == on:
            since.pop(flag.value, None)  # as it is: nothing pending
            continue
        began = since.setdefault(flag.value, now_s)
        wait = (
            hold_s
            if not on
            else (0.0 if flag in (FaultFlag.DVL_DROPOUT, FaultFlag.FIX_OUTAGE) else params.clear_s)
        )
        if now_s - began < wait:
            continue
        since.pop(flag.value, None)
        if not on:
            flags |= flag
            reaction = reactions.get(flag, REACTIONS[flag])
            text = f"fault {kind_of(flag)}: {conditions[flag]}: {_SAID[reaction]}"
            found.append(Finding(flag, text, reaction))
            named.append(Named(flag, text, reaction, t_mission))
        else:
            flags &= ~flag
            cleared.append(f"fault {kind_of(flag)} cleared")
            for k in range(len(named) - 1, -1, -1):
                if named[k].flag is flag and named[k].cleared_s is None:
                    named[k] = replace(named[k], cleared_s=t_mission)
                    break

    new_state = DiagnosisState(
        flags=flags,
        since_s=tuple(sorted(since.items())),
        dvl=dvl,
        fix=fix,
        dr_xy=dr_xy,
        window=window,
        depth_pred_m=pred,
        rps_lp=rps_lp,
        speed_lp_mps=speed_lp,
        thrust_since_s=thrust_since,
        fins_base=fins_base,
        fins_rate_radps=fins_rate,
        named=tuple(named),
        mission_start_s=state.mission_start_s,
    )
    measured = Measured(fin_error, heading_error, innovation, ratio)
    return DiagnosisResult(flags, tuple(found), tuple(cleared), measured), new_state


__all__ = [
    "REACTIONS",
    "ActuatorFeedback",
    "DiagnosisInputs",
    "DiagnosisParams",
    "DiagnosisResult",
    "DiagnosisState",
    "FaultFlag",
    "Finding",
    "Measured",
    "Named",
    "Reaction",
    "fin_reaction",
    "kind_of",
    "start_mission",
    "step",
]
