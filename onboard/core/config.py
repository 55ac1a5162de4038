"""The configuration of the pure core: the tables the autopilot flies with (no bus, loop or link)."""

from __future__ import annotations

from dataclasses import dataclass, field

from onboard.core.control.pd import ControlParams
from onboard.core.guidance.guidance import GuidanceParams
from onboard.core.mission.params import MissionParams
from onboard.core.nav.estimator import NavParams
from onboard.core.planner.config import PlannerConfig
from onboard.core.safety.failsafe import FailsafeParams


@dataclass(frozen=True)
class CoreConfig:
    """[planner], [nav], [guidance], [control], [failsafe], [mission] of ``onboard.toml``."""

    planner: PlannerConfig = field(default_factory=PlannerConfig)
    nav: NavParams = field(default_factory=NavParams)
    guidance: GuidanceParams = field(default_factory=GuidanceParams)
    control: ControlParams = field(default_factory=ControlParams)
    failsafe: FailsafeParams = field(default_factory=FailsafeParams)
    mission: MissionParams = field(default_factory=MissionParams)
