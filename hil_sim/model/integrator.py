"""Fixed-step integrators for autonomous-in-the-step ODEs on float tuples (pure, no shared state).

``f(t_s, x) -> x_dot``: ``t_s`` is the time since the start of the step's control period, so the caller can
evaluate time-varying inputs (the actuator trajectories) at the stage times. Every call returns a new tuple.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TypeVar

P = TypeVar("P")

Vector = tuple[float, ...]
Rhs = Callable[[float, Vector], Vector]


def rk4_step(f: Rhs, t_s: float, x: Vector, h_s: float) -> Vector:
    """One classical fourth-order Runge-Kutta step of size ``h_s`` (s) from ``x`` at ``t_s``."""
    half = 0.5 * h_s
    k1 = f(t_s, x)
    k2 = f(t_s + half, tuple([xi + half * ki for xi, ki in zip(x, k1, strict=True)]))
    k3 = f(t_s + half, tuple([xi + half * ki for xi, ki in zip(x, k2, strict=True)]))
    k4 = f(t_s + h_s, tuple([xi + h_s * ki for xi, ki in zip(x, k3, strict=True)]))
    sixth = h_s / 6.0
    ks = zip(x, k1, k2, k3, k4, strict=True)
    return tuple([xi + sixth * (a + 2.0 * b + 2.0 * c + d) for xi, a, b, c, d in ks])


def euler_step(f: Rhs, t_s: float, x: Vector, h_s: float) -> Vector:
    """One explicit Euler step (the reference integrator of the benchmark; first order)."""
    k = f(t_s, x)
    return tuple([xi + h_s * ki for xi, ki in zip(x, k, strict=True)])


def rk4_step_staged(
    f: Callable[[Vector, Vector, P], Vector],
    x: Vector,
    h_s: float,
    u_start: Vector,
    u_mid: Vector,
    u_end: Vector,
    params: P,
) -> Vector:
    """RK4 step of ``x_dot = f(x, u(t), params)`` with the inputs given at the stage times t, t+h/2, t+h.

    The caller evaluates the (exactly known) input trajectory at the three stage times, so a time-varying
    input costs no integration error beyond RK4's own. Equivalent to :func:`rk4_step`, without a closure.
    """
    half = 0.5 * h_s
    k1 = f(x, u_start, params)
    k2 = f(tuple([xi + half * ki for xi, ki in zip(x, k1, strict=True)]), u_mid, params)
    k3 = f(tuple([xi + half * ki for xi, ki in zip(x, k2, strict=True)]), u_mid, params)
    k4 = f(tuple([xi + h_s * ki for xi, ki in zip(x, k3, strict=True)]), u_end, params)
    sixth = h_s / 6.0
    ks = zip(x, k1, k2, k3, k4, strict=True)
    return tuple([xi + sixth * (a + 2.0 * b + 2.0 * c + d) for xi, a, b, c, d in ks])
