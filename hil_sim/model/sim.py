"""The simulation facade the bench program calls once per control period (pure).

    result = step(state, command, setup, rng)

integrates the truth over one control period (an integer number of fixed RK4 steps), moves the actuators
under the held command, samples the sensors that fall due, updates the current, and returns a *new*
:class:`SimState` plus the measurements (truth and measurements kept apart). Nothing is stored between
calls: the caller owns the state, the setup and the ``numpy.random.Generator`` (seeded), so two runs never
share state and one seed reproduces a run bit for bit.

The watchdog (:mod:`hil_sim.model.actuators`) sits in front of ``step``: the bus layer decides which command
is valid, ``watchdog_tick``/``watchdog_output`` turn that into the command passed here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hil_sim.model.actuators import (
    ActuatorCommand,
    ActuatorState,
    SaturationFlags,
    actuators_after,
    saturate_command,
)
from hil_sim.model.current import CurrentParams, current_after
from hil_sim.model.dynamics import BodyState, derivatives
from hil_sim.model.integrator import euler_step, rk4_step_staged
from hil_sim.model.params import ActuatorParams, Coefficients, SensorProfile, VehicleParams
from hil_sim.model.sensors import (
    Measurement,
    SensorSchedule,
    advance_schedule,
    due_mask,
    make_schedule,
    sample,
)
from onboard.protocol.conventions import body_to_ned_matrix

_PI = math.pi
_TWO_PI = 2.0 * math.pi


@dataclass(frozen=True, slots=True)
class SimSetup:
    """What stays fixed during a run.

    Attributes:
        params: the vehicle model.
        sensors: the sensor profile (``basin`` or ``sea`` from the params file, or a custom one).
        current: the current model.
        step_s: RK4 step (s); ``control_period_s`` must be an integer multiple of it.
        control_period_s: the period of :func:`step` (s), e.g. 0.05 for the 20 Hz control loop.
        substeps: control_period_s / step_s.
    """

    params: VehicleParams
    sensors: SensorProfile
    current: CurrentParams
    step_s: float
    control_period_s: float
    substeps: int


@dataclass(frozen=True, slots=True)
class SimState:
    """The complete simulator state (immutable).

    Attributes:
        step_index: RK4 steps since the start; time is ``step_index * step_s`` (no accumulated rounding).
        t_s: simulation time (s).
        body: truth eta + nu.
        actuators: actual fin angles and propeller speed.
        current_ned_mps: the current now (north, east, down), m/s.
        schedule: sensor sampling schedule.
    """

    step_index: int
    t_s: float
    body: BodyState
    actuators: ActuatorState
    current_ned_mps: tuple[float, float, float]
    schedule: SensorSchedule


@dataclass(frozen=True, slots=True)
class StepResult:
    """Outcome of one control period: the new state, the measurements sampled in (t, t + period], and the
    saturated command actually applied with its saturation flags."""

    state: SimState
    measurements: tuple[Measurement, ...]
    applied_command: ActuatorCommand
    saturation: SaturationFlags


def dividing_step_s(max_step_s: float, control_period_s: float) -> float:
    """The largest integration step <= ``max_step_s`` that divides ``control_period_s`` (both > 0).

    The params file's ``step_s`` is the largest step that keeps the model accurate (its accuracy test); any
    control rate the bench allows has such a step: the period split into ceil(period / max_step) equal steps.
    """
    if not (max_step_s > 0.0 and control_period_s > 0.0):
        raise ValueError("step_s and control_period_s must be > 0")
    n = max(1, math.ceil(control_period_s / max_step_s - 1e-9))
    return control_period_s / n


def make_setup(
    params: VehicleParams,
    profile: str | SensorProfile = "basin",
    current: CurrentParams | None = None,
    step_s: float | None = None,
    control_period_s: float | None = None,
) -> SimSetup:
    """Build a :class:`SimSetup`; defaults come from the params file.

    Without ``step_s`` the step is :func:`dividing_step_s` of the params file's ``step_s`` (an upper bound)
    and the period, so every control rate works. An explicit ``step_s`` is taken as it is (an accuracy test
    asks for exactly that step): ValueError when it does not divide the period.
    """
    sensors = params.sensor_profiles[profile] if isinstance(profile, str) else profile
    cur = current if current is not None else CurrentParams.from_config(params.config.current)
    period = params.control_period_s if control_period_s is None else control_period_s
    h = dividing_step_s(params.step_s, period) if step_s is None else step_s
    if not (h > 0.0 and period > 0.0):
        raise ValueError("step_s and control_period_s must be > 0")
    n = round(period / h)
    if n < 1 or abs(n * h - period) > 1e-9 * period:
        raise ValueError(f"step_s={h} does not divide control_period_s={period}")
    return SimSetup(params, sensors, cur, h, period, n)


def initial_state(
    setup: SimSetup,
    body: BodyState | None = None,
    actuators: ActuatorState | None = None,
    current_ned_mps: tuple[float, float, float] | None = None,
) -> SimState:
    """A fresh state at t = 0 (default: at rest at the origin, on the surface plane, fins neutral)."""
    return SimState(
        step_index=0,
        t_s=0.0,
        body=body if body is not None else BodyState(),
        actuators=actuators if actuators is not None else ActuatorState(),
        current_ned_mps=current_ned_mps if current_ned_mps is not None else setup.current.mean_ned_mps,
        schedule=make_schedule(setup.sensors, setup.step_s, start_step=1),
    )


def drifting_with_water(body: BodyState, current_ned_mps: tuple[float, float, float]) -> BodyState:
    """``body`` drifting with the water: its velocity over ground is the current (in body axes), zero through
    the water, no rotation; the pose kept.

    A vehicle at sea before its mission (propeller off, fins neutral) drifts with the water. Started at rest
    over ground instead it is set sideways until its fins bite, and its DVL never shows the current before
    the start, so the onboard's first plan ignores it.
    """
    cn, ce, cd = current_ned_mps
    r11, r12, r13, r21, r22, r23, r31, r32, r33 = body_to_ned_matrix(
        body.roll_rad, body.pitch_rad, body.yaw_rad
    )
    return body._replace(
        u_mps=r11 * cn + r21 * ce + r31 * cd,
        v_mps=r12 * cn + r22 * ce + r32 * cd,
        w_mps=r13 * cn + r23 * ce + r33 * cd,
        p_radps=0.0,
        q_radps=0.0,
        r_radps=0.0,
    )


def _wrap(angle: float) -> float:
    if -_PI < angle <= _PI:
        return angle
    a = math.fmod(angle + _PI, _TWO_PI)
    if a <= 0.0:
        a += _TWO_PI
    return a - _PI


def stage_inputs(
    act: ActuatorState,
    cmd: ActuatorCommand,
    current_ned_mps: tuple[float, float, float],
    n_substeps: int,
    h_s: float,
    ap: ActuatorParams,
) -> list[tuple[float, ...]]:
    """Dynamics inputs at every half step 0, h/2, ..., n h of a period (exact actuator trajectories)."""
    cn, ce, cd = current_ned_mps
    out: list[tuple[float, ...]] = []
    for j in range(2 * n_substeps + 1):
        a = actuators_after(act, cmd, 0.5 * h_s * j, ap)
        out.append((a.rudder_rad, a.stern_port_rad, a.stern_starboard_rad, a.propeller_rps, cn, ce, cd))
    return out


def propagate(
    x: tuple[float, ...],
    inputs: list[tuple[float, ...]],
    n_substeps: int,
    h_s: float,
    coeffs: Coefficients,
) -> tuple[float, ...]:
    """Integrate the 12-state truth over ``n_substeps`` RK4 steps (precomputed stage inputs; yaw wrapped)."""
    for k in range(n_substeps):
        x = rk4_step_staged(derivatives, x, h_s, inputs[2 * k], inputs[2 * k + 1], inputs[2 * k + 2], coeffs)
        psi = x[5]
        if not -_PI < psi <= _PI:
            x = (*x[:5], _wrap(psi), *x[6:])
    return x


def propagate_euler(
    x: tuple[float, ...],
    inputs: list[tuple[float, ...]],
    n_substeps: int,
    h_s: float,
    coeffs: Coefficients,
) -> tuple[float, ...]:
    """Explicit-Euler counterpart of :func:`propagate` (benchmark reference; inputs at every half step)."""
    for k in range(n_substeps):
        u0 = inputs[2 * k]

        def rhs(_t: float, s: tuple[float, ...], u0: tuple[float, ...] = u0) -> tuple[float, ...]:
            return derivatives(s, u0, coeffs)

        x = euler_step(rhs, 0.0, x, h_s)
        psi = x[5]
        if not -_PI < psi <= _PI:
            x = (*x[:5], _wrap(psi), *x[6:])
    return x


def step(state: SimState, command: ActuatorCommand, setup: SimSetup, rng: np.random.Generator) -> StepResult:
    """Advance the simulation by one control period under ``command`` (held constant over the period).

    Args:
        state: the state at the start of the period (not modified).
        command: the command after the watchdog; it is saturated here (flags returned).
        setup: run constants.
        rng: the run's seeded generator (sensor noise, current variation).

    Returns:
        The new state, the measurements due in (t, t + control_period_s] in time order, the applied command.
    """
    params = setup.params
    cmd, flags = saturate_command(command, params.actuators)
    n, h = setup.substeps, setup.step_s
    inputs = stage_inputs(state.actuators, cmd, state.current_ned_mps, n, h, params.actuators)
    coeffs = params.coeffs
    x: tuple[float, ...] = tuple(state.body)
    schedule = state.schedule
    measurements: list[Measurement] = []
    first = state.step_index + 1
    last = state.step_index + n
    if min(schedule.next_due_step) > last:
        x = propagate(x, inputs, n, h, coeffs)  # no sensor due: the fast path
    else:
        for k in range(n):
            x = propagate(x, inputs[2 * k : 2 * k + 3], 1, h, coeffs)
            idx = first + k
            mask = due_mask(schedule, idx)
            if any(mask):
                measurements.extend(sample(BodyState._make(x), idx * h, mask, setup.sensors, rng))
                schedule = advance_schedule(schedule, idx)
    new_act = actuators_after(state.actuators, cmd, n * h, params.actuators)
    current = current_after(state.current_ned_mps, setup.current, n * h, rng)
    new_state = SimState(last, last * h, BodyState._make(x), new_act, current, schedule)
    return StepResult(new_state, tuple(measurements), cmd, flags)
