"""Steady turns at a fixed rudder: the turning-diameter table that sets the planner's turning radius.

The REMUS-derived model is open-loop unstable in pitch (Munk moment), so depth is held by a small bench depth
keeper (PD on pitch with a depth outer loop, stern planes only; *not* the product controller). Rudder and
propeller are fixed. After a settling time the diameter is the least-squares circle (Kasa fit) through the
horizontal track over the measuring window; it agrees with 2 U / |psi_dot| of the steady turn.

``python -m hil_sim.model.turning`` prints the table for the params file.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hil_sim.model.actuators import ActuatorCommand, ActuatorState, actuators_after, saturate_command
from hil_sim.model.dynamics import BodyState
from hil_sim.model.params import VehicleParams
from hil_sim.model.sim import propagate, stage_inputs


@dataclass(frozen=True, slots=True)
class DepthKeeper:
    """Bench depth keeper: theta_ref = clip(kz (z - z_ref), +-max_pitch); stern = kth (theta - theta_ref)
    + kq q (rad per m, rad per rad, rad per rad/s). +stern pitches nose down (conventions)."""

    kz_radpm: float = 0.4
    max_pitch_rad: float = math.radians(20.0)
    ktheta: float = 2.0
    kq_s: float = 1.5

    def stern_rad(self, body: BodyState, depth_ref_m: float) -> float:
        """Stern-plane command (rad) for the truth ``body`` and the depth reference (m)."""
        theta_ref = self.kz_radpm * (body.z_m - depth_ref_m)
        theta_ref = max(-self.max_pitch_rad, min(self.max_pitch_rad, theta_ref))
        return self.ktheta * (body.pitch_rad - theta_ref) + self.kq_s * body.q_radps


@dataclass(frozen=True, slots=True)
class SteadyTurn:
    """A steady turn: diameter (m), speed through the water (m/s), yaw rate (rad/s), roll (rad), drift angle
    (rad), mean depth error (m), and the diameter from the first and second halves of the window (m)."""

    rudder_rad: float
    diameter_m: float
    speed_mps: float
    yaw_rate_radps: float
    roll_rad: float
    drift_rad: float
    depth_error_m: float
    diameter_first_half_m: float
    diameter_second_half_m: float


def fit_circle(x: np.ndarray, y: np.ndarray) -> tuple[float, float, float]:
    """Least-squares circle (Kasa): centre (xc, yc) and radius, from points on an arc."""
    a = np.column_stack([x, y, np.ones_like(x)])
    b = x * x + y * y
    sol, *_ = np.linalg.lstsq(a, b, rcond=None)
    xc, yc = 0.5 * sol[0], 0.5 * sol[1]
    return float(xc), float(yc), float(math.sqrt(sol[2] + xc * xc + yc * yc))


def run_fixed_rudder(
    params: VehicleParams,
    rudder_rad: float,
    propeller_rps: float,
    duration_s: float,
    depth_m: float = 5.0,
    step_s: float | None = None,
    keeper: DepthKeeper | None = None,
    start: BodyState | None = None,
) -> list[BodyState]:
    """Truth at every control period of a fixed-rudder, fixed-rps run with the depth held (no sensors).

    Starts at ``start`` (default: at ``depth_m``, heading north, moving at 1 m/s) with the rudder already at
    its angle and the propeller at speed, so the run is not dominated by the actuator transient.
    """
    keeper = keeper or DepthKeeper()
    h = params.step_s if step_s is None else step_s
    period = params.control_period_s
    n = round(period / h)
    body = start or BodyState(z_m=depth_m, u_mps=1.0)
    act = ActuatorState(rudder_rad, 0.0, 0.0, propeller_rps)
    out = [body]
    x = tuple(body)
    for _ in range(round(duration_s / period)):
        ds = keeper.stern_rad(body, depth_m)
        cmd, _ = saturate_command(ActuatorCommand(rudder_rad, ds, ds, propeller_rps), params.actuators)
        inputs = stage_inputs(act, cmd, (0.0, 0.0, 0.0), n, h, params.actuators)
        x = propagate(x, inputs, n, h, params.coeffs)
        act = actuators_after(act, cmd, n * h, params.actuators)
        body = BodyState._make(x)
        out.append(body)
    return out


def steady_turn(
    params: VehicleParams,
    rudder_rad: float,
    propeller_rps: float | None = None,
    depth_m: float = 5.0,
    settle_s: float = 60.0,
    measure_s: float = 60.0,
    step_s: float | None = None,
) -> SteadyTurn:
    """Simulate a fixed-rudder turn, depth held, and measure its steady diameter (circle fit) and state."""
    rps = params.nominal_rps if propeller_rps is None else propeller_rps
    track = run_fixed_rudder(params, rudder_rad, rps, settle_s + measure_s, depth_m, step_s)
    k0 = round(settle_s / params.control_period_s)
    win = track[k0:]
    xs = np.array([b.x_m for b in win])
    ys = np.array([b.y_m for b in win])
    _, _, rad = fit_circle(xs, ys)
    half = len(win) // 2
    _, _, r1 = fit_circle(xs[:half], ys[:half])
    _, _, r2 = fit_circle(xs[half:], ys[half:])
    speed = float(np.mean([math.sqrt(b.u_mps**2 + b.v_mps**2 + b.w_mps**2) for b in win]))
    yaw_rate = float(np.mean([b.r_radps for b in win]))
    roll = float(np.mean([b.roll_rad for b in win]))
    drift = float(np.mean([math.atan2(b.v_mps, b.u_mps) for b in win]))
    depth_err = float(np.mean([b.z_m - depth_m for b in win]))
    return SteadyTurn(rudder_rad, 2.0 * rad, speed, yaw_rate, roll, drift, depth_err, 2.0 * r1, 2.0 * r2)


def turning_table(
    params: VehicleParams, rudder_deg: tuple[float, ...] = (5.0, 10.0, 15.0, 20.0)
) -> list[tuple[float, SteadyTurn, SteadyTurn]]:
    """(rudder_deg, port turn, starboard turn) at the nominal propeller speed for each rudder angle.

    +rudder turns to port. The propeller torque rolls the vehicle, so starboard circles are slightly wider;
    the planner's radius must use the wider of the two (``max`` of the diameters).
    """
    return [
        (d, steady_turn(params, math.radians(d)), steady_turn(params, -math.radians(d))) for d in rudder_deg
    ]


if __name__ == "__main__":  # pragma: no cover - regenerates the [turning] table of the params file
    import sys

    from hil_sim.model.params import load_params

    p = load_params(sys.argv[1] if len(sys.argv) > 1 else None)
    for _deg, port, stbd in turning_table(p):
        for t in (port, stbd):
            sys.stdout.write(
                f"rudder {math.degrees(t.rudder_rad):+6.1f} deg: diameter {t.diameter_m:7.3f} m "
                f"(halves {t.diameter_first_half_m:.3f}/{t.diameter_second_half_m:.3f}), "
                f"speed {t.speed_mps:.3f} m/s, r {t.yaw_rate_radps:+.4f} rad/s, "
                f"roll {math.degrees(t.roll_rad):+.2f} deg, drift {math.degrees(t.drift_rad):+.2f} deg, "
                f"depth err {t.depth_error_m:+.3f} m\n"
            )
