"""Onboard navigation: a pure Kalman filter for horizontal position plus attitude/depth pass-through.

Public API: the input messages (:class:`PositionFix`, :class:`DvlVelocity`, :class:`Ahrs`, :class:`Depth`,
bundled in :class:`NavInputs`), the output :class:`NavState` with :class:`NavCondition` flags, the ``[nav]``
config :class:`NavParams`, the filter state :class:`NavFilterState` and :func:`step`.
"""

from onboard.core.nav.estimator import AxisFilter, NavDebug, NavFilterState, NavParams, step
from onboard.core.nav.types import (
    NAV_BLOCKING,
    Ahrs,
    Depth,
    DvlVelocity,
    NavCondition,
    NavInputs,
    NavState,
    PositionFix,
    nav_state_at,
)

__all__ = [
    "NAV_BLOCKING",
    "Ahrs",
    "AxisFilter",
    "Depth",
    "DvlVelocity",
    "NavCondition",
    "NavDebug",
    "NavFilterState",
    "NavInputs",
    "NavParams",
    "NavState",
    "PositionFix",
    "nav_state_at",
    "step",
]
