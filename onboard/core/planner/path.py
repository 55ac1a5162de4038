"""The planned path: an immutable sequence of straight and arc segments with a depth profile.

Frame and conventions (see ``onboard/protocol/conventions.py``): NED world frame, x north, y east,
metres; yaw in radians from north towards east (positive = clockwise seen from above), wrapped to (-pi, pi].
A right turn (starboard) has a positive yaw rate, so ``turn = +1`` is a right turn and ``turn = -1`` a left
turn.

Depth varies linearly with horizontal arc length from ``start_depth_m`` to ``end_depth_m``; the planner
guarantees the slope is within the vehicle's climb/dive limit. The path pitch is the flight-path angle:
diving (depth increasing) is nose down, a negative pitch.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from onboard.protocol.conventions import wrap_pi


@dataclass(frozen=True)
class PathSample:
    """The reference pose at arc length ``s_m`` along a path."""

    s_m: float
    x_m: float
    y_m: float
    yaw_rad: float
    curvature_1pm: float  # signed: + = right turn (yaw increasing), 1/m
    depth_m: float
    pitch_rad: float  # flight-path angle of the depth profile, + = nose up (climbing)


def _path_sample(
    s_m: float, x_m: float, y_m: float, yaw_rad: float, curvature_1pm: float, depth_m: float, pitch_rad: float
) -> PathSample:
    """``PathSample(...)`` without the frozen dataclass ``__init__``, which sets each field through
    ``object.__setattr__``: several times cheaper, and guidance samples the path a few times every tick."""
    sample = object.__new__(PathSample)
    sample.__dict__.update(
        s_m=s_m,
        x_m=x_m,
        y_m=y_m,
        yaw_rad=yaw_rad,
        curvature_1pm=curvature_1pm,
        depth_m=depth_m,
        pitch_rad=pitch_rad,
    )
    return sample


@dataclass(frozen=True)
class StraightSegment:
    """A straight line from (x0_m, y0_m) along ``yaw_rad`` for ``length_m``."""

    x0_m: float
    y0_m: float
    yaw_rad: float
    length_m: float

    kind = "S"

    def pose_at(self, s_m: float) -> tuple[float, float, float, float]:
        """Return (x_m, y_m, yaw_rad, curvature_1pm) at local arc length ``s_m``."""
        return (
            self.x0_m + s_m * math.cos(self.yaw_rad),
            self.y0_m + s_m * math.sin(self.yaw_rad),
            wrap_pi(self.yaw_rad),
            0.0,
        )


@dataclass(frozen=True)
class ArcSegment:
    """A circular arc around (center_x_m, center_y_m).

    ``turn`` is +1 for a right (clockwise, yaw increasing) turn and -1 for a left turn; the arc starts at
    heading ``start_yaw_rad`` and sweeps ``sweep_rad`` >= 0 of heading change.
    """

    center_x_m: float
    center_y_m: float
    radius_m: float
    turn: int
    start_yaw_rad: float
    sweep_rad: float

    @property
    def kind(self) -> str:
        return "R" if self.turn > 0 else "L"

    @property
    def length_m(self) -> float:
        return self.radius_m * self.sweep_rad

    def pose_at(self, s_m: float) -> tuple[float, float, float, float]:
        """Return (x_m, y_m, yaw_rad, curvature_1pm) at local arc length ``s_m``."""
        yaw = self.start_yaw_rad + self.turn * s_m / self.radius_m
        r = self.radius_m
        return (
            self.center_x_m + self.turn * r * math.sin(yaw),
            self.center_y_m - self.turn * r * math.cos(yaw),
            wrap_pi(yaw),
            self.turn / r,
        )


Segment = StraightSegment | ArcSegment


@dataclass(frozen=True)
class Path:
    """An immutable planned path. ``sample(s_m)`` clamps ``s_m`` to [0, length_m]."""

    segments: tuple[Segment, ...]
    start_depth_m: float = 0.0
    end_depth_m: float = 0.0
    virtual_goals: tuple[tuple[float, float], ...] = ()
    word: str = ""
    cost: float = 0.0
    # Start pose, used for a zero-length path (start == goal).
    start_pose: tuple[float, float, float] = (0.0, 0.0, 0.0)
    # What the operator should know of how it was planned ("" = nothing), e.g. a tighter turning radius.
    note: str = ""
    # Derived once (the path is immutable): cumulative arc lengths, the depth slope and path pitch, and the
    # end sample (guidance asks for it every tick).
    _cum_m: tuple[float, ...] = field(init=False, repr=False, compare=False)
    _depth_slope: float = field(init=False, repr=False, compare=False)
    _pitch_rad: float = field(init=False, repr=False, compare=False)
    _end: PathSample = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        cum = [0.0]
        for seg in self.segments:
            cum.append(cum[-1] + seg.length_m)
        object.__setattr__(self, "_cum_m", tuple(cum))
        length = cum[-1]
        slope = 0.0 if length <= 0.0 else (self.end_depth_m - self.start_depth_m) / length
        object.__setattr__(self, "_depth_slope", slope)
        object.__setattr__(self, "_pitch_rad", -math.atan(slope))
        object.__setattr__(self, "_end", self._sample(length))

    @property
    def length_m(self) -> float:
        return self._cum_m[-1]

    @property
    def depth_slope(self) -> float:
        """d(depth)/ds of the linear depth profile (dimensionless, + = diving)."""
        return self._depth_slope

    def sample(self, s_m: float) -> PathSample:
        """The reference at arc length ``s_m`` (m), clamped to the path."""
        if s_m >= self._cum_m[-1] > 0.0:  # (a zero-length path samples afresh: s_m = -0.0 keeps its sign)
            return self._end
        return self._sample(s_m)

    def _sample(self, s_m: float) -> PathSample:
        length = self._cum_m[-1]
        s = min(max(s_m, 0.0), length)
        depth = self.start_depth_m + self._depth_slope * s
        pitch = self._pitch_rad
        if not self.segments:
            x, y, yaw = self.start_pose
            return _path_sample(s, x, y, wrap_pi(yaw), 0.0, depth, pitch)
        i = bisect.bisect_right(self._cum_m, s) - 1
        i = min(max(i, 0), len(self.segments) - 1)
        seg = self.segments[i]
        x, y, yaw, kappa = seg.pose_at(s - self._cum_m[i])
        return _path_sample(s, x, y, yaw, kappa, depth, pitch)

    def segment_start_s(self, index: int) -> float:
        """Arc length (m) at which segment ``index`` starts."""
        return self._cum_m[index]

    @property
    def end_pose(self) -> tuple[float, float, float]:
        """(x_m, y_m, yaw_rad) at the end of the path."""
        p = self._end
        return (p.x_m, p.y_m, p.yaw_rad)


#: The spacing of a path drawn or logged as points (the flight log, the vehicle's path file).
POINT_STEP_M = 0.5


def sample_evenly(path: Path, step_m: float = POINT_STEP_M) -> list[PathSample]:
    """The path every ``step_m`` of arc length or closer (evenly spaced), both ends included; one sample
    for a path of zero length."""
    length = path.length_m
    n = math.ceil(length / step_m - 1e-9) if length > 0.0 else 0
    return [path.sample(length * i / n if n else 0.0) for i in range(n + 1)]


#: The most points :func:`departure_m` samples a path at (its distance table is their square).
DEPARTURE_SAMPLES = 1000


def _points(p: Path, step_m: float) -> npt.NDArray[np.float64]:
    """``p`` sampled every ``step_m`` (m), at most :data:`DEPARTURE_SAMPLES` points: (n, 2) x, y."""
    n = min(max(math.ceil(p.length_m / step_m), 1), DEPARTURE_SAMPLES)
    samples = [p.sample(p.length_m * k / n) for k in range(n + 1)]
    return np.array([(q.x_m, q.y_m) for q in samples])


def clearance_m(path: Path, circles: Sequence[tuple[float, float, float]], step_m: float = 0.25) -> float:
    """The closest (m) ``path`` comes to the edge of any circle ``(x_m, y_m, radius_m)`` (inf: none)."""
    if not circles:
        return math.inf
    pts, c = _points(path, step_m), np.array(circles, dtype=float)
    d = np.hypot(pts[:, None, 0] - c[None, :, 0], pts[:, None, 1] - c[None, :, 1]) - c[None, :, 2]
    return float(d.min())


def departure_m(path: Path, held: Path, step_m: float = 0.25) -> float:
    """The farthest (m) any point of ``path`` lies from ``held``, both sampled every ``step_m`` (m): how far
    a new path departs from the path flown (a re-plan for the current that departs far is not taken:
    :func:`onboard.core.plans.compute_plan`). At most :data:`DEPARTURE_SAMPLES` points a path (a longer
    path is sampled more coarsely)."""
    new, old = _points(path, step_m), _points(held, step_m)
    d = np.hypot(new[:, None, 0] - old[None, :, 0], new[:, None, 1] - old[None, :, 1])
    return float(d.min(axis=1).max())
