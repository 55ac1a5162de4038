"""Mission data: 3-D goal poses and obstacle circles, in SI units and radians (NED frame)."""

from __future__ import annotations

import math
from dataclasses import dataclass


class MissionError(ValueError):
    """An invalid mission; ``reason`` is a short machine-readable tag, the message is for humans."""

    def __init__(self, reason: str, message: str) -> None:
        super().__init__(message)
        self.reason = reason


@dataclass(frozen=True)
class Goal:
    """A goal pose: position (m, NED), depth (m, positive down) and arrival yaw (rad), or None = free."""

    x_m: float
    y_m: float
    depth_m: float
    yaw_rad: float | None

    def validate(self) -> None:
        for name in ("x_m", "y_m", "depth_m"):
            if not math.isfinite(getattr(self, name)):
                raise MissionError("nan", f"goal {name} is not finite: {getattr(self, name)!r}")
        if self.yaw_rad is not None and not math.isfinite(self.yaw_rad):
            raise MissionError("nan", f"goal yaw_rad is not finite: {self.yaw_rad!r}")
        if self.depth_m < 0.0:
            raise MissionError("depth", f"goal depth {self.depth_m} m is above the surface")


@dataclass(frozen=True)
class Obstacle:
    """An obstacle as the smallest circle that surrounds it (centre and radius in m, NED)."""

    x_m: float
    y_m: float
    radius_m: float

    def validate(self) -> None:
        for name in ("x_m", "y_m", "radius_m"):
            if not math.isfinite(getattr(self, name)):
                raise MissionError("nan", f"obstacle {name} is not finite: {getattr(self, name)!r}")
        if self.radius_m <= 0.0:
            raise MissionError("radius", f"obstacle radius {self.radius_m} m must be positive")


@dataclass(frozen=True)
class Mission:
    """An ordered list of goals and a set of obstacle circles. Immutable: replaced, never edited."""

    goals: tuple[Goal, ...]
    obstacles: tuple[Obstacle, ...] = ()

    def validate(self) -> None:
        for g in self.goals:
            g.validate()
        for o in self.obstacles:
            o.validate()
