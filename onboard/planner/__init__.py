"""Homing path planner (paper section 3): pure code, no bus, no clock.

Public API: :func:`plan`, :func:`candidates`, :class:`PlannerConfig`, :class:`PlannerError`, and the
:class:`Path` types.
"""

from onboard.planner.config import PlannerConfig
from onboard.planner.errors import REASONS, PlannerConfigError, PlannerError
from onboard.planner.path import ArcSegment, Path, PathSample, StraightSegment
from onboard.planner.planner import Candidate, candidates, inflate, plan

__all__ = [
    "REASONS",
    "ArcSegment",
    "Candidate",
    "Path",
    "PathSample",
    "PlannerConfig",
    "PlannerConfigError",
    "PlannerError",
    "StraightSegment",
    "candidates",
    "inflate",
    "plan",
]
