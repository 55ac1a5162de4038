"""The onboard configuration: one TOML file, one frozen dataclass per table.

Tables: [bus] (:class:`onboard.protocol.bus.BusConfig`), [loop] (:class:`onboard.app.loop.LoopConfig`),
[planner], [nav], [guidance], [control] (with [control.paper], [control.improved], [control.limits]),
[failsafe], [mission], [mavlink], [store] (:class:`onboard.app.store.StoreConfig`), [log]
(:class:`onboard.app.flight_log.LogConfig`). Every table is
optional and every key has a default; unknown tables or keys and out-of-range values stop start-up with one
clear line (:class:`ConfigError`).
The default file is ``onboard/config/onboard.toml`` (the one the bench and the scenarios fly with).
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

from auv_common.config import ConfigError, from_table, load_toml
from onboard.adapters.mavlink.config import MavlinkConfig
from onboard.app.flight_log import LogConfig
from onboard.app.loop import LoopConfig
from onboard.app.store import StoreConfig
from onboard.core.config import CoreConfig
from onboard.protocol.bus import BusConfig

DEFAULT_CONFIG_PATH = Path(__file__).parents[1] / "config" / "onboard.toml"


@dataclass(frozen=True)
class OnboardConfig(CoreConfig):
    """The core's tables (:class:`~onboard.core.config.CoreConfig`) and the program's: bus, loop, MAVLink,
    the state store, the flight log."""

    bus: BusConfig = field(default_factory=BusConfig)
    loop: LoopConfig = field(default_factory=LoopConfig)
    mavlink: MavlinkConfig = field(default_factory=MavlinkConfig)
    store: StoreConfig = field(default_factory=StoreConfig)
    log: LogConfig = field(default_factory=LogConfig)

    @property
    def core(self) -> CoreConfig:
        """The tables the pure core flies with (nothing of the bus, the loop or the link)."""
        return CoreConfig(**{f.name: getattr(self, f.name) for f in fields(CoreConfig)})


def config_from_dict(data: dict[str, Any], where: str) -> OnboardConfig:
    """Build the configuration from a parsed TOML document (``where`` names it in errors)."""
    return from_table(OnboardConfig, data, where)


def load_config(path: str | Path | None = None) -> OnboardConfig:
    """Read the onboard TOML (default: the packaged ``onboard.toml``)."""
    p = Path(path) if path is not None else DEFAULT_CONFIG_PATH
    return config_from_dict(load_toml(p), str(p))


__all__ = ["DEFAULT_CONFIG_PATH", "ConfigError", "OnboardConfig", "config_from_dict", "load_config"]
