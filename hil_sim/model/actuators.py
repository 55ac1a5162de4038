"""Actuator dynamics and the command watchdog (pure).

- Fins (rudder pair, port and starboard stern planes): commanded angle saturated at +-fin_limit_rad, the
  actual angle moves towards it at most at fin_rate_radps (a rate-limited servo).
- Propeller: command saturated to [propeller_min_rps, propeller_max_rps], first-order lag with time constant
  tau: n_dot = (n_cmd - n) / tau.

Both are evaluated *exactly* for a command held constant over a control period (:func:`actuators_after`), so
the integrator can ask for the actuator positions at any RK4 stage time without adding integration error.

The watchdog (issue 3 point 3): the actuator node holds the last valid command; when no valid command has
come for ``timeout_periods`` control periods it goes to the failsafe (propeller off, fins neutral here; the
actuator node, :class:`hil_sim.bench_program.ActuatorNode`, sends the bus contract's ABORT stern planes
instead) and stays there (latched) until :func:`watchdog_rearm`. Ages are counted in ticks, never read from
a clock, so lock-step runs are deterministic. Frame-level checks (CRC, alive counter) are the bus layer's
job; it passes ``None`` here for a missing or invalid frame. A command with a non-finite field is treated
as invalid too.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from hil_sim.model.params import ActuatorParams

_isfinite = math.isfinite
_exp = math.exp


@dataclass(frozen=True, slots=True)
class ActuatorCommand:
    """Commanded actuator set-points (rad, rev/s). Signs: +rudder turns to port, +stern pitches nose down."""

    rudder_rad: float = 0.0
    stern_port_rad: float = 0.0
    stern_starboard_rad: float = 0.0
    propeller_rps: float = 0.0

    def is_finite(self) -> bool:
        """True when every field is a finite number."""
        return (
            _isfinite(self.rudder_rad)
            and _isfinite(self.stern_port_rad)
            and _isfinite(self.stern_starboard_rad)
            and _isfinite(self.propeller_rps)
        )


NEUTRAL_COMMAND = ActuatorCommand()
"""The failsafe command: fins neutral, propeller off."""


@dataclass(frozen=True, slots=True)
class ActuatorState:
    """Actual actuator positions: fin angles (rad) and propeller speed (rev/s)."""

    rudder_rad: float = 0.0
    stern_port_rad: float = 0.0
    stern_starboard_rad: float = 0.0
    propeller_rps: float = 0.0


@dataclass(frozen=True, slots=True)
class SaturationFlags:
    """Which commanded fields were clipped (or replaced because not finite) by :func:`saturate_command`."""

    rudder: bool = False
    stern_port: bool = False
    stern_starboard: bool = False
    propeller: bool = False

    @property
    def any(self) -> bool:
        """True if any field was clipped."""
        return self.rudder or self.stern_port or self.stern_starboard or self.propeller


def _clip(value: float, lo: float, hi: float) -> tuple[float, bool]:
    if not _isfinite(value):
        return 0.0, True
    if value > hi:
        return hi, True
    if value < lo:
        return lo, True
    return value, False


def saturate_command(cmd: ActuatorCommand, params: ActuatorParams) -> tuple[ActuatorCommand, SaturationFlags]:
    """Clip a command to the actuator limits; non-finite fields become neutral (0). Returns the flags too."""
    lim = params.fin_limit_rad
    rud, f_r = _clip(cmd.rudder_rad, -lim, lim)
    sp, f_sp = _clip(cmd.stern_port_rad, -lim, lim)
    ss, f_ss = _clip(cmd.stern_starboard_rad, -lim, lim)
    n, f_n = _clip(cmd.propeller_rps, params.propeller_min_rps, params.propeller_max_rps)
    return ActuatorCommand(rud, sp, ss, n), SaturationFlags(f_r, f_sp, f_ss, f_n)


def fin_angle_after(angle_rad: float, target_rad: float, dt_s: float, rate_radps: float) -> float:
    """Fin angle (rad) ``dt_s`` after moving from ``angle_rad`` towards ``target_rad`` at ``rate_radps``."""
    step = rate_radps * dt_s
    diff = target_rad - angle_rad
    if diff > step:
        return angle_rad + step
    if diff < -step:
        return angle_rad - step
    return target_rad


def propeller_after(rps: float, target_rps: float, dt_s: float, time_constant_s: float) -> float:
    """Propeller speed (rev/s) ``dt_s`` after ``rps``, first-order lag towards ``target_rps`` (exact)."""
    return target_rps + (rps - target_rps) * _exp(-dt_s / time_constant_s)


def actuators_after(
    state: ActuatorState, cmd: ActuatorCommand, dt_s: float, params: ActuatorParams
) -> ActuatorState:
    """Actuator positions ``dt_s`` (s, >= 0) after ``state`` under the constant saturated command."""
    rate = params.fin_rate_radps
    return ActuatorState(
        fin_angle_after(state.rudder_rad, cmd.rudder_rad, dt_s, rate),
        fin_angle_after(state.stern_port_rad, cmd.stern_port_rad, dt_s, rate),
        fin_angle_after(state.stern_starboard_rad, cmd.stern_starboard_rad, dt_s, rate),
        propeller_after(state.propeller_rps, cmd.propeller_rps, dt_s, params.propeller_time_constant_s),
    )


# ----------------------------------------------------------------------------------------------------
# Watchdog


@dataclass(frozen=True, slots=True)
class WatchdogState:
    """The actuator node's command watchdog.

    Attributes:
        last_command: the last valid command (held while fresh).
        ticks_since_valid: control periods since the last valid command (0 on the tick one arrives).
        failsafe: True once the timeout fired; latched until :func:`watchdog_rearm`.
        timeouts: how many times the failsafe fired (for the status frame).
    """

    last_command: ActuatorCommand = NEUTRAL_COMMAND
    ticks_since_valid: int = 0
    failsafe: bool = False
    timeouts: int = 0


def watchdog_tick(
    state: WatchdogState, command: ActuatorCommand | None, timeout_periods: int
) -> WatchdogState:
    """Advance the watchdog by one control period.

    Args:
        state: the watchdog state before this period.
        command: the valid command received in this period, or ``None`` (none, or dropped as invalid by the
            bus layer). A command with a non-finite field counts as ``None``.
        timeout_periods: N; the failsafe fires on the N-th consecutive period without a valid command.

    Returns:
        The new state. While in failsafe, valid commands are remembered (and reset the age) but the output
        stays neutral until :func:`watchdog_rearm`.
    """
    if command is not None and command.is_finite():
        return WatchdogState(command, 0, state.failsafe, state.timeouts)
    ticks = state.ticks_since_valid + 1
    fired = not state.failsafe and ticks >= timeout_periods
    return WatchdogState(
        state.last_command, ticks, state.failsafe or fired, state.timeouts + (1 if fired else 0)
    )


def watchdog_output(state: WatchdogState) -> ActuatorCommand:
    """The command the actuators should follow: the held command, or neutral in failsafe."""
    return NEUTRAL_COMMAND if state.failsafe else state.last_command


def watchdog_rearm(state: WatchdogState) -> WatchdogState:
    """Clear the latched failsafe (operator re-arm / node reset); the held command restarts from neutral."""
    return WatchdogState(NEUTRAL_COMMAND, 0, False, state.timeouts)
