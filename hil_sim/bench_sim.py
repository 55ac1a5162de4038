"""Benchmark of the simulation core: simulated seconds per wall second for one vehicle (no bus).

``run(quick)`` returns a flat dict with unit-suffixed names (merged by ``auv-bench``). It measures and
reports; it asserts nothing about time. Figures:

- ``rk4_realtime_factor``: simulated s per wall s of a 60 s fixed-rudder turn (depth held) at the default
  step, one RK4 step per 50 ms control period, actuator and depth-keeper bookkeeping included.
- ``euler500_realtime_factor``: the same run with explicit Euler at 500 Hz (the step Fossen's remus100
  needs for this accuracy), as the reference; ``speedup_vs_euler500_ratio`` is their ratio.
- ``rk4_end_error_m`` / ``euler500_end_error_m``: end-position error of each against RK4 at step/8, so the
  comparison is at (at least) equal accuracy.
- ``derivative_eval_us``: one call of :func:`hil_sim.model.dynamics.derivatives`; ``numpy_derivative_eval_us``
  the same right-hand side through a 6x6 numpy solve, to show why plain floats are used.
"""

from __future__ import annotations

import math
import time

import numpy as np

from hil_sim.model.actuators import ActuatorCommand, ActuatorState, actuators_after, saturate_command
from hil_sim.model.dynamics import BodyState, derivatives
from hil_sim.model.params import VehicleParams, load_params
from hil_sim.model.sim import propagate, propagate_euler, stage_inputs
from hil_sim.model.turning import DepthKeeper


def _turn(params: VehicleParams, duration_s: float, step_s: float, euler: bool = False) -> BodyState:
    keeper = DepthKeeper()
    period = params.control_period_s
    n = round(period / step_s)
    rudder = math.radians(15.0)
    act = ActuatorState(rudder, 0.0, 0.0, params.nominal_rps)
    body = BodyState(z_m=5.0, u_mps=1.0)
    x: tuple[float, ...] = tuple(body)
    prop = propagate_euler if euler else propagate
    for _ in range(round(duration_s / period)):
        ds = keeper.stern_rad(body, 5.0)
        cmd, _ = saturate_command(ActuatorCommand(rudder, ds, ds, params.nominal_rps), params.actuators)
        inputs = stage_inputs(act, cmd, (0.0, 0.0, 0.0), n, step_s, params.actuators)
        x = prop(x, inputs, n, step_s, params.coeffs)
        act = actuators_after(act, cmd, n * step_s, params.actuators)
        body = BodyState._make(x)
    return body


def _numpy_rhs(params: VehicleParams) -> float:
    """Cost (us) of the same derivative with numpy arrays and a linear solve (the textbook formulation)."""
    mm = np.array(params.coeffs.mass_matrix).reshape(6, 6)
    state = tuple(BodyState(z_m=5.0, u_mps=1.5, r_radps=0.1))
    inputs = (0.1, 0.0, 0.0, 25.0, 0.0, 0.0, 0.0)
    reps = 2000
    t0 = time.perf_counter()
    for _ in range(reps):
        d = np.asarray(derivatives(state, inputs, params.coeffs))
        f = mm @ d[6:]  # rebuild a force vector, then solve as a numpy model would
        np.linalg.solve(mm, f)
    return (time.perf_counter() - t0) / reps * 1e6


def _dist(a: BodyState, b: BodyState) -> float:
    return math.dist((a.x_m, a.y_m, a.z_m), (b.x_m, b.y_m, b.z_m))


def run(quick: bool = False) -> dict[str, float]:
    """Measure and return the benchmark figures (see the module docstring)."""
    params = load_params()
    duration = 20.0 if quick else 60.0
    h = params.step_s

    reps = 3 if quick else 5
    best = math.inf
    end = BodyState()
    for _ in range(reps):
        t0 = time.perf_counter()
        end = _turn(params, duration, h)
        best = min(best, time.perf_counter() - t0)
    t0 = time.perf_counter()
    end_euler = _turn(params, duration, 0.002, euler=True)
    wall_euler = time.perf_counter() - t0
    ref = _turn(params, duration, h / 8.0)

    state = tuple(BodyState(z_m=5.0, u_mps=1.5, r_radps=0.1))
    inputs = (0.1, 0.0, 0.0, 25.0, 0.0, 0.0, 0.0)
    n_eval = 20000 if quick else 100000
    t0 = time.perf_counter()
    for _ in range(n_eval):
        derivatives(state, inputs, params.coeffs)
    eval_us = (time.perf_counter() - t0) / n_eval * 1e6

    rk4_factor = duration / best
    euler_factor = duration / wall_euler
    return {
        "rk4_realtime_factor": rk4_factor,
        "rk4_step_ms": h * 1000.0,
        "derivative_eval_us": eval_us,
        "numpy_derivative_eval_us": _numpy_rhs(params),
        "euler500_realtime_factor": euler_factor,
        "euler500_step_ms": 2.0,
        "speedup_vs_euler500_ratio": rk4_factor / euler_factor,
        "rk4_end_error_m": _dist(end, ref),
        "euler500_end_error_m": _dist(end_euler, ref),
        "simulated_s": duration,
    }


if __name__ == "__main__":  # pragma: no cover
    import json
    import sys

    sys.stdout.write(json.dumps(run(quick="--quick" in sys.argv), indent=2) + "\n")
