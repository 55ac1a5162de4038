"""``auv-onboard run``: start-up, the bus, the loop, the MAVLink endpoint, clean shutdown.

Start-up validates everything first (configuration, mission file) and exits with one clear line (code 2) on
a bad one; then waits for the bus (one log line every few seconds) and runs until SIGINT/SIGTERM.
"""

from __future__ import annotations

import argparse
import json
import logging
import signal
import sys
import threading
import time
import tomllib
from pathlib import Path
from typing import Any

import can

from auv_common.config import ConfigError, load_toml
from onboard.app.config import DEFAULT_CONFIG_PATH, OnboardConfig, config_from_dict
from onboard.app.loop import ControlLoop
from onboard.app.mission_file import load_mission
from onboard.core.autopilot import Autopilot, StepOutput
from onboard.core.mission.model import Mission, MissionError
from onboard.protocol.bus import BusUnavailable, open_bus
from onboard.protocol.codec import Codec
from onboard.protocol.messages import (
    AhrsAttitude,
    AhrsRates,
    DepthMeas,
    DvlVelocity,
    FinStatus,
    PositionFix,
    PropStatus,
    Sync,
)
from onboard.protocol.port import BusPort

log = logging.getLogger("onboard")

LISTEN = (AhrsAttitude, AhrsRates, DepthMeas, DvlVelocity, PositionFix, FinStatus, PropStatus, Sync)


def _apply_overrides(data: dict[str, Any], sets: list[str]) -> dict[str, Any]:
    """Apply ``--set table.key=VALUE`` (VALUE in TOML syntax, e.g. 0.5, "paper", [1, 2])."""
    for item in sets:
        key, sep, raw = item.partition("=")
        if not sep or "." not in key:
            raise ConfigError(f"--set {item!r}: expected TABLE.KEY=VALUE")
        try:
            value = tomllib.loads(f"v = {raw}")["v"]
        except tomllib.TOMLDecodeError:
            value = raw  # a bare word is a string
        *tables, leaf = key.split(".")
        node = data
        for t in tables:
            node = node.setdefault(t, {})
            if not isinstance(node, dict):
                raise ConfigError(f"--set {item!r}: {t} is not a table")
        node[leaf] = value
    return data


def build_config(path: str | None, sets: list[str]) -> OnboardConfig:
    p = Path(path) if path else DEFAULT_CONFIG_PATH
    return config_from_dict(_apply_overrides(load_toml(p), sets), str(p))


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="auv-onboard run",
        description=(
            "Run the onboard control loop. Reads sensor and actuator-status frames (and SYNC in lock-step) "
            "from the CAN bus; sends FIN_CMD + PROP_CMD every tick (default 20 Hz), SYNC_ACK per SYNC in "
            "lock-step and ONBOARD_HEARTBEAT at 1 Hz and on every mission-state change; serves MAVLink 2 "
            "(HEARTBEAT 1 Hz, telemetry at the [mavlink] rates) to the ground stations."
        ),
    )
    parser.add_argument("--config", help=f"onboard TOML (default {DEFAULT_CONFIG_PATH})")
    parser.add_argument("--mission", help="YAML mission file loaded at start (wins over a persisted one)")
    parser.add_argument("--autostart", action="store_true", help="arm and start the mission at once")
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="TABLE.KEY=VALUE",
        help="override one configuration key (TOML value), e.g. --set control.profile=paper",
    )
    parser.add_argument("--state-dir", help="MAVLink state directory (missions, parameters)")
    parser.add_argument("--no-mavlink", action="store_true", help="run without the MAVLink endpoint")
    parser.add_argument("--summary-json", help="write the loop's counters to this file at exit")
    parser.add_argument("--log-level", default="INFO", help="logging level (default INFO)")
    return parser


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    logging.basicConfig(
        level=getattr(logging, str(args.log_level).upper(), logging.INFO),
        format="%(asctime)s %(levelname)s %(name)s: %(message)s",
    )
    try:
        sets = list(args.set)
        if args.state_dir:
            sets.append(f"mavlink.state_dir={args.state_dir!r}".replace("'", '"'))
        cfg = build_config(args.config, sets)
        mission = load_mission(args.mission) if args.mission else None
    except (ConfigError, MissionError) as exc:
        print(f"auv-onboard: {exc}", file=sys.stderr)
        return 2

    stop = threading.Event()

    def _stop(signum: int, _frame: Any) -> None:
        log.info("signal %d: stopping", signum)
        stop.set()

    signal.signal(signal.SIGINT, _stop)
    signal.signal(signal.SIGTERM, _stop)
    try:
        return run(
            cfg, mission, args.autostart, stop, mavlink_on=not args.no_mavlink, summary_json=args.summary_json
        )
    except (ConfigError, BusUnavailable) as exc:
        print(f"auv-onboard: {exc}", file=sys.stderr)
        return 2 if isinstance(exc, ConfigError) else 1


def run(
    cfg: OnboardConfig,
    mission: Mission | None,
    autostart: bool,
    stop: threading.Event,
    mavlink_on: bool = True,
    summary_json: str | None = None,
) -> int:
    """Open the bus, build the loop and run it until ``stop`` is set."""
    autopilot = Autopilot(cfg.core)
    link = _start_link(autopilot, cfg.mavlink, mission) if mavlink_on and cfg.mavlink.enabled else None
    if link is not None:
        mission = link.mission() if mission is None else mission
    if mission is not None and mission.goals:
        autopilot.replace_mission(mission)
        log.info("mission: %d goals, %d obstacles", len(mission.goals), len(mission.obstacles))
    if autostart:
        autopilot.request_autostart()
    try:
        bus = open_bus(cfg.bus, stop=stop)
    except BusUnavailable:
        if link is not None:
            link.stop()
        if stop.is_set():
            return 0
        raise
    lockstep = cfg.loop.time_source == "lockstep"
    codec = Codec()
    clock = time.monotonic
    port = BusPort(bus, clock, [codec.frame_id(c) for c in LISTEN], codec, record=cfg.bus.record or None)
    loop = ControlLoop(port, autopilot, cfg.loop)
    if link is not None:
        loop.on_tick = _link_bridge(autopilot, link, loop.stats)
    log.info(
        "onboard loop: %s at %.0f Hz on %s %s",
        "lock-step" if lockstep else "real time",
        cfg.loop.rate_hz,
        cfg.bus.interface,
        cfg.bus.channel,
    )
    code = 0
    try:
        if lockstep:
            loop.run_lockstep(stop)
        else:
            loop.run_realtime(stop)
    except (OSError, can.CanError) as exc:  # the bus went away (hub stopped, interface down)
        log.error("bus lost: %s: %s", type(exc).__name__, exc)
        code = 1
    except Exception as exc:
        if type(exc).__name__ != "WebsocketClosed":  # python-can-remote's "hub went away"
            log.exception("onboard loop stopped by an unexpected error")
        else:
            log.error("bus lost: the bench hub closed the connection")
        code = 1
    finally:
        loop.close()
        port.close()
        if link is not None:
            link.stop()
        log.info(
            "onboard stopped: %d ticks, %d overruns, %d frames rejected %s",
            loop.stats.ticks,
            loop.stats.overruns,
            port.receiver.rejected_total,
            dict(port.receiver.rejected),
        )
        if summary_json:
            Path(summary_json).write_text(json.dumps(_summary(loop, autopilot), indent=2))
    return code


def _summary(loop: ControlLoop, autopilot: Autopilot) -> dict[str, Any]:
    compute = sorted(loop.stats.compute_s)
    late = sorted(loop.stats.lateness_s)

    def pct(values: list[float], q: float) -> float:
        return values[min(len(values) - 1, int(q * len(values)))] * 1e6 if values else float("nan")

    return {
        "ticks": loop.stats.ticks,
        "overruns": loop.stats.overruns,
        "missed_deadlines": loop.stats.missed_deadlines,
        "encode_errors": loop.stats.encode_errors,
        "frames_rejected": dict(loop.port.receiver.rejected),
        "tick_compute_p50_us": pct(compute, 0.5),
        "tick_compute_p99_us": pct(compute, 0.99),
        "lateness_p50_us": pct(late, 0.5),
        "lateness_p99_us": pct(late, 0.99),
        "final_state": autopilot.status.state.name,
        "goals_reached": autopilot.goals_reached,
        "fixes_rejected": autopilot.nav_state.fixes_rejected,
    }


def _start_link(autopilot: Autopilot, mavlink_cfg: Any, mission: Mission | None) -> Any:
    from onboard.adapters.mavlink import bridge as link_bridge
    from onboard.adapters.mavlink.endpoint import VehicleLink

    link = VehicleLink(mavlink_cfg, params=link_bridge.param_specs(autopilot), initial_mission=mission)
    link.start()
    return link


def _link_bridge(autopilot: Autopilot, link: Any, loop_stats: Any) -> Any:
    """The per-tick exchange with the MAVLink endpoint: events in, a snapshot out (both cheap)."""
    from onboard.adapters.mavlink import bridge as link_bridge

    def on_tick(out: StepOutput, now_s: float) -> None:
        for event in link.take_events():
            link_bridge.apply_event(autopilot, event)
        link.publish(link_bridge.snapshot(autopilot, out, now_s, loop_stats.overruns))

    return on_tick
