"""Navigation messages: sensor inputs in, the vehicle state out.

Frames and units as in ``onboard/protocol/conventions.py``: NED world frame (x north, y east, z down, m), body
frame FRD (u v w in m/s, p q r in rad/s), yaw in rad wrapped to (-pi, pi]. Every input carries the time its
sample was taken, ``t_sample_s``, on the same time base as the ``now_s`` given to
:func:`onboard.core.nav.step`
(the loop converts the sensor time stamps once, at the bus edge).
"""

from __future__ import annotations

import enum
import functools
import math
from dataclasses import dataclass

from onboard.protocol.conventions import body_to_ned


@dataclass(frozen=True)
class PositionFix:
    """A horizontal position fix (USBL, GNSS at the surface, ...): NED x and y in m; ``std_m`` the sensor's
    own 1-sigma accuracy (m; 0 = not stated)."""

    x_m: float
    y_m: float
    t_sample_s: float
    std_m: float = 0.0


@dataclass(frozen=True)
class DvlVelocity:
    """DVL velocity over ground in the body frame (FRD): u forward, v starboard, w down, m/s."""

    u_mps: float
    v_mps: float
    w_mps: float
    t_sample_s: float


@dataclass(frozen=True)
class Ahrs:
    """Attitude (rad; roll + starboard down, pitch + nose up, yaw 0 = north, + clockwise), rates (rad/s)."""

    roll_rad: float
    pitch_rad: float
    yaw_rad: float
    p_radps: float
    q_radps: float
    r_radps: float
    t_sample_s: float


@dataclass(frozen=True)
class Depth:
    """Depth of the vehicle reference point below the surface, m (positive down)."""

    depth_m: float
    t_sample_s: float


@dataclass(frozen=True)
class NavInputs:
    """The latest sample of each sensor (``None`` = never received).

    The loop may pass the same latest-value cache every tick: a sample whose ``t_sample_s`` is not newer than
    the last one used is not used again (so a position fix is never applied twice).
    """

    position: PositionFix | None = None
    dvl: DvlVelocity | None = None
    ahrs: Ahrs | None = None
    depth: Depth | None = None


class NavCondition(enum.IntFlag):
    """Typed conditions of the navigation solution (bit flags; ``NavCondition(0)`` = all good).

    ``*_MISSING``: never received (or never a valid sample); ``*_STALE``: older than the configured timeout;
    ``NAN_INPUT`` / ``FIX_REJECTED``: this step rejected a non-finite sample / an outlier fix (counted in the
    filter state). ``POSITION_INVALID``: no fix yet, or dead reckoning's 1-sigma wider than ``[nav]
    max_position_std_m``.
    """

    POSITION_MISSING = enum.auto()
    POSITION_STALE = enum.auto()
    POSITION_INVALID = enum.auto()
    DVL_MISSING = enum.auto()
    DVL_STALE = enum.auto()
    AHRS_MISSING = enum.auto()
    AHRS_STALE = enum.auto()
    DEPTH_MISSING = enum.auto()
    DEPTH_STALE = enum.auto()
    NAN_INPUT = enum.auto()
    FIX_REJECTED = enum.auto()
    FIX_REJECTED_REPEATEDLY = enum.auto()


#: The conditions that make one sensor's part of the solution unusable.
ATTITUDE_CONDITIONS = NavCondition.AHRS_MISSING | NavCondition.AHRS_STALE
DEPTH_CONDITIONS = NavCondition.DEPTH_MISSING | NavCondition.DEPTH_STALE
VELOCITY_CONDITIONS = NavCondition.DVL_MISSING | NavCondition.DVL_STALE

#: Conditions that make the solution unusable for closed-loop control (the failsafe treats them as stale nav).
NAV_BLOCKING = NavCondition.POSITION_INVALID | ATTITUDE_CONDITIONS | DEPTH_CONDITIONS


@dataclass(frozen=True)
class NavState:
    """The navigation solution at time ``t_s`` (the ``now_s`` of the step that produced it).

    Position is the Kalman estimate (NED, m); attitude, rates, depth and body velocity are the latest valid
    samples passed through. ``speed_mps`` is the horizontal speed over ground sqrt(u^2 + v^2), m/s.
    ``velocity_bias_x_mps`` / ``velocity_bias_y_mps`` is the position filter's velocity bias (NED, m/s): the
    difference between the DVL dead-reckoned and the fixed position rates (a bottom-track DVL's bias).
    ``current_north_mps`` / ``current_east_mps``: the estimated water current (NED, m/s; 1-sigma
    ``current_std_mps``); ``water_speed_mps``: the speed through the water (:mod:`onboard.core.nav.current`).
    ``position_std_m``: the position's radial 1-sigma sqrt(P_xx + P_yy), m; ``position_std_x_m`` /
    ``position_std_y_m`` each axis's (the filter's axes are independent: the covariance is their diagonal).
    ``fixes_rejected``: position fixes refused by the innovation gate since boot (each also flags
    ``FIX_REJECTED`` on its step).
    Ages are ``t_s - t_sample_s`` of the latest sample used (inf = never). ``conditions`` lists what is wrong.
    """

    t_s: float
    x_m: float
    y_m: float
    depth_m: float
    roll_rad: float
    pitch_rad: float
    yaw_rad: float
    u_mps: float
    v_mps: float
    w_mps: float
    p_radps: float
    q_radps: float
    r_radps: float
    speed_mps: float
    velocity_bias_x_mps: float = 0.0
    velocity_bias_y_mps: float = 0.0
    current_north_mps: float = 0.0
    current_east_mps: float = 0.0
    current_std_mps: float = math.inf
    water_speed_mps: float = 0.0
    position_std_m: float = math.inf
    position_std_x_m: float = math.inf
    position_std_y_m: float = math.inf
    position_age_s: float = math.inf
    fixes_rejected: int = 0
    velocity_age_s: float = math.inf
    attitude_age_s: float = math.inf
    depth_age_s: float = math.inf
    conditions: NavCondition = NavCondition(0)  # noqa: RUF009 (an immutable IntFlag value)

    @functools.cached_property
    def velocity_ned_mps(self) -> tuple[float, float, float]:
        """The DVL's velocity over ground rotated to NED (north, east, down), m/s (computed once per state:
        the guidance and the controller both ask)."""
        return body_to_ned(self.roll_rad, self.pitch_rad, self.yaw_rad, self.u_mps, self.v_mps, self.w_mps)

    @property
    def position_std_max_m(self) -> float:
        """The 1-sigma major semi-axis of the position's error ellipse, m (inf before the first fix)."""
        return max(self.position_std_x_m, self.position_std_y_m)

    @property
    def position_valid(self) -> bool:
        """True when the horizontal position estimate may be used."""
        return not self.conditions & NavCondition.POSITION_INVALID

    @property
    def attitude_valid(self) -> bool:
        return not self.conditions & ATTITUDE_CONDITIONS

    @property
    def depth_valid(self) -> bool:
        return not self.conditions & DEPTH_CONDITIONS

    @property
    def velocity_valid(self) -> bool:
        return not self.conditions & VELOCITY_CONDITIONS

    @property
    def valid(self) -> bool:
        """True when nothing blocks closed-loop control (see :data:`NAV_BLOCKING`)."""
        return not self.conditions & NAV_BLOCKING


def nav_state_at(
    x_m: float = 0.0,
    y_m: float = 0.0,
    depth_m: float = 0.0,
    yaw_rad: float = 0.0,
    *,
    u_mps: float = 0.0,
    pitch_rad: float = 0.0,
    roll_rad: float = 0.0,
    p_radps: float = 0.0,
    q_radps: float = 0.0,
    r_radps: float = 0.0,
    t_s: float = 0.0,
) -> NavState:
    """A fresh, fully valid NavState at a pose (for tests, replays and the simulator truth shortcut)."""
    return NavState(
        t_s=t_s,
        x_m=x_m,
        y_m=y_m,
        depth_m=depth_m,
        roll_rad=roll_rad,
        pitch_rad=pitch_rad,
        yaw_rad=yaw_rad,
        u_mps=u_mps,
        v_mps=0.0,
        w_mps=0.0,
        p_radps=p_radps,
        q_radps=q_radps,
        r_radps=r_radps,
        speed_mps=abs(u_mps),
        position_std_m=0.0,
        position_std_x_m=0.0,
        position_std_y_m=0.0,
        position_age_s=0.0,
        velocity_age_s=0.0,
        attitude_age_s=0.0,
        depth_age_s=0.0,
    )
