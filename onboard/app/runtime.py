"""``auv-onboard run``: start-up, the state store, the bus, the loop, the MAVLink endpoint, clean shutdown.

Start-up validates everything first (configuration, mission file) and exits with one clear line (code 2) on
a bad one; then waits for the bus (one log line every few seconds) and runs until SIGINT/SIGTERM.

The state store (``[store]``, :mod:`onboard.app.store`) is the vehicle's, opened with or without MAVLink:
the persisted parameter edits apply at boot (:func:`resolve_boot`), the mission progress is kept (by the
link's mission service, or without MAVLink by :func:`_keep_progress` each tick) and restored, the flight
logs default to ``<store.dir>/logs``, and a directory that cannot be written is said in the log.
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime as dt
import json
import logging
import signal
import sys
import threading
import time
import tomllib
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from auv_common.config import ConfigError, load_toml
from onboard.app.config import DEFAULT_CONFIG_PATH, OnboardConfig, config_from_dict
from onboard.app.flight_log import FlightLog, LoggedLink, open_flight_log, run_metadata
from onboard.app.loop import ControlLoop
from onboard.app.mission_file import load_mission
from onboard.app.store import StateStore
from onboard.core.autopilot import Autopilot
from onboard.core.config import CoreConfig
from onboard.core.mission.model import Mission, MissionError
from onboard.core.mission.validate import MissionCheck, check_mission
from onboard.core.params import (
    PARAM_NAMES,
    BusLimits,
    ParamError,
    apply_param,
    check_against_bus,
    float32,
    param_path,
    param_table,
    param_value,
)
from onboard.protocol.bus import BusUnavailable, open_bus
from onboard.protocol.codec import Codec, command_ranges
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
#: What the loop calls after each tick: (the tick's output, the loop's time).
TickHook = Callable[[Any, float], None]

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
    """The configuration of the file (default: the packaged ``onboard.toml``) with the ``--set`` overrides,
    without the persisted ground-station edits (those are :func:`resolve_config`'s)."""
    p = Path(path) if path else DEFAULT_CONFIG_PATH
    return config_from_dict(_apply_overrides(load_toml(p), sets), str(p))


def bus_limits_from_dbc() -> BusLimits:
    """The command-signal ranges of the DBC (FIN_CMD, PROP_CMD) the core's limits must stay within."""
    return BusLimits.from_ranges(command_ranges())


@dataclass(frozen=True)
class BootConfig:
    """The configuration resolved at start-up (:func:`resolve_config`).

    - ``config``: what the vehicle flies with: packaged defaults < file < persisted edits < ``--set``.
    - ``configured``: the file with ``--set`` but without the persisted edits: the parameter table's
      defaults (``param_table(configured.core, bus_limits)``), the values a ground-station edit is compared
      with (``is_default``) to decide whether it is persisted.
    - ``persisted``: the persisted values applied, by parameter name; ``dropped``: those refused, name ->
      reason (never applied; the store may forget them).
    - ``log_lines``: one line per value away from the packaged default, with its source (``file``,
      ``persisted``, ``--set``), then one per persisted value dropped or overridden.
    """

    config: OnboardConfig
    configured: OnboardConfig
    bus_limits: BusLimits
    persisted: dict[str, float]
    dropped: dict[str, str]
    log_lines: tuple[str, ...]


def _set_keys(sets: list[str]) -> tuple[str, ...]:
    return tuple(item.partition("=")[0].strip() for item in sets)


def _covered(path: str, keys: tuple[str, ...]) -> bool:
    """True if a ``--set`` key sets ``path`` (the key itself or a table above it)."""
    return any(path == k or path.startswith(k + ".") for k in keys)


def _with_core(cfg: OnboardConfig, core: CoreConfig) -> OnboardConfig:
    return dataclasses.replace(cfg, **{f.name: getattr(core, f.name) for f in dataclasses.fields(core)})


def _leaves(node: Any, prefix: str = "") -> list[tuple[str, Any]]:
    """(dotted key, value) of every configuration key (derived fields left out)."""
    out: list[tuple[str, Any]] = []
    for f in dataclasses.fields(node):
        if not f.init:
            continue
        value = getattr(node, f.name)
        key = f"{prefix}{f.name}"
        if dataclasses.is_dataclass(value) and not isinstance(value, type):
            out.extend(_leaves(value, key + "."))
        else:
            out.append((key, value))
    return out


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, float) and isinstance(b, int | float) and not isinstance(b, bool):
        return float32(a) == float32(float(b))
    return bool(a == b)


def resolve_config(
    config_path: str | None,
    sets: list[str],
    persisted: Mapping[str, float],
    bus_limits: BusLimits | None = None,
) -> BootConfig:
    """The start-up configuration: packaged defaults < the config file < ``persisted`` ground-station
    edits (by parameter name, each applied with :func:`onboard.core.params.apply_param`; one that is
    refused is reported and dropped, never applied) < ``--set``.

    Raises ``ConfigError`` (one line) for a bad file or ``--set``, or a configured limit beyond the DBC.
    """
    return resolve_built(build_config(config_path, sets), sets, persisted, bus_limits)


def resolve_built(
    configured: OnboardConfig,
    sets: list[str],
    persisted: Mapping[str, float],
    bus_limits: BusLimits | None = None,
) -> BootConfig:
    """:func:`resolve_config` of a configuration already built from the file and ``sets``."""
    bus = bus_limits if bus_limits is not None else bus_limits_from_dbc()
    check_against_bus(configured.core, bus)
    keys = _set_keys(sets)
    core = configured.core
    notes: list[str] = []
    applied: dict[str, float] = {}
    dropped: dict[str, str] = {}
    pending: dict[str, float] = {}
    for name, value in persisted.items():
        try:
            path = param_path(core, name)
        except ParamError as exc:
            dropped[name] = exc.reason
            continue
        if _covered(path, keys):
            notes.append(f"persisted {name} = {value:g} not applied: --set {path} wins")
        else:
            pending[name] = value
    # A value refused for a rule spanning several values may pass once another is in (e.g. two weights).
    reasons: dict[str, str] = {}
    progress = True
    while pending and progress:
        progress = False
        for name, value in list(pending.items()):
            try:
                core = apply_param(core, name, value, bus)
            except ParamError as exc:
                reasons[name] = exc.reason
                continue
            applied[name] = param_value(core, name)
            del pending[name]
            progress = True
    dropped.update({name: reasons[name] for name in pending})
    config = _with_core(configured, core)

    param_at = {param_path(core, n): n for n in PARAM_NAMES}
    persisted_paths = {param_path(core, n) for n in applied}
    lines = []
    packaged = dict(_leaves(type(config)()))
    for key, value in _leaves(config):
        if key in packaged and _same(value, packaged[key]):
            continue
        source = "--set" if _covered(key, keys) else "persisted" if key in persisted_paths else "file"
        name = f", {param_at[key]}" if key in param_at else ""
        lines.append(f"config {key} = {value!r} ({source}{name})")
    lines.extend(notes)
    lines.extend(f"persisted {n} = {persisted[n]!r} dropped: {why}" for n, why in dropped.items())
    return BootConfig(config, configured, bus, applied, dropped, tuple(lines))


def resolve_boot(configured: OnboardConfig, sets: list[str], store: StateStore | None) -> BootConfig:
    """The one boot path of every vehicle program (``auv-onboard run``, the standalone vehicle): the
    persisted ground-station edits of ``store`` applied to ``configured`` (:func:`resolve_built`) BEFORE the
    core and the link exist, so the link serves the values in force from its first packet (a ground station
    caches the list it reads at connect). A refused edit is not kept to be applied at a later boot."""
    persisted = store.load_params() if store is not None else {}
    boot = resolve_built(configured, sets, persisted)
    if store is not None and boot.dropped:
        try:
            store.save_params({n: v for n, v in persisted.items() if n not in boot.dropped})
        except OSError as exc:
            log.error("cannot rewrite the persisted parameters without the refused ones: %s", exc)
    return boot


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
    parser.add_argument(
        "--state-dir",
        help="the state store's directory ([store] dir: parameters, progress, missions, flight logs)",
    )
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
    # From the first moment: a SIGINT / SIGTERM during start-up (loading, rewriting the state files,
    # logging) stops the program cleanly once start-up is through, never as a KeyboardInterrupt mid-way
    stop = threading.Event()

    def _stop(signum: int, _frame: Any) -> None:
        log.info("signal %d: stopping", signum)
        stop.set()

    signal.signal(signal.SIGINT, _stop)
    signal.signal(signal.SIGTERM, _stop)
    mavlink_on = not args.no_mavlink
    try:
        sets = list(args.set)
        if args.state_dir:
            sets.append(f"store.dir={json.dumps(args.state_dir)}")
        cfg0 = build_config(args.config, sets)
        mavlink_on = mavlink_on and cfg0.mavlink.enabled
        # with or without MAVLink: a directory that cannot be written is reported (the log; each station),
        # never fatal: the vehicle boots with what it can read and refuses what it cannot save
        store = StateStore.of(cfg0.store)
        store.open()
        boot = resolve_boot(cfg0, sets, store)
        mission = load_mission(args.mission, boot.config.core) if args.mission else None
    except (ConfigError, MissionError) as exc:
        print(f"auv-onboard: {exc}", file=sys.stderr)
        return 2
    for line in boot.log_lines:
        log.info("%s", line)
    try:
        return run(
            boot,
            mission,
            args.autostart,
            stop,
            store=store,
            mavlink=mavlink_on,
            summary_json=args.summary_json,
            config_name=str(args.config or DEFAULT_CONFIG_PATH),
        )
    except (ConfigError, BusUnavailable) as exc:
        print(f"auv-onboard: {exc}", file=sys.stderr)
        return 2 if isinstance(exc, ConfigError) else 1


def run(
    boot: BootConfig,
    mission: Mission | None,
    autostart: bool,
    stop: threading.Event,
    store: StateStore | None = None,
    summary_json: str | None = None,
    config_name: str = "",
    mavlink: bool = True,
) -> int:
    """Open the bus, build the loop and run it until ``stop`` is set: with the MAVLink link if ``mavlink``
    (and ``[mavlink] enabled``); ``store``: the opened state store (None: the one of ``[store]``).

    The flight log (``[log]``, :mod:`onboard.app.flight_log`; default ``<store.dir>/logs``) starts once the
    bus is open and is closed, with its footer, however the loop ends (``config_name`` names the
    configuration in its metadata).

    The mission: ``mission`` (``--mission``, already checked) wins over the persisted one, which the link
    loads and checks with the same validator; the persisted progress (current goal) of that same mission is
    restored, disarmed: START continues from it. Without the link only ``mission`` is flown, its progress
    kept in the store under the key the link would give it
    (:func:`onboard.adapters.mavlink.storage.progress_key`).
    """
    cfg = boot.config
    if store is None:
        store = StateStore.of(cfg.store)
        store.open()
    autopilot = Autopilot(cfg.core, bus_limits=boot.bus_limits)
    link = _start_link(autopilot, boot, store, mission) if mavlink and cfg.mavlink.enabled else None
    keep_progress: TickHook | None = None
    if link is not None:
        mission = link.mission() if mission is None else mission
    if mission is not None and mission.goals:
        autopilot.replace_mission(mission)
        log.info("mission: %d goals, %d obstacles", len(mission.goals), len(mission.obstacles))
        if link is not None:
            progress = link.progress()
        else:
            from onboard.adapters.mavlink.storage import progress_key

            key = progress_key(mission)
            progress = store.load_progress(key)
            keep_progress = _keep_progress(store, key)
        if progress is not None and autopilot.restore_progress(progress):
            log.info("mission progress restored: goal %d is the current goal", progress)
        autopilot.take_notes()  # the start-up mission is no news for a ground station
    if autostart:
        autopilot.request_autostart()
    codec = Codec()
    listen = [codec.frame_id(c) for c in LISTEN]
    try:
        # acceptance filters: other ids never reach this process (a recording node hears the whole bus)
        bus = open_bus(cfg.bus, stop=stop, listen_ids=None if cfg.bus.record else listen)
    except BusUnavailable:
        if link is not None:
            link.stop()
        if stop.is_set():
            return 0
        raise
    lockstep = cfg.loop.time_source == "lockstep"
    clock = time.monotonic
    listen_ids = None if cfg.bus.record else listen
    # A bus is a link that can come back: a lost bus (hub gone, interface down) does not end the program.
    # The port reopens it with back-off; the loop tells the autopilot (BusLost: ABORT, MAVLink on; BusBack).
    port = BusPort(
        bus,
        clock,
        listen,
        codec,
        record=cfg.bus.record or None,
        reopen=lambda: open_bus(cfg.bus, timeout_s=0.0, listen_ids=listen_ids),
        reconnect_max_s=cfg.bus.reconnect_max_s,
    )
    # Frames far above an id's DBC rate are dropped undecoded and the id distrusted (its frames drained once
    # per tick). Not in lock-step on this wall clock (the simulation runs faster than it), nor with a loop
    # faster than the bus contract's control period (the bench's status frames follow the loop).
    if not lockstep and codec.rates_checkable(cfg.loop.period_s):
        port.receiver.check_rates(receive_period_s=cfg.loop.period_s)
        port.rates_on_bus_time = True  # the frames' own arrival times: a stall of this process bunches none
    elif not lockstep:
        log.warning(
            "frame rate check off: the loop runs at %.0f Hz, faster than the bus contract's %.0f Hz",
            cfg.loop.rate_hz,
            1.0 / codec.control_cycle_s,
        )
    loop = ControlLoop(port, autopilot, cfg.loop)
    start = dt.datetime.now(dt.UTC)
    flight = open_flight_log(cfg.log, store.dir, run_metadata(cfg, config_name, start), start)
    if link is not None or flight is not None:
        _bridge(loop, autopilot, link, flight)
    if link is None:
        _watch_store(loop, store, keep_progress)
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
    except Exception:  # a lost bus is no error here: the port reconnects (BusPort), the loop runs on
        log.exception("onboard loop stopped by an unexpected error")
        code = 1
    finally:
        loop.close()
        port.close()
        if link is not None:
            link.stop()
        if flight is not None:
            flight.close()
        log.info(
            "onboard stopped: %d ticks, %d overruns, CAN bus lost %d time(s), %d frames rejected %s",
            loop.stats.ticks,
            loop.stats.overruns,
            port.losses,
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
        "max_consecutive_overruns": loop.stats.max_consecutive_overruns,
        "max_late_s": loop.stats.max_late_s,
        "drains_at_budget": loop.port.drain_capped,
        "missed_deadlines": loop.stats.missed_deadlines,
        "encode_errors": loop.stats.encode_errors,
        "frames_rejected": dict(loop.port.receiver.rejected),
        "tick_compute_p50_us": pct(compute, 0.5),
        "tick_compute_p99_us": pct(compute, 0.99),
        "lateness_p50_us": pct(late, 0.5),
        "lateness_p99_us": pct(late, 0.99),
        "lateness_max_us": late[-1] * 1e6 if late else float("nan"),
        "final_state": autopilot.status.state.name,
        "goals_reached": autopilot.goals_reached,
        "fixes_rejected": autopilot.nav_state.fixes_rejected,
    }


def mission_validator(autopilot: Autopilot, timeout_s: float) -> Callable[[Mission], MissionCheck]:
    """The one mission check, with the configuration the core flies with at the time of the upload.

    Leg 0 is not planned from the vehicle's pose of the moment: the vehicle plans it at START from where it
    is then (and holds with the reason if it cannot); an upload is judged on what does not depend on where
    the vehicle happens to be (limits, goals clear of obstacles, every leg between goals). The planning of
    the legs stops at ``timeout_s`` (wall clock) with a problem saying so: a check abandoned by its caller
    does not go on planning, and a check at boot is bounded too.
    """

    def validator(candidate: Mission) -> MissionCheck:
        t_end = time.monotonic() + timeout_s
        return check_mission(candidate, autopilot.config, expired=lambda: time.monotonic() > t_end)

    return validator


def build_link(
    autopilot: Autopilot, boot: BootConfig, store: StateStore, mission: Mission | None, **kw: Any
) -> Any:
    """The MAVLink link of ``boot`` (:func:`resolve_boot`), not started: the one validator bound to the
    core's configuration, the one table, and the values in force (the persisted edits are in already:
    the link never serves a table default for a value that is not in force). ``kw``: more for
    :class:`~onboard.adapters.mavlink.endpoint.VehicleLink` (tests: a clock)."""
    from onboard.adapters.mavlink.endpoint import VehicleLink

    return VehicleLink(
        boot.config.mavlink,
        validator=mission_validator(autopilot, boot.config.mavlink.validate_timeout_s),
        params=param_table(boot.configured.core, boot.bus_limits),
        param_values={name: param_value(autopilot.config, name) for name in PARAM_NAMES},
        initial_mission=mission,
        store=store,
        log_dir=boot.config.log.directory(store.dir),  # the flight logs it serves over MAVLink FTP
        **kw,
    )


def _start_link(autopilot: Autopilot, boot: BootConfig, store: StateStore, mission: Mission | None) -> Any:
    """:func:`build_link`, started."""
    link = build_link(autopilot, boot, store, mission)
    link.start()
    return link


def _keep_progress(store: StateStore, key: str) -> TickHook:
    """Without the link: the current goal of each tick to the store (``StateStore.keep_progress`` writes it
    when it changes, and says in the log when it cannot). The mission cannot change without the link, so
    ``key`` stays its key."""

    def keep(out: Any, _now_s: float) -> None:  # the TickRecord of the real autopilot
        store.keep_progress(out.status.goal_index, key, time.monotonic())

    return keep


def _watch_store(loop: ControlLoop, store: StateStore, keep_progress: TickHook | None) -> None:
    """Without the link, the loop's tick hook also keeps the progress and probes a store that cannot be
    written (every ``[store] probe_period_s``; the store logs when it can be written again), the link's jobs
    when there is one."""
    inner = loop.on_tick

    def after(out: Any, now_s: float) -> None:
        if inner is not None:
            inner(out, now_s)
        if keep_progress is not None:
            keep_progress(out, now_s)
        store.reprobe(time.monotonic())

    loop.on_tick = after


def _bridge(loop: ControlLoop, autopilot: Autopilot, link: Any, flight: FlightLog | None = None) -> None:
    """The per-tick exchange with the link: requests judged before the step, notes and snapshot after.

    The flight log's one hook: with ``flight``, the bridge's link is :class:`LoggedLink`, which hands the
    notes and the snapshot of every tick to the log as well (``link`` None: to the log only).
    """
    from onboard.adapters.mavlink import bridge

    stats = loop.stats
    if flight is not None:
        link = LoggedLink(flight, link, lambda: autopilot.mission.obstacles)

    def before(_now_s: float) -> None:
        bridge.before_tick(autopilot, link)

    def after(out: Any, now_s: float) -> None:  # the StepOutput of the real autopilot
        bridge.after_tick(autopilot, link, out, now_s, stats.overruns, stats.load)

    loop.before_tick = before
    loop.on_tick = after
