"""A vehicle-side process: the real onboard core and MAVLink link over a simple plant (tests, benches).

``python -m onboard.app.standalone --endpoint udpin:127.0.0.1:0 --state-dir DIR [--time-scale K]`` (DIR: the
state store's directory, ``[store] dir``) prints
one JSON line ``{"ports": [...], "pid": N}`` on stdout once the sockets are bound, then runs until SIGTERM /
SIGINT.

:class:`SimpleVehicle` is the onboard program without the CAN bus: the real
:class:`~onboard.core.autopilot.Autopilot` (its whole step: navigation filter, failsafes, arrival, guidance,
PD, the end of a mission; every command and upload judged by ``Autopilot.handle`` through the bridge; plans
from the planning worker) flies :class:`SimplePlant`, a kinematic point that answers the actuator commands
with sensor messages. The plant is no model of the vehicle (that is ``hil_sim``): speed follows the
propeller through the speed map with a 1 s lag, yaw rate is speed times the rudder's curvature, depth rate is
speed times the stern. Simulated time runs ``time_scale`` times faster than the wall clock (lock-step
inside the process: the plan of a tick is awaited, so a run repeats exactly). The configuration is the
packaged ``onboard.toml`` (``--config`` may give other ``[mavlink]`` and ``[store]`` tables) with the
persisted ground-station edits of the state store, resolved and in force before the link exists, by the one
boot path of ``auv-onboard run`` (:func:`onboard.app.runtime.resolve_boot`, ``build_link``).
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import json
import math
import os
import signal
import sys
import threading
import time
from dataclasses import dataclass
from typing import Any

from auv_common.config import ConfigError, from_table, load_toml
from onboard.adapters.mavlink import bridge
from onboard.adapters.mavlink.config import MavlinkConfig
from onboard.adapters.mavlink.endpoint import VehicleLink
from onboard.app.config import load_config
from onboard.app.loop import LoopStats
from onboard.app.planning import PlanWorker
from onboard.app.runtime import build_link, mission_validator, resolve_boot
from onboard.app.store import StateStore, StoreConfig
from onboard.core import commands as core
from onboard.core.autopilot import Autopilot
from onboard.core.config import CoreConfig
from onboard.core.control.actuators import ActuatorCommand
from onboard.core.mission.model import Mission
from onboard.core.mission.validate import check_mission
from onboard.core.params import BusLimits, ParamSpec, param_table
from onboard.protocol import messages as m


def bus_limits() -> BusLimits:
    """The DBC's command ranges (read with cantools)."""
    from onboard.protocol.codec import command_ranges

    return BusLimits.from_ranges(command_ranges())


def default_core() -> CoreConfig:
    """The core tables of the packaged ``onboard.toml`` (what the vehicle flies with)."""
    return load_config().core


def default_params(config: CoreConfig) -> tuple[ParamSpec, ...]:
    """The parameter table of ``config`` bounded by the DBC's command ranges."""
    return param_table(config, bus_limits())


def make_link(
    config: MavlinkConfig,
    core_config: CoreConfig | None = None,
    autopilot: Autopilot | None = None,
    *,
    store: StateStore,
    **kw: Any,
) -> VehicleLink:
    """A link alone (tests) on ``store``: the one validator (bound to the autopilot's configuration when
    given) and the parameter table of the configuration; the persisted edits go to the core as requests, and
    the link answers no PARAM_* or mission request until the loop has judged them all. A vehicle is
    :func:`build`."""
    cc = core_config or (autopilot.config if autopilot is not None else default_core())
    validator = (
        mission_validator(autopilot, config.validate_timeout_s)
        if autopilot is not None
        else functools.partial(check_mission, config=cc)
    )
    return VehicleLink(config, validator=validator, params=default_params(cc), store=store, **kw)


@dataclass
class SimplePlant:
    """A kinematic point at depth: x, y, depth (m, NED), yaw (rad), speed u (m/s)."""

    x_m: float = 0.0
    y_m: float = 0.0
    depth_m: float = 0.0  # at the surface, at the origin
    yaw_rad: float = 0.0
    u_mps: float = 0.0
    speed_per_rps: float = 1.5375 / 25.0  # the straight-run speed map of onboard.toml
    rudder_per_curvature_radm: float = 0.68
    lag_s: float = 1.0

    def advance(self, cmd: ActuatorCommand, dt_s: float) -> tuple[float, float]:
        """Move for ``dt_s`` under ``cmd``; returns (yaw rate, depth rate)."""
        target = max(cmd.propeller_rps, 0.0) * self.speed_per_rps
        self.u_mps += (target - self.u_mps) * min(dt_s / self.lag_s, 1.0)
        r = -self.u_mps * cmd.rudder_rad / self.rudder_per_curvature_radm  # + rudder turns to port
        w = self.u_mps * cmd.stern_rad  # + stern: nose down, deeper
        if self.u_mps < 0.05 and self.depth_m > 0.0:
            w = -0.1  # positively buoyant: floats up when stopped
        self.yaw_rad = math.atan2(math.sin(self.yaw_rad + r * dt_s), math.cos(self.yaw_rad + r * dt_s))
        self.x_m += self.u_mps * math.cos(self.yaw_rad) * dt_s
        self.y_m += self.u_mps * math.sin(self.yaw_rad) * dt_s
        self.depth_m = max(0.0, self.depth_m + w * dt_s)
        return r, w

    def sensors(self, t_s: float, r_radps: float, w_mps: float) -> dict[type, Any]:
        pitch = -math.atan2(w_mps, self.u_mps) if self.u_mps > 0.05 else 0.0
        msgs = [
            m.AhrsAttitude(0.0, pitch, self.yaw_rad, t_s),
            m.AhrsRates(0.0, 0.0, r_radps, t_s),
            m.DepthMeas(self.depth_m, t_s),
            m.DvlVelocity(self.u_mps, 0.0, 0.0, True, t_s),
            m.PositionFix(self.x_m, self.y_m, t_s),
        ]
        return {type(msg): msg for msg in msgs}


class SimpleVehicle:
    """The real core, the link and :class:`SimplePlant`, ticking at the configured rate, ``time_scale``
    times faster than the wall clock."""

    def __init__(self, link: VehicleLink, autopilot: Autopilot, rate_hz: float = 20.0) -> None:
        self.link = link
        self.ap = autopilot
        self.plant = SimplePlant()
        self.period_s = 1.0 / rate_hz
        self.plans = PlanWorker(autopilot, lockstep=True)
        self.t_s = 0.0
        self.stats = LoopStats()  # the overrun count and the load, accounted as the control loop does
        self._r = self._w = 0.0
        mission = link.mission()
        if mission.goals or mission.obstacles:
            autopilot.handle(core.ReplaceMission(mission, True, "stored mission"))
            progress = link.progress()
            if progress is not None:
                autopilot.restore_progress(progress)
            autopilot.take_notes()

    def tick(self, period_s: float | None = None) -> None:
        """One tick of simulated ``period_s`` (s); ``period_s``: the wall time it may take (default: the
        simulated period), which the load is the busy share of."""
        t_busy = time.perf_counter()
        ap, dt = self.ap, self.period_s
        cache = self.plant.sensors(self.t_s, self._r, self._w)
        bridge.before_tick(ap, self.link)
        ap.before_step()
        self.plans.before_step()
        out = ap.step(cache, self.t_s, dt)
        self.plans.after_step()
        bridge.after_tick(ap, self.link, out, self.t_s, self.stats.overruns, self.stats.load)
        self._r, self._w = self.plant.advance(out.command, dt)
        self.t_s += dt
        self.stats.ticks += 1
        self.stats.note_busy(time.perf_counter() - t_busy, period_s or dt)

    def run(self, stop: threading.Event, time_scale: float = 1.0) -> None:
        wall_period = self.period_s / time_scale
        nxt = time.monotonic()
        try:
            while not stop.is_set():
                self.tick(wall_period)
                nxt += wall_period
                end_s = time.monotonic()
                if self.stats.end_tick(end_s, nxt) > 0.0:
                    nxt = end_s  # behind: the schedule starts again from now
                else:
                    stop.wait(nxt - end_s)
        finally:
            self.plans.close()


def build(
    config: MavlinkConfig,
    rate_hz: float = 20.0,
    *,
    store: StateStore | None = None,
    initial_mission: Mission | None = None,
    **link_kw: Any,
) -> SimpleVehicle:
    """The link and the vehicle for ``config``: the packaged configuration with the persisted edits of
    ``store`` (default: the one of the packaged ``[store]`` table) in force in the core before the link
    exists (the boot path of ``auv-onboard run``)."""
    store = store if store is not None else StateStore.of(load_config().store)
    store.open()
    boot = resolve_boot(dataclasses.replace(load_config(), mavlink=config), [], store)
    ap = Autopilot(boot.config.core, bus_limits=boot.bus_limits)
    link = build_link(ap, boot, store, initial_mission, **link_kw)
    return SimpleVehicle(link, ap, rate_hz)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m onboard.app.standalone", description=__doc__)
    ap.add_argument("--config", help="TOML file with [mavlink] and [store] tables")
    ap.add_argument("--endpoint", action="append", help="endpoint spec (repeatable), overrides the config")
    ap.add_argument("--state-dir", help="the state store's directory (overrides [store] dir)")
    ap.add_argument("--signing-key", help="signing key file (overrides the config)")
    ap.add_argument("--time-scale", type=float, default=1.0, help="simulated time per wall second")
    ap.add_argument("--rate-hz", type=float, default=20.0)
    args = ap.parse_args(argv)
    try:
        data = load_toml(args.config) if args.config else {}
        table = data.get("mavlink", {})
        if args.endpoint:
            table["endpoints"] = args.endpoint
        if args.signing_key:
            table["signing_key_file"] = args.signing_key
        config = MavlinkConfig.from_table(table)
        store_table = data.get("store", {})
        if args.state_dir:
            store_table["dir"] = args.state_dir
        store = StateStore.of(from_table(StoreConfig, store_table, f"{args.config or 'options'} [store]"))
    except ConfigError as exc:
        sys.stderr.write(f"error: {exc}\n")
        return 2
    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    vehicle = build(config, args.rate_hz, store=store)
    vehicle.link.start()
    try:
        sys.stdout.write(json.dumps({"ports": vehicle.link.ports, "pid": os.getpid()}) + "\n")
        sys.stdout.flush()
        vehicle.run(stop, args.time_scale)
    finally:
        vehicle.link.stop()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
