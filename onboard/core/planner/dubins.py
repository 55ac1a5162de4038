"""Obstacle-free Dubins words in the NED frame: the paper's tangent construction plus the CCC words.

Paper section 3: each pose gets two minimum-radius circles; the common tangents between a start circle and
a goal circle give the virtual goals. Of the paper's 16 tangent lines only 4 are flyable without reversing:
the outer tangent for two circles flown in the same sense (RSR, LSL) and the inner tangent for opposite
senses (RSL, LSR). Beyond the paper we add the CCC words (RLR, LRL), so that the set is complete and the
shortest word is the true Dubins optimum (Dubins 1957).

Letters are NED: ``R`` = right turn (yaw increasing, ``turn = +1``), ``L`` = left turn. A table in the usual
maths frame (x right, y up, counter-clockwise headings) gives the same lengths with L and R swapped.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from onboard.core.planner.errors import PlannerError
from onboard.core.planner.geometry import (
    TWO_PI,
    arc,
    circle_center,
    heading_on_circle,
    sweep,
    tangent,
)
from onboard.core.planner.path import Segment, StraightSegment

Pose = tuple[float, float, float]

CSC_WORDS = ("LSL", "RSR", "LSR", "RSL")
CCC_WORDS = ("RLR", "LRL")
ALL_WORDS = CSC_WORDS + CCC_WORDS


def _letter(turn: int) -> str:
    return "R" if turn > 0 else "L"


def _turn(letter: str) -> int:
    return 1 if letter == "R" else -1


@dataclass(frozen=True)
class DubinsWord:
    """One candidate word: its three pieces and the segments that fly them.

    ``sweeps_rad`` are the turn angles of the arcs (the middle entry is 0 for a CSC word) and
    ``straight_m`` the length of the straight part (0 for CCC). ``segments`` holds only the pieces of
    non-zero length, so a zero arc never appears (and never becomes a loop).
    """

    word: str
    radius_m: float
    sweeps_rad: tuple[float, float, float]
    straight_m: float
    segments: tuple[Segment, ...]

    @property
    def length_m(self) -> float:
        """Total horizontal length (m)."""
        return self.radius_m * sum(self.sweeps_rad) + self.straight_m


def _validate(start: Pose, goal: Pose, radius_m: float) -> None:
    if not (math.isfinite(radius_m) and radius_m > 0.0):
        raise PlannerError("radius", f"turning radius must be positive and finite, got {radius_m!r}")
    for name, pose in (("start", start), ("goal", goal)):
        if not all(math.isfinite(v) for v in pose):
            raise PlannerError("nan", f"{name} pose {pose!r} is not finite")


def csc(start: Pose, goal: Pose, radius_m: float, turn0: int, turn1: int) -> DubinsWord | None:
    """The word turn0-S-turn1 (e.g. ``+1, -1`` = RSL), or None when its tangent does not exist."""
    x0, y0, yaw0 = start
    x1, y1, yaw1 = goal
    r = radius_m
    c0 = circle_center(x0, y0, yaw0, r, turn0)
    c1 = circle_center(x1, y1, yaw1, r, turn1)
    word = f"{_letter(turn0)}S{_letter(turn1)}"
    tan = tangent(c0, r, turn0, c1, r, turn1)
    if tan is None:
        if turn0 == turn1 and math.hypot(c1[0] - c0[0], c1[1] - c0[1]) <= 1e-9 * (1.0 + r):
            # Both poses on one circle flown in one sense: a single arc, zero when the poses coincide.
            t = sweep(turn0 * (yaw1 - yaw0))
            segs: tuple[Segment, ...] = (arc(*c0, r, turn0, yaw0, t),) if t > 0.0 else ()
            return DubinsWord(word, r, (t, 0.0, 0.0), 0.0, segs)
        return None
    t = sweep(turn0 * (tan.yaw_rad - yaw0))
    q = sweep(turn1 * (yaw1 - tan.yaw_rad))
    pieces: list[Segment] = []
    if t > 0.0:
        pieces.append(arc(*c0, r, turn0, yaw0, t))
    if tan.length_m > 0.0:
        pieces.append(StraightSegment(tan.leave[0], tan.leave[1], tan.yaw_rad, tan.length_m))
    if q > 0.0:
        pieces.append(arc(*c1, r, turn1, tan.yaw_rad, q))
    return DubinsWord(word, r, (t, 0.0, q), tan.length_m, tuple(pieces))


def ccc(start: Pose, goal: Pose, radius_m: float, turn: int) -> DubinsWord | None:
    """The word turn-(-turn)-turn (``+1`` = RLR), or None when the end circles are more than 4r apart.

    The middle circle touches both end circles, so its centre is 2r from each; of the two such circles we
    take the one whose middle arc is >= pi, the branch the standard closed form returns (an optimal CCC
    word always has a middle arc longer than pi).
    """
    x0, y0, yaw0 = start
    x1, y1, yaw1 = goal
    r = radius_m
    c0 = circle_center(x0, y0, yaw0, r, turn)
    c2 = circle_center(x1, y1, yaw1, r, turn)
    dx, dy = c2[0] - c0[0], c2[1] - c0[1]
    d = math.hypot(dx, dy)
    word = _letter(turn) + _letter(-turn) + _letter(turn)
    tol = 1e-9 * (1.0 + r)
    if d > 4.0 * r + tol:
        return None
    if d <= tol:
        # Both end circles coincide: the middle circle touches them at one point and its arc shrinks to
        # zero (the standard closed form gives p = mod2pi(2*pi - acos(1)) = 0), leaving one arc on the end
        # circle. With no net heading change that arc is a full loop: the word is degenerate, and the CSC
        # single arc (zero for identical poses) is always at least as short, so this is never chosen.
        q = sweep(turn * (yaw1 - yaw0)) or TWO_PI
        return DubinsWord(word, r, (0.0, 0.0, q), 0.0, (arc(*c0, r, turn, yaw0, q),))
    base = math.atan2(dy, dx)
    half = math.acos(min(1.0, d / (4.0 * r)))
    best: tuple[float, float, float, float, float, tuple[float, float]] | None = None
    for side in (1.0, -1.0):
        ang = base + side * half
        c1 = (c0[0] + 2.0 * r * math.cos(ang), c0[1] + 2.0 * r * math.sin(ang))
        # The tangent points are the midpoints between touching centres.
        yaw_a = heading_on_circle(0.5 * (c0[0] + c1[0]), 0.5 * (c0[1] + c1[1]), c0[0], c0[1], turn)
        yaw_b = heading_on_circle(0.5 * (c1[0] + c2[0]), 0.5 * (c1[1] + c2[1]), c2[0], c2[1], turn)
        t = sweep(turn * (yaw_a - yaw0))
        p = (-turn * (yaw_b - yaw_a)) % TWO_PI
        q = sweep(turn * (yaw1 - yaw_b))
        if best is None or p > best[1]:
            best = (t, p, q, yaw_a, yaw_b, c1)
    assert best is not None
    t, p, q, yaw_a, yaw_b, c1 = best
    pieces: list[Segment] = []
    if t > 0.0:
        pieces.append(arc(*c0, r, turn, yaw0, t))
    if p > 0.0:
        pieces.append(arc(*c1, r, -turn, yaw_a, p))
    if q > 0.0:
        pieces.append(arc(*c2, r, turn, yaw_b, q))
    return DubinsWord(word, r, (t, p, q), 0.0, tuple(pieces))


def word(start: Pose, goal: Pose, radius_m: float, name: str) -> DubinsWord | None:
    """The Dubins word ``name`` (one of :data:`ALL_WORDS`, NED letters) from start to goal, or None.

    Poses are (x_m, y_m, yaw_rad) in NED. Raises :class:`PlannerError` for a bad radius or NaN.
    """
    _validate(start, goal, radius_m)
    if name in CSC_WORDS:
        return csc(start, goal, radius_m, _turn(name[0]), _turn(name[2]))
    if name in CCC_WORDS:
        return ccc(start, goal, radius_m, _turn(name[0]))
    raise ValueError(f"unknown Dubins word {name!r}")


def all_words(start: Pose, goal: Pose, radius_m: float, csc_only: bool = False) -> list[DubinsWord]:
    """Every existing word from start to goal (NED poses, m and rad), CSC first then CCC."""
    _validate(start, goal, radius_m)
    out: list[DubinsWord] = []
    for t0, t1 in ((-1, -1), (1, 1), (-1, 1), (1, -1)):
        w = csc(start, goal, radius_m, t0, t1)
        if w is not None:
            out.append(w)
    if not csc_only:
        for t in (1, -1):
            w = ccc(start, goal, radius_m, t)
            if w is not None:
                out.append(w)
    return out


def shortest(start: Pose, goal: Pose, radius_m: float, csc_only: bool = False) -> DubinsWord:
    """The shortest word (the Dubins optimum unless ``csc_only``). A CSC word always exists."""
    return min(all_words(start, goal, radius_m, csc_only), key=lambda w: w.length_m)


def arc_then_straight(
    start: Pose, point: tuple[float, float], radius_m: float, turn: int
) -> DubinsWord | None:
    """Turn on the start circle of sense ``turn``, then fly straight to ``point`` (free arrival heading).

    This is the shortest path to a point outside both start circles (Bui, Boissonnat, Soueres and Laumond
    1994); None when the point lies inside that circle.
    """
    x0, y0, yaw0 = start
    r = radius_m
    c0 = circle_center(x0, y0, yaw0, r, turn)
    tan = tangent(c0, r, turn, point, 0.0, 1)
    if tan is None:
        return None
    t = sweep(turn * (tan.yaw_rad - yaw0))
    pieces: list[Segment] = []
    if t > 0.0:
        pieces.append(arc(*c0, r, turn, yaw0, t))
    if tan.length_m > 0.0:
        pieces.append(StraightSegment(tan.leave[0], tan.leave[1], tan.yaw_rad, tan.length_m))
    return DubinsWord(f"{_letter(turn)}S", r, (t, 0.0, 0.0), tan.length_m, tuple(pieces))
