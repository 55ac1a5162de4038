"""The onboard configuration: one TOML file, one frozen dataclass per table.

Tables: [bus] (:class:`onboard.protocol.bus.BusConfig`), [loop] (:class:`onboard.app.loop.LoopConfig`),
[planner], [nav], [guidance], [control] (with [control.paper], [control.improved], [control.limits]),
[failsafe], [mavlink]. Every table is optional and every key has a default; unknown tables or
keys and out-of-range values stop start-up with one clear line (:class:`ConfigError`).
The default file is ``onboard/config/onboard.toml`` (the one the bench and the scenarios fly with).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from auv_common.config import ConfigError, from_table, load_toml
from onboard.adapters.mavlink.config import MavlinkConfig
from onboard.app.loop import LoopConfig
from onboard.core.config import CoreConfig
from onboard.core.control.pd import ControlParams
from onboard.core.guidance.guidance import GuidanceParams
from onboard.core.mission.params import MissionParams
from onboard.core.nav.estimator import NavParams
from onboard.core.planner.config import PlannerConfig
from onboard.core.safety.failsafe import FailsafeParams
from onboard.protocol.bus import BusConfig

DEFAULT_CONFIG_PATH = Path(__file__).parents[1] / "config" / "onboard.toml"


@dataclass(frozen=True)
class OnboardConfig:
    bus: BusConfig = field(default_factory=BusConfig)
    loop: LoopConfig = field(default_factory=LoopConfig)
    planner: PlannerConfig = field(default_factory=PlannerConfig)
    nav: NavParams = field(default_factory=NavParams)
    guidance: GuidanceParams = field(default_factory=GuidanceParams)
    control: ControlParams = field(default_factory=ControlParams)
    failsafe: FailsafeParams = field(default_factory=FailsafeParams)
    mission: MissionParams = field(default_factory=MissionParams)
    mavlink: MavlinkConfig = field(default_factory=MavlinkConfig)

    @property
    def core(self) -> CoreConfig:
        """The tables the pure core flies with."""
        return CoreConfig(self.planner, self.nav, self.guidance, self.control, self.failsafe, self.mission)


def config_from_dict(data: dict[str, Any], where: str) -> OnboardConfig:
    """Build the configuration from a parsed TOML document (``where`` names it in errors)."""
    return from_table(OnboardConfig, data, where)


def load_config(path: str | Path | None = None) -> OnboardConfig:
    """Read the onboard TOML (default: the packaged ``onboard.toml``)."""
    p = Path(path) if path is not None else DEFAULT_CONFIG_PATH
    return config_from_dict(load_toml(p), str(p))


__all__ = ["DEFAULT_CONFIG_PATH", "ConfigError", "OnboardConfig", "config_from_dict", "load_config"]
