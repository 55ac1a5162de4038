"""The configuration of the pure core: the tables the autopilot flies with (no bus, loop or link)."""

from __future__ import annotations

from dataclasses import dataclass, field

from onboard.core.control.pd import ControlParams
from onboard.core.guidance.guidance import GuidanceParams
from onboard.core.mission.params import MissionParams
from onboard.core.nav.estimator import NavParams
from onboard.core.planner.config import PlannerConfig
from onboard.core.safety.diagnosis import DiagnosisParams
from onboard.core.safety.failsafe import FailsafeParams


@dataclass(frozen=True)
class CoreConfig:
    """[planner], [nav], [guidance], [control], [failsafe], [mission], [diagnosis] of ``onboard.toml``."""

    planner: PlannerConfig = field(default_factory=PlannerConfig)
    nav: NavParams = field(default_factory=NavParams)
    guidance: GuidanceParams = field(default_factory=GuidanceParams)
    control: ControlParams = field(default_factory=ControlParams)
    failsafe: FailsafeParams = field(default_factory=FailsafeParams)
    mission: MissionParams = field(default_factory=MissionParams)
    diagnosis: DiagnosisParams = field(default_factory=DiagnosisParams)

    def __post_init__(self) -> None:
        # One staleness timeout: the estimator marks attitude and depth stale after the operator's
        # FS_NAV_TMO_S (a SetParam rebuilds this configuration with dataclasses.replace, so it follows).
        nav = self.nav.with_stale_after(self.failsafe.nav_timeout_s)
        if nav is not self.nav:
            object.__setattr__(self, "nav", nav)
        # One arrival distance: guidance's path is done within the mission's MIS_ARRIVE_R_M of its end.
        guidance = self.guidance.with_arrival_radius(self.mission.arrival_radius_m)
        if guidance is not self.guidance:
            object.__setattr__(self, "guidance", guidance)
