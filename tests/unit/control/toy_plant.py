"""A toy vehicle for closed-loop unit tests (not a dynamics model): first-order speed, yaw-rate and pitch-rate
responses with the real fin signs (+rudder -> negative yaw rate, +stern -> nose down), kinematic position,
and an optional water current. Pure; each run starts from its own state."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from onboard.core.control import ActuatorCommand
from onboard.core.nav import NavState, nav_state_at

RPS_PER_MPS = 25.0 / 1.6  # matches the placeholder speed map
YAW_GAIN = 1.07  # r_ss = -YAW_GAIN * U * rudder: with 1 rad*m of rudder per curvature, r = U * kappa
PITCH_GAIN = 1.5  # q_ss = -PITCH_GAIN * U * stern - restoring


@dataclass(frozen=True)
class ToyState:
    x_m: float
    y_m: float
    depth_m: float
    yaw_rad: float
    pitch_rad: float = 0.0
    u_mps: float = 0.0
    r_radps: float = 0.0
    q_radps: float = 0.0


def toy_step(
    s: ToyState, cmd: ActuatorCommand, dt_s: float, current_xy_mps: tuple[float, float] = (0.0, 0.0)
) -> ToyState:
    u = s.u_mps + dt_s * (cmd.propeller_rps / RPS_PER_MPS - s.u_mps) / 1.0
    r = s.r_radps + dt_s * (-YAW_GAIN * u * cmd.rudder_rad - s.r_radps) / 0.3
    q = s.q_radps + dt_s * (-PITCH_GAIN * u * cmd.stern_rad - 0.5 * s.pitch_rad - s.q_radps) / 0.3
    yaw = s.yaw_rad + dt_s * r
    pitch = s.pitch_rad + dt_s * q
    x = s.x_m + dt_s * (u * math.cos(pitch) * math.cos(yaw) + current_xy_mps[0])
    y = s.y_m + dt_s * (u * math.cos(pitch) * math.sin(yaw) + current_xy_mps[1])
    depth = s.depth_m + dt_s * (-u * math.sin(pitch))
    return replace(
        s, x_m=x, y_m=y, depth_m=depth, yaw_rad=yaw, pitch_rad=pitch, u_mps=u, r_radps=r, q_radps=q
    )


def toy_nav(s: ToyState, t_s: float = 0.0) -> NavState:
    return nav_state_at(
        s.x_m,
        s.y_m,
        s.depth_m,
        math.remainder(s.yaw_rad, 2 * math.pi),
        u_mps=s.u_mps,
        pitch_rad=s.pitch_rad,
        q_radps=s.q_radps,
        r_radps=s.r_radps,
        t_s=t_s,
    )
