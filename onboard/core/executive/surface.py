"""Surface: the ``surface`` end action (and a loiter's fallback), and the stop it shares with HOLD.

The end stops (issue 23, item 3). Before, ``surface`` was propeller 0 and fins neutral at once: the vehicle
arrived at 1.24-1.30 m/s and glided 15.7-19.9 m on in 20-30 s, into an obstacle 2-3 m past the goal, and a
goal at 19.5 m sank on to the 20 m depth limit. Now:

- the run-in to the last goal slows to ``[mission] arrival_speed_mps`` (guidance's speed reference,
  :func:`onboard.core.guidance.guidance.step`), and where the vehicle is faster than that reference the
  propeller reverses (:func:`run_in_rps`): drag alone halves this hull's speed only every ~16 m;
- after COMPLETE (surface) and in HOLD, :class:`Stop` brakes: the propeller in reverse, at most ``[mission]
  brake_rps`` (PROP_CMD carries +-40 rps; the bench's propeller goes to -10 rps), tapering off with the speed
  over ground ahead, the rudder centred (hard over above :data:`HARD_OVER_MPS`: a HOLD at cruise) and the
  stern planes level, nose up where the vehicle is below the
  depth the stop began at (its last goal's), so it never sinks below it, and stops within ``[mission]
  stop_distance_m`` (the zone the validator keeps clear past every goal). Once the speed over ground ahead
  is below :data:`STOPPED_MPS` (or after :data:`BRAKE_MAX_S`: a following current the reverse propeller
  cannot stem), the propeller is 0 and the fins neutral; positive buoyancy brings the vehicle up.

While the stop brakes in COMPLETE the actuators are live (the vehicle commands them: armed, actuator mode
ARMED); once it has stopped they are not (``Autopilot.actuators_live``). ABORT does not brake: the bus
contract's ABORT mode is propeller off at the actuator node; its stern planes are nose up already.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from onboard.core.config import CoreConfig
from onboard.core.control.actuators import ActuatorCommand, ActuatorLimits, saturate
from onboard.core.executive.maneuver import Leg, Plans, Progress, Vehicle
from onboard.core.guidance.guidance import GuidanceReference, GuidanceState
from onboard.core.nav.current import CURRENT_NOISE_MPS
from onboard.core.nav.types import NavState
from onboard.core.planner.path import Path, StraightSegment

#: Below this speed over ground ahead (m/s) the vehicle has stopped: the DVL's noise is centimetres a second.
STOPPED_MPS = 0.02
#: The reverse propeller tapers off below this speed over ground ahead (m/s; thrust goes with rps^2, so
#: rps with the square root of the speed: the thrust with the speed), so it does not drive the vehicle
#: astern once it has stopped (the propeller lags ~0.4 s). Drag alone is no brake at a few cm/s: the
#: bench's vehicle creeps on at 0.05 m/s for minutes with the propeller off.
BRAKE_TAPER_MPS = 0.1
#: The longest a stop brakes (s): from 0.5 m/s the bench's vehicle stops in about 20 s (the reverse
#: propeller is weak: -10 rps); longer means a following current the propeller cannot stem, and braking on
#: would only cost battery.
BRAKE_MAX_S = 40.0
#: The stop's stern planes: pitch (rad) towards level, nose up by ``DEPTH_GAIN`` rad a metre below the depth
#: the stop began at (at most :data:`NOSE_UP_MAX_RAD`), each radian of pitch error one radian of stern.
#: Not hard nose up: a positively buoyant hull pitched nose up is driven forward along its axis by its
#: buoyancy (the bench: 0.46 m/s kept for 5 s against -10 rps at 15 deg nose up).
DEPTH_GAIN_RAD_PER_M = 0.3
NOSE_UP_MAX_RAD = math.radians(10.0)
PITCH_GAIN = 1.0
#: Faster than this over ground ahead (m/s: a HOLD at cruise, not the end after the run-in's 0.25-0.35) the
#: stop also puts the rudder hard over, the way it was already turning: the reverse propeller alone
#: decelerates this hull ~0.07 m/s^2 (1.2 m/s: 14.7 m to stop), a hull turning hard sheds its speed in
#: drag and its way ahead in the turn (4.3 m from 1.2 m/s at 5 m deep, never deeper;
#: tests/integration/test_abort_stops.py).
HARD_OVER_MPS = 0.4
#: The turn a fast stop makes with the rudder hard over, as a circle of this radius (m; from 1.05 m/s it
#: turned 125 deg over 6 m ahead, clutter_current r7): the stop turns the side whose circle keeps clear of
#: the obstacles (the way it was turning took it 1.4 m into one 5 m past the last goal).
STOP_TURN_RADIUS_M = 4.0
#: ... where that circle keeps less than this (m) from an obstacle and the other side's keeps more.
STOP_TURN_CLEAR_M = 2.0


def clear_side(
    x_m: float, y_m: float, yaw_rad: float, obstacles: Sequence[tuple[float, float, float]], turning: float
) -> float:
    """The rudder's sign for a fast stop's hard-over turn from (``x_m``, ``y_m``, ``yaw_rad``) among the
    ``obstacles`` (x, y, radius): the way it was turning (``turning``, the rudder's sign now; 0.0 = port)
    unless that turn's circle (:data:`STOP_TURN_RADIUS_M`) comes within :data:`STOP_TURN_CLEAR_M` of an
    obstacle and the other's keeps farther."""
    way = 1.0 if turning >= 0.0 else -1.0  # positive rudder: a turn to port (the bus contract's sign)

    def clearance_m(rudder_sign: float) -> float:
        side = -rudder_sign  # to port: the centre to the left (NED: yaw - 90 deg)
        cx = x_m + STOP_TURN_RADIUS_M * math.cos(yaw_rad + side * math.pi / 2.0)
        cy = y_m + STOP_TURN_RADIUS_M * math.sin(yaw_rad + side * math.pi / 2.0)
        return min(
            (math.hypot(ox - cx, oy - cy) - STOP_TURN_RADIUS_M - r for ox, oy, r in obstacles),
            default=math.inf,
        )

    kept_m = clearance_m(way)
    return -way if kept_m < STOP_TURN_CLEAR_M and clearance_m(-way) > kept_m else way


#: On the run-in the propeller reverses while the vehicle is faster than the speed reference, fully once it
#: is this much faster (m/s): the run-in's deceleration asks for most of the reverse propeller's authority.
RUN_IN_MARGIN_MPS = 0.05
#: A path less curved than this (1/m: a 1 km radius) is a straight, where the run-in may reverse.
RUN_IN_STRAIGHT_1PM = 1e-3


#: The run-in's arrival speed rises by this much per m/s of estimated current (s/s): the fins' force goes
#: with the square of the speed through the water, and slow in a current they cannot hold the goal's line
#: (the current campaign at 0.25 m/s: 0.25-0.43 m off the goal in 0.1-0.2 m/s, 12 of 82 runs never
#: arriving in 0.3-0.5 m/s across the final heading); from 0.2 m/s on the run-in does not slow at all (the
#: stop after COMPLETE still brakes, and the current carries a stopped vehicle anyway).
RUN_IN_CURRENT_GAIN = 4.0


def arrival_speed_mps(cfg: CoreConfig, nav: NavState) -> float:
    """The run-in's speed at the last goal (m/s; 0 = no run-in): ``[mission] arrival_speed_mps``, raised
    by :data:`RUN_IN_CURRENT_GAIN` x the estimated current beyond
    :data:`~onboard.core.nav.current.CURRENT_NOISE_MPS` (the estimate's value however vague: a current it
    is still learning is no reason to creep in slowly)."""
    arrival = cfg.mission.arrival_speed_mps
    if arrival <= 0.0:
        return 0.0
    current = math.hypot(nav.current_north_mps, nav.current_east_mps)
    if not math.isfinite(current):
        return arrival
    return arrival + RUN_IN_CURRENT_GAIN * max(current - CURRENT_NOISE_MPS, 0.0)


def speed_ahead_mps(nav: NavState) -> float:
    """The speed over ground along the heading (m/s; + = ahead): what the stop brings to 0."""
    vn, ve, _ = nav.velocity_ned_mps
    return vn * math.cos(nav.yaw_rad) + ve * math.sin(nav.yaw_rad)


def reverse_rps(
    excess_mps: float,
    brake_rps: float,
    previous_rps: float,
    limits: ActuatorLimits,
    dt_s: float,
    taper_mps: float = BRAKE_TAPER_MPS,
) -> float:
    """The braking propeller speed (rev/s, <= 0) for a speed ``excess_mps`` to take off: ``-brake_rps``,
    tapered below ``taper_mps``, reached at the propeller's rate limit from ``previous_rps`` (or from 0:
    a forward propeller stops at once, as the actuators' not-live rule has it)."""
    previous_rps = min(previous_rps, 0.0)
    target = -brake_rps * math.sqrt(min(1.0, max(excess_mps, 0.0) / taper_mps))
    rate = limits.propeller_rate_limit_rps_per_s
    if rate > 0.0:
        step = rate * dt_s if math.isfinite(dt_s) and dt_s > 0.0 else 0.0
        target = min(max(target, previous_rps - step), previous_rps + step)
    return min(max(target, -brake_rps), 0.0)


def run_in_rps(
    nav: NavState, reference: GuidanceReference, cfg: CoreConfig, previous_rps: float, dt_s: float
) -> float | None:
    """On the run-in to the last goal: the reverse propeller speed (rev/s) while the vehicle is faster than
    guidance's speed reference (fully from :data:`RUN_IN_MARGIN_MPS` faster) on a straight stretch; None:
    the PD's command stands. Never in a turn (the reference's curvature above :data:`RUN_IN_STRAIGHT_1PM`):
    the fins need the speed through the water there (current campaign, 0.5 m/s across the final heading:
    braking into the turn, the vehicle overshot it by 4 m and arrived 13 deg off the goal's course)."""
    excess = speed_ahead_mps(nav) - reference.speed_mps
    if not excess > 0.0 or cfg.mission.brake_rps <= 0.0 or abs(reference.curvature_1pm) > RUN_IN_STRAIGHT_1PM:
        return None
    mission = cfg.mission
    return reverse_rps(excess, mission.brake_rps, previous_rps, cfg.control.limits, dt_s, RUN_IN_MARGIN_MPS)


@dataclass
class Stop:
    """The stop after COMPLETE (surface) and in HOLD: ``braking`` from :meth:`begin` until stopped."""

    braking: bool = False
    t_s: float = 0.0  # how long it has braked (s)
    depth_m: float = math.nan  # the depth it began at (m): never deeper than that
    obstacles: tuple[tuple[float, float, float], ...] = ()  # the mission's (x, y, radius), m
    rudder_sign: float = 0.0  # the side of a fast stop's hard-over turn, chosen at its first (0: not yet)

    def begin(self, depth_m: float, obstacles: tuple[tuple[float, float, float], ...] = ()) -> None:
        """Brake from now on, never deeper than ``depth_m`` (the vehicle's depth now: at COMPLETE, its last
        goal's); a fast stop turns hard to the side clear of ``obstacles`` (:func:`clear_side`)."""
        self.braking, self.t_s, self.depth_m = True, 0.0, depth_m
        self.obstacles, self.rudder_sign = obstacles, 0.0

    def end(self) -> None:
        self.braking = False

    def command(
        self, nav: NavState, cfg: CoreConfig, previous: ActuatorCommand, dt_s: float
    ) -> ActuatorCommand | None:
        """One tick of braking: the command, or None once stopped (the caller sends its still command)."""
        if not self.braking:
            return None
        self.t_s += max(dt_s, 0.0) if math.isfinite(dt_s) else 0.0
        speed = speed_ahead_mps(nav)
        if not (math.isfinite(speed) and speed > STOPPED_MPS and self.t_s <= BRAKE_MAX_S):
            self.braking = False
            return None
        limits = cfg.control.limits
        below_m = nav.depth_m - self.depth_m if math.isfinite(self.depth_m) else 0.0
        # level, or nose up where it is below the depth it began at
        pitch_d = min(max(DEPTH_GAIN_RAD_PER_M * below_m, 0.0), NOSE_UP_MAX_RAD)
        pitch_err = pitch_d - nav.pitch_rad if math.isfinite(nav.pitch_rad) else 0.0
        stern = -PITCH_GAIN * pitch_err  # negative stern = nose up
        rudder = 0.0
        if speed > HARD_OVER_MPS:
            if self.obstacles and not self.rudder_sign and nav.position_valid:
                self.rudder_sign = clear_side(
                    nav.x_m, nav.y_m, nav.yaw_rad, self.obstacles, previous.rudder_rad
                )
            rudder = math.copysign(
                math.radians(limits.rudder_limit_deg), self.rudder_sign or previous.rudder_rad
            )
        fins = saturate(ActuatorCommand(rudder, stern, stern, 0.0), previous, limits, dt_s)
        rps = reverse_rps(speed, cfg.mission.brake_rps, previous.propeller_rps, limits, dt_s)
        return ActuatorCommand(
            fins.rudder_rad, fins.stern_port_rad, fins.stern_starboard_rad, rps, fins.flags
        )


#: Once stopped, a vehicle carried this far (m, over ground) from where it stopped is drifting with the
#: water: the ``surface`` end then holds position at the last goal. The current estimate cannot say so: in
#: a 1.5 m/s head current along one heading it read 0.01 m/s (a slow vehicle, not a current), and the
#: stopped vehicle was swept 8-13 m back within 20 s (head_current.yaml).
HOLD_DRIFT_M = 1.0
#: Carried astern over ground faster than this (m/s) while the stop brakes, the vehicle was stemming a head
#: current (its reverse propeller tapers off before it could drive it astern): it holds position at once.
HOLD_ASTERN_MPS = 0.05
#: The hold's path: a straight of this length (m) against the drift, ending at the last goal.
HOLD_PATH_M = 20.0


def hold_path(x_m: float, y_m: float, depth_m: float, drift_north_m: float, drift_east_m: float) -> Path:
    """The path a hold flies: :data:`HOLD_PATH_M` of straight heading against the drift (north, east: the
    way the water carried the vehicle), ending at the goal (x_m, y_m) at ``depth_m``; guidance's reference
    waits at its end (``reference_stops_at_end``) and the speed loop's integral holds the vehicle there."""
    yaw = math.atan2(-drift_east_m, -drift_north_m)
    x0, y0 = x_m - HOLD_PATH_M * math.cos(yaw), y_m - HOLD_PATH_M * math.sin(yaw)
    return Path(
        (StraightSegment(x0, y0, yaw, HOLD_PATH_M),),
        start_depth_m=depth_m,
        end_depth_m=depth_m,
        word="S",
        start_pose=(x0, y0, yaw),
    )


class Surface:
    """The ``surface`` end: the pipeline sends the stop's command (:class:`Stop`), then NEUTRAL (the
    actuators are then not live, :func:`actuators_live`). Stopped, a vehicle the water carries
    :data:`HOLD_DRIFT_M` from where it stopped holds position at the last goal instead (heading against the
    drift, no deeper than the goal or than it is then; the stop is begun again, so the actuators are live
    and the pipeline flies the hold's leg) until the operator ends the mission (a new mission, STOP,
    DISARM): drifting, it would leave the stopping zone the validator kept clear."""

    kind = "surface"

    def __init__(self) -> None:
        self.stopped_at: tuple[float, float] | None = None  # where the stop ended (x_m, y_m)

    def start(self, ex: Plans, v: Vehicle) -> None:
        ex.drop_path()

    def step(self, ex: Plans, v: Vehicle, nav: NavState, dt_s: float) -> Leg | None:
        if ex.path_kind != "hold":
            if not v.mission.goals or not (math.isfinite(nav.x_m) and math.isfinite(nav.y_m)):
                return None
            astern = speed_ahead_mps(nav) < -HOLD_ASTERN_MPS
            if ex.braking and not astern:
                self.stopped_at = None
                return None
            if self.stopped_at is None:
                self.stopped_at = (nav.x_m, nav.y_m)
            dn, de = nav.x_m - self.stopped_at[0], nav.y_m - self.stopped_at[1]
            if astern:  # the way the water carries it: astern over ground
                vn, ve, _ = nav.velocity_ned_mps
                dn, de = vn, ve
            elif math.hypot(dn, de) < HOLD_DRIFT_M:
                return None
            goal = v.mission.goals[-1]
            depth_m = min(goal.depth_m, nav.depth_m) if math.isfinite(nav.depth_m) else goal.depth_m
            path = hold_path(goal.x_m, goal.y_m, depth_m, dn, de)
            yaw = math.atan2(-de, -dn)
            x0, y0, _ = path.start_pose
            along = (nav.x_m - x0) * math.cos(yaw) + (nav.y_m - y0) * math.sin(yaw)
            ex.path, ex.path_kind, ex.path_goal_index = path, "hold", len(v.mission.goals) - 1
            # the reference waits at the goal from the start: the speed loop brings the vehicle back to it
            ex.guidance_state = GuidanceState(s_ref_m=HOLD_PATH_M, s_proj_m=min(max(along, 0.0), HOLD_PATH_M))
            ex.begin_stop(v)  # live again (the stop's command is not sent while a leg is flown)
        return ex.follow(v, nav, dt_s)

    def plan_failed(self, ex: Plans, v: Vehicle, why: str, late: bool) -> None:
        return None

    def done(self, v: Vehicle) -> bool:
        return True

    def progress(self, ex: Plans, v: Vehicle) -> Progress:
        if ex.path_kind == "hold":
            return Progress("holding position", 1.0)
        return Progress("stopping" if ex.braking else "surfacing", 1.0)
