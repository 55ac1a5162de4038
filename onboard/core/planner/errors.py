"""Typed planner errors: every bad input gets a :class:`PlannerError` with a machine-readable ``reason``."""

from __future__ import annotations

from auv_common.config import ConfigError

#: Every ``PlannerError.reason`` the planner raises, with what it means.
REASONS: dict[str, str] = {
    "radius": "a turning or obstacle radius is not positive and finite",
    "nan": "a pose, depth or obstacle contains NaN or infinity",
    "start_in_obstacle": "the start position is inside an inflated obstacle",
    "goal_in_obstacle": "the goal position is inside an inflated obstacle",
    "turning_circle_blocked": "both turning circles at the start (or at the goal) cut an obstacle; no path",
    "unreachable": "no collision-free path exists in the tangent graph",
    "depth_slope": "the path is too short for the depth change at the maximum climb/dive slope",
    "config": "a planner configuration value is out of range",
    "departs": "a re-plan departs farther from the path flown than [planner] replan_hold_m",
}


class PlannerError(ValueError):
    """The planner cannot return a safe path.

    ``reason`` is one of :data:`REASONS` (machine-readable); the message is for humans.
    """

    def __init__(self, reason: str, message: str) -> None:
        super().__init__(message)
        self.reason = reason


class PlannerConfigError(ConfigError, PlannerError):
    """A bad :class:`~onboard.core.planner.config.PlannerConfig` value.

    It is both a :class:`ConfigError` (so ``from_table`` reports it with the file and table name) and a
    :class:`PlannerError` (so callers that build the config in code see a ``reason``, e.g. ``"radius"``).
    """
