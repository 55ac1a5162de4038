"""Homing path planner (paper section 3): pure code, no bus, no clock.

Public API: :func:`plan`, :func:`candidates`, :class:`PlannerConfig`, :class:`PlannerError`, and the
:class:`Path` types.
"""

from onboard.core.planner.config import PlannerConfig
from onboard.core.planner.errors import REASONS, PlannerConfigError, PlannerError
from onboard.core.planner.path import ArcSegment, Path, PathSample, StraightSegment
from onboard.core.planner.planner import Candidate, candidates, inflate, plan

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
