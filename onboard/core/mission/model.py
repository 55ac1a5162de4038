"""Mission data: 3-D goal poses and obstacle circles, in SI units and radians (NED frame).

The ``validate`` methods check only what makes a value a value: every field is a real, finite number (a
goal's yaw may be None = free). A goal's acceptance radius ``radius_m`` is 0 for the vehicle's default
(``[mission] arrival_radius_m``); :func:`goal_radius_m` is the one place that resolves it. Every other rule
(depth range, operating area, capacities, obstacle radius, a goal radius's bounds, feasibility) lives in one
place, :func:`onboard.core.mission.validate.check_mission`, which every door (mission files, MAVLink
uploads, persisted missions) runs with the configuration.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


class MissionError(ValueError):
    """An invalid mission; ``reason`` is a short machine-readable tag, the message is for humans."""

    def __init__(self, reason: str, message: str) -> None:
        super().__init__(message)
        self.reason = reason


def _is_finite_number(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


@dataclass(frozen=True)
class Goal:
    """A goal pose: position (m, NED), depth (m, positive down) and arrival yaw (rad), or None = free; and
    its acceptance radius ``radius_m`` (m; 0 = the vehicle's default, ``[mission] arrival_radius_m``: MAVLink
    NAV_WAYPOINT param2, the YAML ``radius_m``). Read the radius in force with :func:`goal_radius_m`."""

    x_m: float
    y_m: float
    depth_m: float
    yaw_rad: float | None
    radius_m: float = 0.0

    def invalid_fields(self) -> tuple[str, ...]:
        """The names of the fields that are not finite numbers (``yaw_rad`` may also be None)."""
        bad = [n for n in ("x_m", "y_m", "depth_m", "radius_m") if not _is_finite_number(getattr(self, n))]
        if self.yaw_rad is not None and not _is_finite_number(self.yaw_rad):
            bad.append("yaw_rad")
        return tuple(bad)

    def validate(self) -> None:
        """Raise :class:`MissionError` (reason ``"nan"``) if a field is not a finite number."""
        for name in self.invalid_fields():
            raise MissionError("nan", f"goal {name} is not a finite number: {getattr(self, name)!r}")


def goal_radius_m(goal: Goal, default_m: float) -> float:
    """The acceptance radius in force for ``goal`` (m): its own ``radius_m`` when it gives one (> 0), else
    ``default_m``, the vehicle's ``[mission] arrival_radius_m``. The one resolution: guidance's arrival,
    the executive's confirmation and the campaign's judgement all ask it."""
    return goal.radius_m if goal.radius_m > 0.0 else default_m


@dataclass(frozen=True)
class Obstacle:
    """An obstacle as the smallest circle that surrounds it (centre and radius in m, NED)."""

    x_m: float
    y_m: float
    radius_m: float

    def invalid_fields(self) -> tuple[str, ...]:
        """The names of the fields that are not finite numbers."""
        return tuple(n for n in ("x_m", "y_m", "radius_m") if not _is_finite_number(getattr(self, n)))

    def validate(self) -> None:
        """Raise :class:`MissionError` (reason ``"nan"``) if a field is not a finite number."""
        for name in self.invalid_fields():
            raise MissionError("nan", f"obstacle {name} is not a finite number: {getattr(self, name)!r}")


@dataclass(frozen=True)
class Mission:
    """An ordered list of goals and a set of obstacle circles. Immutable: replaced, never edited."""

    goals: tuple[Goal, ...]
    obstacles: tuple[Obstacle, ...] = ()

    def validate(self) -> None:
        """Raise :class:`MissionError` (reason ``"nan"``) naming the first goal or obstacle field that is
        not a finite number."""
        items: list[tuple[str, int, Goal | Obstacle]] = [("goal", i, g) for i, g in enumerate(self.goals)]
        items += [("obstacle", i, o) for i, o in enumerate(self.obstacles)]
        for kind, i, item in items:
            for name in item.invalid_fields():
                raise MissionError(
                    "nan", f"{kind} {i}: {name} is not a finite number: {getattr(item, name)!r}"
                )
