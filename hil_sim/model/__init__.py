"""The pure simulation core of the ISiMI100 HIL bench: parameters, 6-DOF dynamics, RK4, actuators, sensors.

No bus, no clock: the bench program (``auv-hil``) calls :func:`step` once per control period. See
``hil_sim/params/isimi100.toml`` for the vehicle and the reasons behind every number.
"""

from hil_sim.model.actuators import (
    NEUTRAL_COMMAND,
    ActuatorCommand,
    ActuatorState,
    SaturationFlags,
    WatchdogState,
    actuators_after,
    saturate_command,
    watchdog_output,
    watchdog_rearm,
    watchdog_tick,
)
from hil_sim.model.current import CurrentParams
from hil_sim.model.dynamics import BodyState, DynInputs, derivatives
from hil_sim.model.params import VehicleParams, load_params
from hil_sim.model.sensors import AhrsMeasurement, DepthMeasurement, DvlMeasurement, Measurement, PositionFix
from hil_sim.model.sim import SimSetup, SimState, StepResult, initial_state, make_setup, step
from hil_sim.model.turning import SteadyTurn, steady_turn, turning_table

__all__ = [
    "NEUTRAL_COMMAND",
    "ActuatorCommand",
    "ActuatorState",
    "AhrsMeasurement",
    "BodyState",
    "CurrentParams",
    "DepthMeasurement",
    "DvlMeasurement",
    "DynInputs",
    "Measurement",
    "PositionFix",
    "SaturationFlags",
    "SimSetup",
    "SimState",
    "SteadyTurn",
    "StepResult",
    "VehicleParams",
    "WatchdogState",
    "actuators_after",
    "derivatives",
    "initial_state",
    "load_params",
    "make_setup",
    "saturate_command",
    "steady_turn",
    "step",
    "turning_table",
    "watchdog_output",
    "watchdog_rearm",
    "watchdog_tick",
]
