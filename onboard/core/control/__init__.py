"""Onboard control: the paper's revised PD (eqs. 8-10) in ``paper`` and ``improved`` profiles.

Public API: :class:`ControlParams` (``[control]`` with ``[control.paper]``, ``[control.improved]``,
``[control.limits]``), :class:`ControllerState`, :func:`step`, and in
:mod:`onboard.core.control.actuators` the
:class:`ActuatorCommand`, :class:`ActuatorFlag`, :class:`ActuatorLimits` and the one limiter :func:`saturate`.
"""

from onboard.core.control.actuators import (
    NEUTRAL,
    ActuatorCommand,
    ActuatorFlag,
    ActuatorLimits,
    saturate,
)
from onboard.core.control.pd import (
    ControlDebug,
    ControllerState,
    ControlParams,
    ImprovedGains,
    PaperGains,
    PdGains,
    step,
)

__all__ = [
    "NEUTRAL",
    "ActuatorCommand",
    "ActuatorFlag",
    "ActuatorLimits",
    "ControlDebug",
    "ControlParams",
    "ControllerState",
    "ImprovedGains",
    "PaperGains",
    "PdGains",
    "saturate",
    "step",
]
