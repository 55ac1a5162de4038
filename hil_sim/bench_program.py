"""``auv-hil run``: the hardware-in-the-loop bench on the CAN bus, in real time or in lock-step.

The bench hosts the CAN hub (python-can-remote on 127.0.0.1) when its bus is ``remote``, and plays three
nodes: the actuator node (consumes FIN_CMD / PROP_CMD through the E2E checks, moves the fins and the
propeller with their limits and lag, goes to a latched failsafe when no valid command came for
``command_timeout_s``, counted in whole control periods; reports FIN_STATUS / PROP_STATUS), the sensor
node (AHRS, depth, DVL, position fix at their own rates with seeded noise) and the bench itself (SYNC in
lock-step).

Time modes:

- ``realtime``: one control period per period of the monotonic clock; commands are taken as they come.
- ``lockstep``: per period, publish the sensors, send SYNC(tick, simulated time), wait for the onboard's
  SYNC_ACK of that tick (collecting its commands), then integrate one period. Simulated time starts only when
  the onboard's heartbeat reports a running mission (the vehicle starts where the scenario puts it, drifting
  with the water; the sensors sampled while it waits show that instant: the DVL the drift);
  staleness is counted in ticks; no wall clock is read for the simulation, so runs repeat exactly. A missing
  echo past ``echo_timeout_s`` (wall clock) ends the run with a clear error.
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import json
import logging
import math
import operator
import signal
import sys
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np

from auv_common.cli import join_negative_values
from auv_common.config import ConfigError, check_declared, from_table, load_toml, param, require
from hil_sim.model import faults as fault_model
from hil_sim.model.actuators import (
    NEUTRAL_COMMAND,
    ActuatorCommand,
    WatchdogState,
    watchdog_output,
    watchdog_rearm,
    watchdog_tick,
)
from hil_sim.model.current import CurrentParams
from hil_sim.model.dynamics import BodyState
from hil_sim.model.faults import Fault, FaultError, FaultEvent, FaultMemory
from hil_sim.model.params import VehicleParams, load_params
from hil_sim.model.sensors import AhrsMeasurement, DepthMeasurement, DvlMeasurement, Measurement, sample
from hil_sim.model.sensors import PositionFix as FixMeasurement
from hil_sim.model.sim import SimSetup, SimState, drifting_with_water, initial_state, make_setup
from hil_sim.model.sim import step as sim_step
from onboard.protocol import messages as m
from onboard.protocol.bus import BenchHub, BusConfig, BusUnavailable, hub_went_away, open_bus
from onboard.protocol.codec import Codec
from onboard.protocol.port import BusPort

log = logging.getLogger("hil_sim")

DEFAULT_CONFIG_PATH = Path(__file__).parent / "config" / "bench.toml"
NUMERIC_OPTIONS = ("--start", "--current", "--seed", "--duration", "--stop-delay")


@dataclass(frozen=True)
class BenchConfig:
    """The ``[bench]`` table: how the bench runs."""

    time_mode: Literal["realtime", "lockstep"] = param(
        "realtime", desc='"realtime" or "lockstep" (one onboard tick per SYNC frame)'
    )
    control_rate_hz: float = param(
        20.0, unit="Hz", min=1.0, max=200.0, desc="the control period (must match the onboard [loop] rate_hz)"
    )
    sensor_profile: Literal["basin", "sea"] = param(
        "basin", desc='"basin" (the paper\'s tank: mm fixes at 20 Hz) or "sea" (slow noisy fixes, DVL)'
    )
    seed: int = param(0, desc="the seed of all noise")
    command_timeout_s: float = param(
        0.0, unit="s", min=0.0, max=10.0,
        desc="the actuator node's command watchdog (0 = the vehicle's [actuators] command_timeout_s)",
    )  # fmt: skip
    echo_timeout_s: float = param(
        10.0,
        unit="s",
        min=0.0,
        min_open=True,
        desc="lock-step: wall-clock deadline for the onboard's SYNC_ACK",
    )
    duration_s: float = param(
        0.0, unit="s", min=0.0, desc="simulated seconds after the start (0 = until stopped)"
    )
    stop_on_state: tuple[str, ...] = param(
        (), desc="onboard mission states (MissionStateCode names) that end the run, after stop_delay_s"
    )
    stop_delay_s: float = param(
        0.0, unit="s", min=0.0, desc="simulated seconds run on after a stop_on_state state"
    )
    truth_log: str = param("", desc='CSV of truth + commands ("" = off)')
    params: str = param("", desc='the vehicle parameter TOML ("" = the packaged ISiMI100)')
    host_hub: bool = param(True, desc="host the CAN hub for a remote bus")

    def __post_init__(self) -> None:
        check_declared(self)
        for s in self.stop_on_state:
            require(s in m.MissionStateCode.__members__, f"stop_on_state: unknown state {s!r}")


@dataclass(frozen=True)
class InitialConfig:
    """The ``[initial]`` table: where the vehicle starts (NED), drifting with the water (at rest in it).

    A free vehicle at sea before its mission drifts with the water: at t = 0 its velocity over ground is the
    current, zero through the water, fins neutral, propeller off. In lock-step, simulated time stands still
    until the onboard reports RUNNING, so the sensors sampled while it waits show that instant: the DVL the
    drift, the position fix the start point (the onboard's clock stands still too, so the two agree); the
    onboard's current estimate at START is the current. In real time the vehicle drifts for real from the
    bench's start. ``held = true`` keeps the bench's old start, at rest over ground in moving water (set
    sideways 4-5 m in 0.5 m/s before its fins bite, its DVL showing no current before START).
    """

    x_m: float = param(0.0, unit="m", desc="north")
    y_m: float = param(0.0, unit="m", desc="east")
    depth_m: float = param(1.0, unit="m", desc="depth")
    yaw_deg: float = param(0.0, unit="deg", desc="heading, from north")
    held: bool = param(
        False,
        desc="start at rest over ground (the old bench) instead of drifting with the water (velocity over "
        "ground = the current, zero through the water)",
    )

    def __post_init__(self) -> None:
        check_declared(self)


@dataclass(frozen=True)
class WaterCurrentConfig:
    """The ``[current]`` table: a constant current."""

    speed_mps: float = param(0.0, unit="m/s", min=0.0, max=3.0, desc="current speed")
    direction_deg: float = param(
        0.0, unit="deg", desc="the direction the water flows towards, from north (NED)"
    )

    def __post_init__(self) -> None:
        check_declared(self)


@dataclass(frozen=True)
class HilConfig:
    bus: BusConfig = field(default_factory=BusConfig)
    bench: BenchConfig = field(default_factory=BenchConfig)
    initial: InitialConfig = field(default_factory=InitialConfig)
    current: WaterCurrentConfig = field(default_factory=WaterCurrentConfig)


def load_hil_config(path: str | Path | None, overrides: dict[str, dict[str, Any]] | None = None) -> HilConfig:
    p = Path(path) if path else DEFAULT_CONFIG_PATH
    data = load_toml(p)
    for table, values in (overrides or {}).items():
        data.setdefault(table, {}).update(values)
    return from_table(HilConfig, data, str(p))


# --- the actuator node -----------------------------------------------------------------------------
#: The onboard's heartbeat (1 Hz and at every change) is stale after this (s): ARMED commands do nothing then.
ONBOARD_HEARTBEAT_TIMEOUT_S = 3.0


def timeout_periods(timeout_s: float, period_s: float) -> int:
    """A timeout in seconds as the whole control periods the actuator node counts (rounded up, >= 1).

    The node counts periods, never reads a clock, so lock-step runs repeat exactly; the configuration is in
    seconds so one value means the same at every control rate.
    """
    return max(1, math.ceil(timeout_s / period_s - 1e-9))


@dataclass
class ActuatorNode:
    """Commands from the bus (already E2E-checked) into the watchdog; mode handling.

    SAFE: fins neutral, propeller off, and a latched failsafe is cleared (the onboard acknowledged it).
    ARMED: follow the commands, but only while the onboard's own heartbeat (ONBOARD_HEARTBEAT, sent at every
    change of its mission state and each second) says it is in a live state (``messages.LIVE_MISSION_STATES``)
    and is younger than ``heartbeat_timeout_periods``; otherwise as SAFE (a second sender of valid command
    frames while the onboard is IDLE moves nothing; counted in ``refused_periods``). ABORT: fins as
    commanded, propeller off.

    The watchdog's failsafe (no valid command for ``timeout_periods``: the onboard, or the bus to it, is what
    failed) after a command that moved anything is the bus contract's ABORT done by the node itself:
    propeller off, rudder centred, stern planes nose up by ``messages.ABORT_STERN_DEG``, so the vehicle
    pitches up and surfaces instead of gliding on. Before it held the fins neutral: from 1.2 m/s the vehicle
    glided 22 m and sank 0.17 m.
    """

    timeout_periods: int
    heartbeat_timeout_periods: int = 60
    watchdog: WatchdogState = field(default_factory=WatchdogState)
    fin: m.FinCmd | None = None
    prop: m.PropCmd | None = None
    fin_fresh: bool = False
    prop_fresh: bool = False
    onboard_state: m.MissionStateCode | None = None
    onboard_age_periods: int = 0
    refused_periods: int = 0
    #: the most periods in a row without a valid command since the first one (the measurement behind the
    #: timeout's default: ``max_gap_periods + 1`` periods is the longest time between two valid commands)
    max_gap_periods: int = 0
    commanded: bool = False  # a valid command has come (gaps count from then)

    def take(self, msg: m.BusMessage) -> None:
        if isinstance(msg, m.FinCmd):
            self.fin, self.fin_fresh = msg, True
        elif isinstance(msg, m.PropCmd):
            self.prop, self.prop_fresh = msg, True
        elif isinstance(msg, m.OnboardHeartbeat):
            self.onboard_state, self.onboard_age_periods = msg.node_state, 0

    @property
    def onboard_live(self) -> bool:
        """The onboard's latest heartbeat is recent and says its actuators may move."""
        return (
            self.onboard_state in m.LIVE_MISSION_STATES
            and self.onboard_age_periods <= self.heartbeat_timeout_periods
        )

    @property
    def armed(self) -> bool:
        """Following ARMED commands now (not in a latched failsafe, and the onboard says it is live)."""
        return (
            self.prop is not None
            and self.prop.mode is m.ActuatorMode.ARMED
            and not self.watchdog.failsafe
            and self.onboard_live
        )

    def end_period(self) -> ActuatorCommand:
        """Close one control period: advance the watchdog; the command the actuators follow.

        A period counts as commanded only when both a valid FIN_CMD and a valid PROP_CMD arrived in it (a
        rejected fin frame next to a good propeller frame does not keep stale fins alive).
        """
        cmd: ActuatorCommand | None = None
        if self.fin_fresh and self.prop_fresh and self.fin is not None and self.prop is not None:
            mode = self.prop.mode
            if mode is m.ActuatorMode.SAFE:
                cmd = ActuatorCommand()
                if self.watchdog.failsafe:
                    log.info("actuator failsafe cleared by a SAFE command")
                    self.watchdog = watchdog_rearm(self.watchdog)
            elif mode is m.ActuatorMode.ARMED and not self.onboard_live:
                if self.refused_periods == 0:
                    log.warning(
                        "ARMED commands while the onboard heartbeat says %s: held neutral",
                        "nothing (none for a while)"
                        if self.onboard_state is None
                        else self.onboard_state.name,
                    )
                self.refused_periods += 1
                cmd = ActuatorCommand()
            else:
                rps = self.prop.propeller_rps if mode is m.ActuatorMode.ARMED else 0.0
                cmd = ActuatorCommand(
                    self.fin.rudder_rad, self.fin.stern_port_rad, self.fin.stern_starboard_rad, rps
                )
        self.onboard_age_periods += 1
        was = self.watchdog.failsafe
        self.watchdog = watchdog_tick(self.watchdog, cmd, self.timeout_periods)
        if self.watchdog.ticks_since_valid == 0:
            self.commanded = True
        elif self.commanded:
            self.max_gap_periods = max(self.max_gap_periods, self.watchdog.ticks_since_valid)
        if self.watchdog.failsafe and not was:
            log.warning("actuator failsafe: no valid command for %d control periods", self.timeout_periods)
        self.fin_fresh = self.prop_fresh = False
        return self._stop(watchdog_output(self.watchdog))

    def _stop(self, out: ActuatorCommand) -> ActuatorCommand:
        """In the watchdog's failsafe after a command that moved anything (the vehicle may be under way),
        nobody commands the fins: the contract's ABORT stern planes, nose up (``ABORT_STERN_DEG``), propeller
        off. Else ``out``: never commanded, or last told SAFE (nothing moves), the failsafe stays neutral."""
        if not self.watchdog.failsafe or self.watchdog.last_command == NEUTRAL_COMMAND:
            return out
        stern = -math.radians(m.ABORT_STERN_DEG)
        return ActuatorCommand(0.0, stern, stern, 0.0)


# --- sensor frames -----------------------------------------------------------------------------------
def _clip(value: float, lo: float, hi: float) -> float:
    """A sensor saturates at the end of its frame's range (non-finite readings are dropped before this)."""
    return min(max(value, lo), hi)


#: Every field of each measurement type, read at once (its time and readings, all floats): the finiteness
#: check of :func:`sensor_frames` (``dataclasses.astuple`` deep-copied each one, ~5 us a measurement).
_READINGS = {
    cls: operator.attrgetter(*(f.name for f in dataclasses.fields(cls)))
    for cls in (AhrsMeasurement, DepthMeasurement, DvlMeasurement, FixMeasurement)
}


def sensor_frames(meas: Measurement) -> list[m.BusMessage]:
    """The bus messages of one measurement (values clipped to the DBC ranges, as a real sensor saturates).

    A measurement with a non-finite value gives no frame (a real sensor drops an invalid reading).
    """
    t = meas.t_sample_s
    if not all(map(math.isfinite, _READINGS[type(meas)](meas))):
        return []
    if isinstance(meas, AhrsMeasurement):
        return [
            m.AhrsAttitude(
                _clip(meas.roll_rad, -3.1416, 3.1416),
                _clip(meas.pitch_rad, -1.5708, 1.5708),
                _clip(meas.yaw_rad, -3.1416, 3.1416),
                t,
            ),
            m.AhrsRates(
                _clip(meas.roll_rate_radps, -6.5, 6.5),
                _clip(meas.pitch_rate_radps, -6.5, 6.5),
                _clip(meas.yaw_rate_radps, -6.5, 6.5),
                t,
            ),
        ]
    if isinstance(meas, DepthMeasurement):
        return [m.DepthMeas(_clip(meas.depth_m, -10.0, 800.0), t)]
    if isinstance(meas, DvlMeasurement):
        return [
            m.DvlVelocity(
                _clip(meas.u_mps, -10.0, 10.0),
                _clip(meas.v_mps, -10.0, 10.0),
                _clip(meas.w_mps, -10.0, 10.0),
                True,
                t,
            )
        ]
    assert isinstance(meas, FixMeasurement)
    # The stated accuracy in the frame's 0.25 m steps (a sensor states its accuracy conservatively: up),
    # 0 when better than one step (the frame's "better than 0.25 m": the onboard's [nav] fix_sigma_m then;
    # rounding 3 mm up to 0.25 m made the basin's filter claim 100 x its error).
    std_m = 0.0 if meas.std_m < 0.25 else _clip(math.ceil(meas.std_m / 0.25 - 1e-9) * 0.25, 0.0, 3.75)
    return [m.PositionFix(_clip(meas.x_m, -8000.0, 8000.0), _clip(meas.y_m, -8000.0, 8000.0), t, std_m)]


# --- the bench ---------------------------------------------------------------------------------------
TRUTH_COLUMNS = (
    "t_s",
    "x_m",
    "y_m",
    "depth_m",
    "roll_deg",
    "pitch_deg",
    "yaw_deg",
    "u_mps",
    "v_mps",
    "w_mps",
    "p_radps",
    "q_radps",
    "r_radps",
    "rudder_cmd_rad",
    "stern_port_cmd_rad",
    "stern_starboard_cmd_rad",
    "propeller_cmd_rps",
    "rudder_rad",
    "stern_port_rad",
    "stern_starboard_rad",
    "propeller_rps",
    "failsafe",
    "onboard_state",
    "current_north_mps",  # the water's velocity now (NED; varies with [current] variation_std_mps)
    "current_east_mps",
    *fault_model.TRUTH_COLUMNS,  # fault_<kind>: 1 while a fault of that kind acts (hil_sim/model/faults.py)
)


class EchoTimeout(RuntimeError):
    """The onboard did not echo a SYNC in time (lock-step)."""


@dataclass
class BenchResult:
    ticks: int = 0
    sim_time_s: float = 0.0
    wall_time_s: float = 0.0
    started: bool = False
    onboard_state: str = ""
    failsafe_timeouts: int = 0
    bus_lost: bool = False  # the bus went away mid-run and could not come back (exit 1)
    bus_losses: int = 0  # times the bus was lost and reopened with back-off while the bench ran on
    rejected: dict[str, int] = field(default_factory=dict)
    stop_reason: str = ""
    run_wall_time_s: float = 0.0  # wall time from the start of simulated time to the end
    command_timeout_s: float = 0.0  # the actuator node's command timeout
    max_command_gap_s: float = 0.0  # the longest time between two valid commands (whole periods)
    faults: list[str] = field(default_factory=list)  # the run's faults (hil_sim.model.faults.describe)
    fault_events: list[dict[str, Any]] = field(default_factory=list)  # each start and end (FaultEvent)
    _t_start_wall: float = 0.0


class Bench:
    """The simulation side of the bench: truth, actuators, sensors; one :meth:`period` per control period."""

    def __init__(
        self, cfg: HilConfig, params: VehicleParams | None = None, faults: tuple[Fault, ...] = ()
    ) -> None:
        self.cfg = cfg
        # Faults act on the truth's sensors and actuators as simulated time runs (hil_sim/model/faults.py)
        self.faults = faults
        self.fault_memory = FaultMemory()
        self.fault_events: list[FaultEvent] = []
        self._active_faults: frozenset[int] = frozenset()
        params = params or load_params(cfg.bench.params or None)
        # The mean current is the bench's [current] table; its variation (a seeded first-order
        # Gauss-Markov process about the mean) the vehicle file's [current] variation_* keys.
        direction = math.radians(cfg.current.direction_deg)
        variation = params.config.current
        current = CurrentParams(
            cfg.current.speed_mps * math.cos(direction),
            cfg.current.speed_mps * math.sin(direction),
            0.0,
            variation.variation_std_mps,
            variation.variation_period_s,
        )
        self.setup: SimSetup = make_setup(
            params, cfg.bench.sensor_profile, current, control_period_s=1.0 / cfg.bench.control_rate_hz
        )
        self.command_timeout_s = cfg.bench.command_timeout_s or params.config.actuators.command_timeout_s
        log.info(
            "integration step %.6g s (%d per control period of %.6g s; the model's largest step %.6g s)",
            self.setup.step_s,
            self.setup.substeps,
            self.setup.control_period_s,
            params.step_s,
        )
        ini = cfg.initial
        body = BodyState(ini.x_m, ini.y_m, ini.depth_m, 0.0, 0.0, math.radians(ini.yaw_deg))
        if not ini.held:
            body = drifting_with_water(body, self.setup.current.mean_ned_mps)
        self.state: SimState = initial_state(self.setup, body=body)
        self.rng = np.random.default_rng(cfg.bench.seed)
        # Pre-start samples (their count depends on how long the operator takes) use their own generator.
        self.idle_rng = np.random.default_rng([cfg.bench.seed, 1])
        self.node = ActuatorNode(
            timeout_periods(self.command_timeout_s, self.setup.control_period_s),
            heartbeat_timeout_periods=round(ONBOARD_HEARTBEAT_TIMEOUT_S * cfg.bench.control_rate_hz),
        )
        self.pending: list[Measurement] = []

    def idle_measurements(self) -> list[Measurement]:
        """All sensors sampled at the frozen start state (before simulated time starts)."""
        st = self.state
        return sample(st.body, st.t_s, (True, True, True, True), self.setup.sensors, self.idle_rng)

    def period(self, integrate: bool) -> ActuatorCommand:
        """Close a control period: the watchdog's command; integrate it if the clock runs."""
        cmd = self.node.end_period()
        if integrate:
            result = sim_step(*self._faulted(cmd), self.rng)
            self.state = result.state
            meas: Sequence[Measurement] = result.measurements
            if self.faults:
                meas, self.fault_memory = fault_model.apply_to_measurements(
                    self.faults, meas, self.fault_memory
                )
                self._note_fault_events()
            self.pending.extend(meas)
        return cmd

    def _faulted(self, cmd: ActuatorCommand) -> tuple[SimState, ActuatorCommand, SimSetup]:
        """The step's state, command and setup under the faults acting over this period (a stuck fin's
        set-point, a thrust loss's thrust); as they are without faults."""
        if not self.faults:
            return self.state, cmd, self.setup
        t = self.state.t_s
        factor = fault_model.thrust_factor(self.faults, t)
        setup = self.setup
        if factor != 1.0:
            params = setup.params
            coeffs = fault_model.thrust_scaled(params.coeffs, factor)
            setup = dataclasses.replace(setup, params=dataclasses.replace(params, coeffs=coeffs))
        return self.state, fault_model.apply_to_command(self.faults, cmd, t), setup

    def _note_fault_events(self) -> None:
        """Log and keep each fault's start and end (at its scheduled time) as simulated time passes it."""
        now = fault_model.active_indices(self.faults, self.state.t_s)
        for event in fault_model.events_between(self.faults, self._active_faults, now):
            log.warning(
                "fault %s %s at t = %.3f s", event.event, fault_model.describe([event.fault]), event.t_s
            )
            self.fault_events.append(event)
        self._active_faults = now

    def status_frames(self, t_s: float, rejected_frames: int = 0) -> list[m.BusMessage]:
        """FIN_STATUS and PROP_STATUS; ``rejected_frames``: frames the bench's receiver dropped so far."""
        a = self.state.actuators
        lim = 0.5236
        wd = self.node.watchdog
        return [
            m.FinStatus(
                _clip(a.rudder_rad, -lim, lim),
                _clip(a.stern_port_rad, -lim, lim),
                _clip(a.stern_starboard_rad, -lim, lim),
                False,
                wd.failsafe,
                t_s,
            ),
            m.PropStatus(
                _clip(a.propeller_rps, -40.0, 40.0),
                self.node.armed,
                wd.failsafe,
                False,
                min(rejected_frames, 65535),
                t_s,
            ),
        ]

    def truth_row(self, cmd: ActuatorCommand, onboard_state: str) -> list[Any]:
        s, a = self.state.body, self.state.actuators
        return [
            round(self.state.t_s, 6),
            s.x_m,
            s.y_m,
            s.z_m,
            math.degrees(s.roll_rad),
            math.degrees(s.pitch_rad),
            math.degrees(s.yaw_rad),
            s.u_mps,
            s.v_mps,
            s.w_mps,
            s.p_radps,
            s.q_radps,
            s.r_radps,
            cmd.rudder_rad,
            cmd.stern_port_rad,
            cmd.stern_starboard_rad,
            cmd.propeller_rps,
            a.rudder_rad,
            a.stern_port_rad,
            a.stern_starboard_rad,
            a.propeller_rps,
            int(self.node.watchdog.failsafe),
            onboard_state,
            self.state.current_ned_mps[0],
            self.state.current_ned_mps[1],
            *fault_model.truth_flags(self.faults, self.state.t_s),
        ]


def _heartbeats(uptime_s: float, failsafe: bool) -> list[m.BusMessage]:
    up = min(max(uptime_s, 0.0), 167772.0)
    return [
        m.ActuatorsHeartbeat(m.NodeHealth.FAILSAFE if failsafe else m.NodeHealth.OK, round(up, 2), up),
        m.SensorsHeartbeat(m.NodeHealth.OK, round(up, 2), up),
    ]


#: What the bench listens to (and so its acceptance filters on the hub): the onboard's frames.
BENCH_LISTENS: tuple[type[m.BusMessage], ...] = (m.FinCmd, m.PropCmd, m.SyncAck, m.OnboardHeartbeat)


def run_bench(
    cfg: HilConfig, stop: threading.Event, bus_override: Any = None, faults: tuple[Fault, ...] = ()
) -> BenchResult:
    """Run the bench until ``stop``, the duration, a stop state, or (lock-step) a missing echo; ``faults``
    acts on its sensors and actuators (:mod:`hil_sim.model.faults`)."""
    bench = Bench(cfg, faults=faults)
    codec = Codec()
    listen = [codec.frame_id(c) for c in BENCH_LISTENS]
    filters = None if cfg.bus.record else listen  # a recording bench hears the whole bus
    hubs: list[BenchHub] = []  # the hub hosted now (one at most)
    reopen: Callable[[], Any] | None = None
    if bus_override is not None:
        bus = bus_override
    elif cfg.bus.interface == "remote" and cfg.bench.host_hub:
        hubs.append(BenchHub(cfg.bus.channel, cfg.bus.hub_channel, filters))
        bus = hubs[0].bus

        def reopen() -> Any:  # the hub process ended: host a new one on the same port
            while hubs:
                hubs.pop().close()
            hubs.append(BenchHub(cfg.bus.channel, cfg.bus.hub_channel, filters, start_timeout_s=5.0))
            return hubs[0].bus

    else:
        bus = open_bus(cfg.bus, stop=stop, listen_ids=filters)

        def reopen() -> Any:
            return open_bus(cfg.bus, timeout_s=0.0, listen_ids=filters)

    # A bus is a link that can come back: the bench simulates on while it is lost (no command reaches the
    # actuator node, whose watchdog holds the actuators) and the port reopens it with back-off.
    port = BusPort(
        bus,
        time.monotonic,
        listen,
        codec,
        record=cfg.bus.record or None,
        reopen=reopen,
        reconnect_max_s=cfg.bus.reconnect_max_s,
    )
    if cfg.bench.time_mode == "realtime" and codec.rates_checkable(bench.setup.control_period_s):
        # as the onboard does: the onboard's frames far above their DBC rate are dropped, on their bus
        # arrival times. Not in lock-step: there the onboard's heartbeat comes every tick before the start
        port.receiver.check_rates(receive_period_s=bench.setup.control_period_s)
        port.rates_on_bus_time = True
    writer = None
    log_file = None
    if cfg.bench.truth_log:
        Path(cfg.bench.truth_log).parent.mkdir(parents=True, exist_ok=True)
        log_file = Path(cfg.bench.truth_log).open("w", newline="")
        writer = csv.writer(log_file)
        writer.writerow(TRUTH_COLUMNS)
    result = BenchResult()
    t_wall0 = time.monotonic()
    try:
        if cfg.bench.time_mode == "lockstep":
            _run_lockstep(bench, port, cfg, stop, writer, result)
        else:
            _run_realtime(bench, port, cfg, stop, writer, result)
    except Exception as exc:
        if not hub_went_away(exc):
            raise
        result.bus_lost = True
        result.stop_reason = "bus lost: the CAN hub closed the connection"
        log.error("%s", result.stop_reason)
    finally:
        result.wall_time_s = time.monotonic() - t_wall0
        if result._t_start_wall:
            result.run_wall_time_s = time.monotonic() - result._t_start_wall
        result.sim_time_s = bench.state.t_s
        result.failsafe_timeouts = bench.node.watchdog.timeouts
        result.command_timeout_s = bench.command_timeout_s
        result.max_command_gap_s = (bench.node.max_gap_periods + 1) * bench.setup.control_period_s
        result.rejected = dict(port.receiver.rejected)
        result.bus_losses = port.losses
        result.faults = [fault_model.describe([f]) for f in faults]
        result.fault_events = [e.to_dict() for e in bench.fault_events]
        if log_file is not None:
            log_file.close()
        port.close()
        for hub in hubs:
            hub.close()
    return result


def _onboard_state(msg: m.BusMessage, current: str) -> str:
    return msg.node_state.name if isinstance(msg, m.OnboardHeartbeat) else current


def _should_stop(bench: Bench, cfg: HilConfig, result: BenchResult, stop_at_s: list[float]) -> bool:
    t = bench.state.t_s
    if cfg.bench.duration_s and t >= cfg.bench.duration_s - 1e-9:
        result.stop_reason = f"duration {cfg.bench.duration_s:g} s reached"
        return True
    if result.onboard_state in cfg.bench.stop_on_state:
        if not stop_at_s:
            stop_at_s.append(t + cfg.bench.stop_delay_s)
        if t >= stop_at_s[0] - 1e-9:
            result.stop_reason = f"onboard {result.onboard_state}"
            return True
    return False


class LockstepBench:
    """The bench's side of one lock-step period, in three calls (the loop of :func:`_run_lockstep`, and of
    a campaign run that drives the onboard in the same thread):

    1. :meth:`offer`: publish the sensor, status and heartbeat frames of this period, then SYNC;
    2. :meth:`take` every frame that arrives, until it returns True (the onboard's SYNC_ACK of this tick);
    3. :meth:`close_period`: start the clock when the onboard reports RUNNING, integrate one period, write
       the truth row; True when the run should end (duration, a stop state).
    """

    def __init__(self, bench: Bench, port: BusPort, cfg: HilConfig, writer: Any, result: BenchResult) -> None:
        self.bench, self.port, self.cfg, self.writer, self.result = bench, port, cfg, writer, result
        self.period_s = bench.setup.control_period_s
        self.tick = 0
        self._offered: list[m.BusMessage] = []
        self._stop_at: list[float] = []
        self._last_hb_s = -math.inf

    def offer(self) -> m.Sync:
        bench, started = self.bench, self.result.started
        t = bench.state.t_s
        msgs: list[m.BusMessage] = []
        for meas in bench.pending if started else bench.idle_measurements():
            msgs.extend(sensor_frames(meas))
        bench.pending.clear()
        msgs.extend(bench.status_frames(t, self.port.receiver.rejected_total))
        if t - self._last_hb_s >= 1.0 - 1e-9 or (not started and self.tick % round(1.0 / self.period_s) == 0):
            msgs.extend(_heartbeats(t, bench.node.watchdog.failsafe))
            self._last_hb_s = t
        sync = m.Sync(self.tick & 0x0FFFFFFF, round(t, 3), t)
        msgs.append(sync)
        self._offered = msgs
        self.port.send_all(msgs)
        return sync

    def reoffer(self) -> None:
        """Send this period's frames and SYNC again (before the start the onboard may not be connected yet;
        it answers a repeated tick without ticking twice, and its first tick sees this period's frames)."""
        self.port.send_all(self._offered)

    def take(self, msg: m.BusMessage) -> bool:
        """One frame from the onboard; True if it is the SYNC_ACK of this tick."""
        if isinstance(msg, m.SyncAck):
            return msg.tick == self.tick & 0x0FFFFFFF
        self.result.onboard_state = _onboard_state(msg, self.result.onboard_state)
        self.bench.node.take(msg)
        return False

    def close_period(self) -> bool:
        result = self.result
        if not result.started and result.onboard_state == "RUNNING":
            result.started = True
            result._t_start_wall = time.monotonic()
            log.info("onboard mission running: simulated time starts")
        cmd = self.bench.period(integrate=result.started)
        self.tick += 1
        result.ticks = self.tick
        if not result.started:
            return False
        if self.writer is not None:
            self.writer.writerow(self.bench.truth_row(cmd, result.onboard_state))
        return _should_stop(self.bench, self.cfg, result, self._stop_at)


def _run_lockstep(
    bench: Bench, port: BusPort, cfg: HilConfig, stop: threading.Event, writer: Any, result: BenchResult
) -> None:
    steps = LockstepBench(bench, port, cfg, writer, result)
    next_wall = time.monotonic()
    while not stop.is_set():
        started = result.started
        steps.offer()
        now = time.monotonic()
        deadline = now + cfg.bench.echo_timeout_s
        resend_at = now + 0.5
        while True:
            msg = port.recv(0.05)
            # Checked on every frame, not only on silence: an onboard that streams commands without echoing
            # (e.g. one running in real time) must still meet the deadline, and a stop must still stop.
            if stop.is_set():
                return
            now = time.monotonic()
            if not started and now > resend_at:
                # Before the start the onboard may not be connected yet: offer the same tick again.
                steps.reoffer()
                resend_at = now + 0.5
                deadline = now + cfg.bench.echo_timeout_s
            elif now > deadline:
                raise EchoTimeout(
                    f"no SYNC_ACK for tick {steps.tick} within {cfg.bench.echo_timeout_s:g} s "
                    "(is auv-onboard running in lock-step on this bus?)"
                )
            if msg is not None and steps.take(msg):
                break
        if steps.close_period():
            return
        if not result.started:
            # Before the start, pace the SYNCs by the wall clock (nothing to simulate, no need to hurry).
            next_wall += steps.period_s
            delay = next_wall - time.monotonic()
            if delay > 0:
                stop.wait(delay)
            else:
                next_wall = time.monotonic()


def _run_realtime(
    bench: Bench, port: BusPort, cfg: HilConfig, stop: threading.Event, writer: Any, result: BenchResult
) -> None:
    period = bench.setup.control_period_s
    next_wall = time.monotonic()
    stop_at: list[float] = []
    last_hb_s = -math.inf
    result.started = True
    result._t_start_wall = time.monotonic()
    while not stop.is_set():
        for msg in port.drain():
            result.onboard_state = _onboard_state(msg, result.onboard_state)
            bench.node.take(msg)
        cmd = bench.period(integrate=True)
        t = bench.state.t_s
        msgs: list[m.BusMessage] = []
        for meas in bench.pending:
            msgs.extend(sensor_frames(meas))
        bench.pending.clear()
        msgs.extend(bench.status_frames(t, port.receiver.rejected_total))
        if t - last_hb_s >= 1.0 - 1e-9:
            msgs.extend(_heartbeats(t, bench.node.watchdog.failsafe))
            last_hb_s = t
        port.send_all(msgs)
        result.ticks += 1
        if writer is not None:
            writer.writerow(bench.truth_row(cmd, result.onboard_state))
        if _should_stop(bench, cfg, result, stop_at):
            return
        next_wall += period
        delay = next_wall - time.monotonic()
        if delay > 0:
            stop.wait(delay)
        elif delay < -period:
            next_wall = time.monotonic()  # fell behind by more than a period: do not try to catch up


# --- CLI ---------------------------------------------------------------------------------------------
def _run_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="auv-hil run",
        description=(
            "Run the HIL bench. Hosts the CAN hub (remote bus) and flies the 6-DOF ISiMI100 model. Reads "
            "FIN_CMD and PROP_CMD (and SYNC_ACK in lock-step); publishes AHRS, DEPTH, DVL, POSITION_FIX at "
            "the sensor profile's rates, FIN_STATUS and PROP_STATUS every control period, actuator and "
            "sensor heartbeats at 1 Hz. Time modes: realtime (default; paced by the monotonic clock) or "
            "lockstep (one SYNC per control period, integrates after the onboard's SYNC_ACK; simulated time "
            "starts when the onboard reports RUNNING; no wall clock is read, so runs repeat exactly)."
        ),
    )
    p.add_argument("--config", help=f"bench TOML (default {DEFAULT_CONFIG_PATH})")
    p.add_argument("--mode", choices=["realtime", "lockstep"], help="time mode (overrides [bench] time_mode)")
    p.add_argument("--channel", help="bus channel (overrides [bus] channel), e.g. ws://127.0.0.1:54701/")
    p.add_argument(
        "--record", help="write every frame to this .blf, .asc or .log (candump -l: cantools reads it) file"
    )
    p.add_argument("--truth-log", help="CSV of truth and commands, one row per control period")
    p.add_argument("--start", help="initial pose X,Y,DEPTH,YAW_DEG (NED m, deg)")
    p.add_argument("--current", help="SPEED_MPS,DIR_DEG (the direction the water flows towards)")
    p.add_argument("--seed", type=int, help="noise seed")
    p.add_argument("--duration", type=float, help="simulated seconds after the start (0 = until stopped)")
    p.add_argument("--stop-on", action="append", help="end when the onboard reports this state (repeatable)")
    p.add_argument("--stop-delay", type=float, help="simulated seconds to run on after --stop-on")
    p.add_argument("--profile", choices=["basin", "sea"], help="sensor profile")
    p.add_argument(
        "--fault",
        action="append",
        default=[],
        metavar="kind=KIND,KEY=VALUE,...",
        help=(
            "inject a fault (repeatable; simulated s after the start): kind=dvl_dropout|fix_outage,start_s=S"
            "[,duration_s=S]; kind=compass_bias,start_s=S,bias_deg=D; kind=depth_stuck,start_s=S; "
            "kind=fin_stuck,fin=rudder|stern_port|stern_starboard,start_s=S,angle_deg=D; "
            "kind=thrust_loss,start_s=S,fraction=F (0-1]. duration_s is optional for every kind (absent: "
            "to the end). Each start and end is logged, in the truth log's fault_<kind> columns and in the "
            "summary JSON. A bad fault: one line and exit 2"
        ),
    )
    p.add_argument("--summary-json", help="write a summary of the run to this file at the end")
    p.add_argument("--log-level", default="INFO")
    return p


def _floats(text: str, n: int, what: str) -> list[float]:
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        raise ConfigError(f"{what}: expected {n} comma-separated numbers, got {text!r}") from None
    if len(values) != n or not all(math.isfinite(v) for v in values):
        raise ConfigError(f"{what}: expected {n} finite comma-separated numbers, got {text!r}")
    return values


def _fault_option(text: str) -> Fault:
    """One ``--fault`` (:func:`hil_sim.model.faults.parse_fault_option`); a bad one: one ConfigError line."""
    try:
        return fault_model.parse_fault_option(text)
    except FaultError as exc:
        raise ConfigError(f"--fault {text!r}: {exc}") from None


def run_main(argv: list[str]) -> int:
    args = _run_parser().parse_args(join_negative_values(argv, NUMERIC_OPTIONS))
    logging.basicConfig(
        level=getattr(logging, str(args.log_level).upper(), logging.INFO),
        format="%(asctime)s %(levelname)s %(name)s: %(message)s",
    )
    logging.getLogger("can_remote").setLevel(logging.WARNING)
    try:
        over: dict[str, dict[str, Any]] = {"bench": {}, "bus": {}, "initial": {}, "current": {}}
        if args.mode:
            over["bench"]["time_mode"] = args.mode
        if args.channel:
            over["bus"]["channel"] = args.channel
        if args.record:
            over["bus"]["record"] = args.record
        if args.truth_log:
            over["bench"]["truth_log"] = args.truth_log
        if args.seed is not None:
            over["bench"]["seed"] = args.seed
        if args.duration is not None:
            over["bench"]["duration_s"] = args.duration
        if args.stop_on:
            over["bench"]["stop_on_state"] = list(args.stop_on)
        if args.stop_delay is not None:
            over["bench"]["stop_delay_s"] = args.stop_delay
        if args.profile:
            over["bench"]["sensor_profile"] = args.profile
        if args.start:
            x, y, depth, yaw = _floats(args.start, 4, "--start")
            over["initial"] = {"x_m": x, "y_m": y, "depth_m": depth, "yaw_deg": yaw}
        if args.current:
            speed, direction = _floats(args.current, 2, "--current")
            over["current"] = {"speed_mps": speed, "direction_deg": direction}
        cfg = load_hil_config(args.config, over)
        faults = tuple(_fault_option(text) for text in args.fault)
    except ConfigError as exc:
        print(f"auv-hil: {exc}", file=sys.stderr)
        return 2
    stop = threading.Event()

    def _stop(signum: int, _frame: Any) -> None:
        stop.set()

    signal.signal(signal.SIGINT, _stop)
    signal.signal(signal.SIGTERM, _stop)
    log.info("bench: %s, %s bus %s", cfg.bench.time_mode, cfg.bus.interface, cfg.bus.channel)
    try:
        result = run_bench(cfg, stop, faults=faults)
    except ConfigError as exc:  # e.g. the vehicle parameter file ([bench] params): one line, as above
        print(f"auv-hil: {exc}", file=sys.stderr)
        return 2
    except (EchoTimeout, BusUnavailable, OSError) as exc:
        print(f"auv-hil: {exc}", file=sys.stderr)
        return 3 if isinstance(exc, EchoTimeout) else 1
    log.info(
        "bench stopped (%s): %d ticks, %.1f s simulated in %.1f s; longest command gap %.3f s "
        "(actuator command timeout %.3g s)",
        result.stop_reason or "signal",
        result.ticks,
        result.sim_time_s,
        result.wall_time_s,
        result.max_command_gap_s,
        result.command_timeout_s,
    )
    if args.summary_json:
        summary = {k: v for k, v in result.__dict__.items() if not k.startswith("_")}
        Path(args.summary_json).write_text(json.dumps(summary, indent=2))
    return 1 if result.bus_lost else 0


def main(argv: list[str]) -> int:
    """Entry for ``auv-hil run ...`` and ``auv-hil scenario ...`` (argv starts with the sub-command)."""
    if argv[0] == "run":
        return run_main(argv[1:])
    from hil_sim.scenario import main as scenario_main

    return scenario_main(argv[1:])
