"""Onboard guidance on the planned path: the paper's moving reference (track), LOS and integral LOS.

Public API: :class:`GuidanceParams` (``[guidance]``), :class:`GuidanceState`, :class:`GuidanceReference`,
:func:`step`, and the path-frame helpers :func:`path_frame`, :func:`project`, :func:`sample_extended`.
"""

from onboard.core.guidance.guidance import (
    GuidanceDebug,
    GuidanceMode,
    GuidanceParams,
    GuidanceReference,
    GuidanceState,
    step,
)
from onboard.core.guidance.path_frame import path_frame, project, sample_extended, yaw_error

__all__ = [
    "GuidanceDebug",
    "GuidanceMode",
    "GuidanceParams",
    "GuidanceReference",
    "GuidanceState",
    "path_frame",
    "project",
    "sample_extended",
    "step",
    "yaw_error",
]
