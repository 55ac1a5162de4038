"""Loiter: the ``loiter`` end action, circling the last goal at its depth, armed, until told otherwise.

The plan (:func:`onboard.core.plans.compute_plan`, kind ``loiter``) is a run-in onto a circle of ``[mission]
loiter_radius_m`` round the last goal (0: twice the turning radius), then the circle, drawn twice: the lap
flown and one lap of look-ahead for guidance's reference. The circle has no end: once the vehicle is a lap
and a half along it, guidance's memory is moved back by one lap (:func:`wrap_lap`), so the same circle is
evaluated modulo one lap for as long as the loiter lasts, and guidance's end-of-path arrival means nothing
here. If the circle cannot be planned (it cuts an obstacle) or its plan misses the deadline, the vehicle
stops and surfaces instead (:mod:`~onboard.core.executive.surface`), with the reason to the operator.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from dataclasses import dataclass

from onboard.core.commands import Severity
from onboard.core.executive.maneuver import Leg, Plans, Progress, Vehicle
from onboard.core.guidance.guidance import GuidanceState
from onboard.core.nav.types import NavState
from onboard.core.planner.path import ArcSegment, Path

log = logging.getLogger(__name__)


def lap_m(path: Path) -> float:
    """One lap of the loiter circle (m): the path's last segment is the circle."""
    circle = path.segments[-1]
    assert isinstance(circle, ArcSegment), "a loiter path ends on its circle"
    return 2.0 * math.pi * circle.radius_m


def wrap_lap(path: Path, state: GuidanceState) -> GuidanceState:
    """Guidance's memory on the loiter ``path`` with its arc lengths moved back by one lap once the vehicle
    is more than a lap and a half along the circle (the circle repeats: the same point, the same heading),
    and no arrival latched (a circle has no end)."""
    lap = lap_m(path)
    wrap_at = path.length_m - lap / 2.0  # run-in + 1.5 laps: the look-ahead is never less than half a lap
    s = state.s_proj_m
    if s is not None and s >= wrap_at:
        return dataclasses.replace(state, s_proj_m=s - lap, s_ref_m=state.s_ref_m - lap, arrived=False)
    if state.arrived:
        return dataclasses.replace(state, arrived=False)
    return state


@dataclass
class Loiter:
    """Circle the mission's last goal (``fell_back``: the circle was not possible, the vehicle surfaces)."""

    kind = "loiter"

    def start(self, ex: Plans, v: Vehicle) -> None:
        if ex.plan_waiting is None:
            ex.ask_plan(v, "loiter")

    def step(self, ex: Plans, v: Vehicle, nav: NavState, dt_s: float) -> Leg | None:
        if ex.path is None or ex.path_kind != "loiter":
            self.start(ex, v)
            return None
        ex.guidance_state = wrap_lap(ex.path, ex.guidance_state)
        return ex.follow(v, nav, dt_s)

    def plan_failed(self, ex: Plans, v: Vehicle, why: str, late: bool) -> None:
        text = f"{why}: surfacing" if late else f"loiter not possible ({why}): surfacing"
        log.warning("%s", text)
        v.note(Severity.WARNING, text)
        ex.path, ex.path_kind = None, "surface"  # the executive hands over to Surface
        ex.begin_stop(v)  # which stops the vehicle first

    def done(self, v: Vehicle) -> bool:
        return False  # until a command ends it (disarm, abort, a new mission)

    def progress(self, ex: Plans, v: Vehicle) -> Progress:
        laps = 0.0
        if ex.path is not None and ex.path_kind == "loiter" and ex.guidance_state.s_proj_m is not None:
            lap = lap_m(ex.path)
            laps = max(0.0, ex.guidance_state.s_proj_m - (ex.path.length_m - 2.0 * lap)) / lap
        return Progress(f"loitering round goal {len(v.mission.goals) - 1} ({laps:.1f} of a lap)", math.nan)
