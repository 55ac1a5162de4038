"""Loop benchmark (issue 5 point 9): tick compute time and real-time wake-up lateness.

``run(quick)`` returns the flat section ``loop`` (unit-suffixed names, merged by ``auv-bench``). It measures
and reports; it asserts nothing about time. Two parts:

(a) **Tick compute** of :meth:`onboard.app.loop.ControlLoop.tick` with the real
    :class:`onboard.core.autopilot.Autopilot` (the default ``onboard/config/onboard.toml``), a one-goal
    mission
    RUNNING with its path already planned (planning excluded: the ticks up to and including the planning one
    are warm-up, not timed), on a python-can ``virtual`` bus. Each tick a sensor node on the same virtual
    channel sends a realistic set of frames (AHRS attitude + rates, depth, DVL, position fix, fin and
    propeller status) of a vehicle that flies the guidance reference with small seeded noise; the loop drains
    them into its cache, then ``tick`` runs (navigation filter, failsafes, mission, guidance, PD, saturation,
    E2E encode + send of FIN_CMD and PROP_CMD, telemetry). Time is synthetic (``k * period``), so the run is
    repeatable.
    Figures: ``tick_compute_p50_us``, ``tick_compute_p99_us``, ``tick_compute_mean_us``,
    ``tick_compute_max_us``; ``autopilot_step_p50_us`` / ``autopilot_step_p99_us`` (the autopilot's share
    of the tick; the rest is E2E encode, virtual-bus send and telemetry); ``loop_own_p50_us`` /
    ``loop_own_p99_us`` (that rest: tick minus autopilot step, per tick); ``drain_decode_p50_us`` /
    ``drain_decode_p99_us`` (the bus drain and E2E decode of the tick's 7 frames, outside ``tick``);
    ``tick_compute_ticks``, ``tick_compute_running_ticks``, ``tick_compute_replanned`` (sanity: all timed
    ticks RUNNING, no re-plan), ``tick_compute_rate_hz``.
(b) **Wake-up lateness** of :meth:`ControlLoop.run_realtime` at 100 Hz on the monotonic clock over 60 s (5 s
    with ``quick``), once with the configured hybrid wait (sleep, then spin the last ``spin_s``) and once
    sleep-only (``spin_s = 0``) in the same run. Lateness = wake-up time - deadline; a miss is a wake-up later
    than 10 % of the period (1 ms). The CPU cost of each variant is process CPU time / wall time.
    Figures: ``lateness_{hybrid,sleep}_{p50,p90,p99,max}_us``, ``misses_{hybrid,sleep}``,
    ``overruns_{hybrid,sleep}``, ``cpu_fraction_{hybrid,sleep}``, ``wakeups_{hybrid,sleep}``,
    ``cpu_steal_pct_{hybrid,sleep}`` (the share of all CPUs' time the hypervisor took during that run, from
    /proc/stat: on a VM, late wake-ups of milliseconds are usually the vCPU not running at all), the ratios
    ``lateness_p99_sleep_over_hybrid_ratio`` and ``cpu_fraction_hybrid_over_sleep_ratio``, and ``spin_us``,
    ``realtime_rate_hz``, ``realtime_duration_s``.
(c) **Ticks while a large plan is computed** (issue 9: planning never in the tick). A START with 400 fence
    circles (one on the leg, 399 in a grid around it): the plan is computed by the loop's planning worker
    (:class:`onboard.app.planning.PlanWorker`, real-time mode) while the autopilot keeps ticking at 20 Hz on
    the wall clock (the sensors of a vehicle at rest, as a dict: no bus). Figures:
    ``plan400_wall_ms`` (from the request to the plan's arrival), ``plan400_ticks_waiting`` (the ticks that
    ran meanwhile, holding still), ``plan400_tick_p50_us`` / ``plan400_tick_max_us`` (the ticks while the
    worker plans) against ``plan400_reference_tick_p50_us`` / ``..._max_us`` (the same ticks after), and
    ``plan400_tick_max_over_reference_ratio``. Before the worker existed the whole plan ran inside one tick.
"""

from __future__ import annotations

import dataclasses
import gc
import math
import os
import random
import threading
import time
from dataclasses import dataclass
from typing import Any, cast

from onboard.app.config import OnboardConfig, load_config
from onboard.app.loop import ControlLoop, LoopConfig
from onboard.core.autopilot import Autopilot
from onboard.core.mission.model import Goal, Mission
from onboard.core.mission.state import MissionState
from onboard.core.record import TickRecord
from onboard.protocol import messages as m
from onboard.protocol.bus import BusConfig, open_bus
from onboard.protocol.codec import Codec
from onboard.protocol.port import BusPort

# The frames the onboard node listens to (as in onboard.app.runtime; SYNC is not sent here).
_LISTEN = (m.AhrsAttitude, m.AhrsRates, m.DepthMeas, m.DvlVelocity, m.PositionFix, m.FinStatus, m.PropStatus)

# (a): start and goal of the timed mission: a turn, then a long straight, so the whole timed run is RUNNING.
_START = (0.0, 0.0, 1.0, math.pi / 2.0)  # x_m, y_m, depth_m, yaw_rad
_GOAL = Goal(x_m=300.0, y_m=200.0, depth_m=2.0, yaw_rad=0.0)
_SEED = 20240605
_WARMUP_TICKS_MAX = 200

REALTIME_RATE_HZ = 100.0
MISS_FRACTION = 0.10  # a wake-up later than 10 % of the period is a miss


def _percentile(values: list[float], q: float) -> float:
    """Nearest-rank percentile, ``q`` in [0, 100] (NaN for no values)."""
    if not values:
        return math.nan
    ordered = sorted(values)
    k = max(0, min(len(ordered) - 1, math.ceil(q / 100.0 * len(ordered)) - 1))
    return ordered[k]


def _virtual_channel(tag: str) -> str:
    """A channel name of this process only, so two benchmark runs on one machine never hear each other."""
    return f"loop-bench-{tag}-{os.getpid()}-{time.monotonic_ns()}"


# --- (a) tick compute ------------------------------------------------------------------------------
@dataclass
class _Truth:
    """The simulated vehicle of part (a): it flies the guidance reference (NED, m, rad, m/s, rad/s)."""

    x_m: float
    y_m: float
    depth_m: float
    yaw_rad: float
    speed_mps: float = 0.0
    yaw_rate_radps: float = 0.0

    def follow(self, out: TickRecord) -> None:
        r = out.reference
        if r is None:
            return
        self.x_m, self.y_m, self.depth_m, self.yaw_rad = r.x_m, r.y_m, max(r.depth_m, 0.0), r.yaw_rad
        self.speed_mps, self.yaw_rate_radps = r.speed_mps, r.yaw_rate_radps


def _sensor_frames(truth: _Truth, rng: random.Random, now_s: float) -> list[m.BusMessage]:
    """One tick's sensor and actuator-status frames (basin profile: mm-level fixes, every tick)."""
    g = rng.gauss
    yaw = math.remainder(truth.yaw_rad + g(0.0, 0.002), 2.0 * math.pi)
    return [
        m.AhrsAttitude(g(0.0, 0.002), g(0.0, 0.002), yaw, now_s),
        m.AhrsRates(g(0.0, 0.001), g(0.0, 0.001), truth.yaw_rate_radps + g(0.0, 0.001), now_s),
        m.DepthMeas(truth.depth_m + g(0.0, 0.01), now_s),
        m.DvlVelocity(truth.speed_mps + g(0.0, 0.005), g(0.0, 0.005), g(0.0, 0.005), True, now_s),
        m.PositionFix(truth.x_m + g(0.0, 0.002), truth.y_m + g(0.0, 0.002), now_s),
        m.FinStatus(0.0, 0.0, 0.0, False, False, now_s),
        m.PropStatus(25.0, True, False, False, 0, now_s),
    ]


class _TimedAutopilot:
    """Forwards to the real autopilot and keeps the time of each ``step`` (one call and two clock reads
    more: well under 1 us), so the tick splits into the autopilot's share and the loop's own (encode, send,
    record)."""

    def __init__(self, inner: Autopilot) -> None:
        self.inner = inner
        self.step_s: list[float] = []
        self.timing = False

    def step(self, cache: dict[type, Any], now_s: float, dt_s: float) -> TickRecord:
        t0 = time.perf_counter()
        out = self.inner.step(cache, now_s, dt_s)
        if self.timing:
            self.step_s.append(time.perf_counter() - t0)
        return out

    def note_loop_late(self, late_s: float) -> None:
        self.inner.note_loop_late(late_s)

    def note_encode_fault(self, message_name: str, reason: str) -> None:
        self.inner.note_encode_fault(message_name, reason)

    def note_bus(self, lost_reason: str) -> None:
        self.inner.note_bus(lost_reason)

    def before_step(self) -> None:
        self.inner.before_step()

    def take_plan_request(self) -> Any:
        return self.inner.take_plan_request()

    def plan_done(self, request_id: int, result: Any) -> None:
        self.inner.plan_done(request_id, result)


def tick_compute(quick: bool = False, config: OnboardConfig | None = None) -> dict[str, float]:
    """Part (a): time ``ControlLoop.tick`` with the real autopilot, planning excluded (see the docstring)."""
    cfg = config or load_config()
    n_ticks = 1000 if quick else 5000
    channel = _virtual_channel("tick")
    now = [0.0]

    def clock() -> float:
        return now[0]

    codec = Codec()
    onboard_port = BusPort(
        open_bus(BusConfig(interface="virtual", channel=channel)),
        clock,
        [codec.frame_id(c) for c in _LISTEN],
        codec,
    )
    sensor_port = BusPort(open_bus(BusConfig(interface="virtual", channel=channel)), clock, (), Codec())
    autopilot = Autopilot(cfg.core)
    autopilot.replace_mission(Mission((_GOAL,)))
    autopilot.request_autostart()  # starts at the first tick with a valid navigation solution
    timed = _TimedAutopilot(autopilot)
    loop = ControlLoop(onboard_port, timed, cfg.loop, clock=clock)
    truth = _Truth(*_START)
    rng = random.Random(_SEED)
    period = cfg.loop.period_s

    tick_s: list[float] = []
    drain_s: list[float] = []
    states: dict[str, int] = {}
    try:
        k = 0
        # Warm-up: navigation converges, autostart, the path is planned (not timed).
        while k < _WARMUP_TICKS_MAX:
            sensor_port.send_all(_sensor_frames(truth, rng, now[0]))
            loop.take(onboard_port.drain())
            out = cast(TickRecord, loop.tick(now[0]))
            sensor_port.drain()
            truth.follow(out)
            k += 1
            now[0] = k * period
            if autopilot.status.state is MissionState.RUNNING and autopilot.path is not None:
                break
        if autopilot.path is None or autopilot.status.state is not MissionState.RUNNING:
            raise RuntimeError(
                f"loop bench: mission not running after {k} ticks "
                f"(state {autopilot.status.state.name}, planner error {autopilot.planner_error!r})"
            )
        planned_index = autopilot.path_goal_index
        perf = time.perf_counter
        timed.timing = True
        for _ in range(n_ticks):
            sensor_port.send_all(_sensor_frames(truth, rng, now[0]))
            t0 = perf()
            loop.take(onboard_port.drain())
            t1 = perf()
            out = cast(TickRecord, loop.tick(now[0]))
            t2 = perf()
            drain_s.append(t1 - t0)
            tick_s.append(t2 - t1)
            sensor_port.drain()  # the actuator node's side: the command frames (not timed)
            truth.follow(out)
            states[out.status.state.name] = states.get(out.status.state.name, 0) + 1
            k += 1
            now[0] = k * period
        replanned = autopilot.path_goal_index != planned_index
    finally:
        loop.close()
        onboard_port.close()
        sensor_port.close()

    us = 1e6
    loop_own_s = [t - a for t, a in zip(tick_s, timed.step_s, strict=True)]
    return {
        "tick_compute_p50_us": _percentile(tick_s, 50) * us,
        "tick_compute_p99_us": _percentile(tick_s, 99) * us,
        "tick_compute_mean_us": sum(tick_s) / len(tick_s) * us,
        "tick_compute_max_us": max(tick_s) * us,
        "autopilot_step_p50_us": _percentile(timed.step_s, 50) * us,
        "autopilot_step_p99_us": _percentile(timed.step_s, 99) * us,
        "loop_own_p50_us": _percentile(loop_own_s, 50) * us,
        "loop_own_p99_us": _percentile(loop_own_s, 99) * us,
        "drain_decode_p50_us": _percentile(drain_s, 50) * us,
        "drain_decode_p99_us": _percentile(drain_s, 99) * us,
        "tick_compute_ticks": float(len(tick_s)),
        "tick_compute_running_ticks": float(states.get("RUNNING", 0)),
        "tick_compute_replanned": float(replanned),
        "tick_compute_rate_hz": cfg.loop.rate_hz,
    }


# --- (b) wake-up lateness ---------------------------------------------------------------------------
@dataclass(frozen=True)
class _StubOutput:
    """A constant autopilot output: neutral fins, propeller off, SAFE."""

    rudder_rad: float = 0.0
    stern_port_rad: float = 0.0
    stern_starboard_rad: float = 0.0
    propeller_rps: float = 0.0
    mode: m.ActuatorMode = m.ActuatorMode.SAFE
    mission_state: m.MissionStateCode = m.MissionStateCode.IDLE

    def telemetry_row(self) -> dict[str, float | int | str]:
        return {}


class _StubAutopilot:
    """A trivial autopilot for part (b): the lateness figures measure the scheduler (the hybrid or
    sleep-only wait of ``run_realtime``), not the autopilot's compute time, which part (a) measures."""

    _OUT = _StubOutput()

    def step(self, cache: dict[type, Any], now_s: float, dt_s: float) -> _StubOutput:
        return self._OUT

    def note_loop_late(self, late_s: float) -> None:
        pass

    def note_encode_fault(self, message_name: str, reason: str) -> None:
        pass

    def note_bus(self, lost_reason: str) -> None:
        pass

    def before_step(self) -> None:
        pass


def _cpu_steal_jiffies() -> tuple[int, int]:
    """(steal, total) jiffies of all CPUs from /proc/stat (Linux; (0, 0) elsewhere)."""
    try:
        with open("/proc/stat") as f:
            fields = [int(v) for v in f.readline().split()[1:]]
    except (OSError, ValueError):
        return 0, 0
    return (fields[7] if len(fields) > 7 else 0), sum(fields[:8])


def _realtime_once(loop_cfg: LoopConfig, duration_s: float) -> dict[str, float]:
    """Run ``run_realtime`` for ``duration_s`` on the monotonic clock; lateness, misses and CPU share."""
    port = BusPort(open_bus(BusConfig(interface="virtual", channel=_virtual_channel("rt"))), time.monotonic)
    loop = ControlLoop(port, _StubAutopilot(), loop_cfg)
    stop = threading.Event()
    timer = threading.Timer(duration_s, stop.set)
    try:
        gc.collect()
        timer.start()
        steal0, total0 = _cpu_steal_jiffies()
        cpu0, wall0 = time.process_time(), time.monotonic()
        loop.run_realtime(stop)
        cpu1, wall1 = time.process_time(), time.monotonic()
        steal1, total1 = _cpu_steal_jiffies()
    finally:
        timer.cancel()
        loop.close()
        port.close()
    lateness = list(loop.stats.lateness_s)
    miss_s = MISS_FRACTION * loop_cfg.period_s
    us = 1e6
    return {
        "p50_us": _percentile(lateness, 50) * us,
        "p90_us": _percentile(lateness, 90) * us,
        "p99_us": _percentile(lateness, 99) * us,
        "max_us": (max(lateness) if lateness else math.nan) * us,
        "misses": float(sum(1 for x in lateness if x > miss_s)),
        "overruns": float(loop.stats.overruns),
        "wakeups": float(len(lateness)),
        "cpu_fraction": (cpu1 - cpu0) / (wall1 - wall0),
        "cpu_steal_pct": 100.0 * (steal1 - steal0) / (total1 - total0) if total1 > total0 else math.nan,
    }


def wakeup_lateness(quick: bool = False, config: OnboardConfig | None = None) -> dict[str, float]:
    """Part (b): the hybrid wait (configured ``spin_s``) and sleep-only, side by side, at 100 Hz."""
    cfg = config or load_config()
    duration = 5.0 if quick else 60.0
    base = dataclasses.replace(cfg.loop, rate_hz=REALTIME_RATE_HZ, telemetry_csv="", history=16)
    variants = {"hybrid": base, "sleep": dataclasses.replace(base, spin_s=0.0)}
    res = {name: _realtime_once(loop_cfg, duration) for name, loop_cfg in variants.items()}
    out: dict[str, float] = {}
    for name, figs in res.items():
        for key in ("p50_us", "p90_us", "p99_us", "max_us"):
            out[f"lateness_{name}_{key}"] = figs[key]
        for key in ("misses", "overruns", "wakeups", "cpu_fraction", "cpu_steal_pct"):
            out[f"{key}_{name}"] = figs[key]
    h, s = res["hybrid"], res["sleep"]
    out["lateness_p99_sleep_over_hybrid_ratio"] = s["p99_us"] / h["p99_us"] if h["p99_us"] > 0 else math.nan
    out["cpu_fraction_hybrid_over_sleep_ratio"] = (
        h["cpu_fraction"] / s["cpu_fraction"] if s["cpu_fraction"] > 0 else math.nan
    )
    out["spin_us"] = base.spin_s * 1e6
    out["miss_threshold_us"] = MISS_FRACTION * base.period_s * 1e6
    out["realtime_rate_hz"] = REALTIME_RATE_HZ
    out["realtime_duration_s"] = duration
    return out


def tick_while_planning(quick: bool = False, config: OnboardConfig | None = None) -> dict[str, float]:
    """Part (c): tick compute while the planning worker plans a 400-obstacle leg (see the docstring)."""
    from onboard.app.planning import PlanWorker
    from onboard.core import commands as c
    from onboard.core.mission.model import Obstacle

    cfg = config or load_config()
    period = cfg.loop.period_s
    core = cfg.core
    ap = Autopilot(dataclasses.replace(core, mission=dataclasses.replace(core.mission, max_obstacles=400)))
    # one circle on the leg (the path must go round it) and 399 in a 7 m grid around it (the tangent graph)
    grid = [(-69.5 + 7.0 * i, -69.5 + 7.0 * j) for i in range(22) for j in range(22)]
    around = [Obstacle(x, y, 0.3) for x, y in grid if not (abs(y) < 9.0 and -12.0 < x < 32.0)]
    fence = (Obstacle(10.0, 0.0, 1.5), *around[:399])
    ap.replace_mission(Mission((Goal(20.0, 0.0, 1.0, 0.0),), fence))
    worker = PlanWorker(ap, lockstep=False)

    def sensors(t: float) -> dict[type, Any]:
        msgs = [
            m.AhrsAttitude(0.0, 0.0, 0.0, t),
            m.AhrsRates(0.0, 0.0, 0.0, t),
            m.DepthMeas(1.0, t),
            m.DvlVelocity(0.0, 0.0, 0.0, True, t),
            m.PositionFix(0.0, 0.0, t),
        ]
        return {type(msg): msg for msg in msgs}

    t0 = time.monotonic()
    ap.step(sensors(0.0), 0.0, period)
    ap.handle(c.Arm("bench"))
    ap.handle(c.Start(None, "bench"))
    waiting: list[float] = []
    after: list[float] = []
    asked = time.perf_counter()
    plan_wall_s = math.nan
    k, n_after = 0, 20 if quick else 60
    nxt = time.monotonic()
    try:
        while len(after) < n_after and k < 2000:
            k += 1
            now = time.monotonic() - t0
            t1 = time.perf_counter()
            worker.before_step()
            ap.step(sensors(now), now, period)
            worker.after_step()
            dt = time.perf_counter() - t1
            if ap.path is None:
                waiting.append(dt)
            else:
                if math.isnan(plan_wall_s):
                    plan_wall_s = time.perf_counter() - asked
                after.append(dt)
            nxt += period
            time.sleep(max(0.0, nxt - time.monotonic()))
    finally:
        worker.close()
    us = 1e6
    ref_max = max(after) if after else math.nan
    return {
        "plan400_wall_ms": plan_wall_s * 1e3,
        "plan400_ticks_waiting": float(len(waiting)),
        "plan400_tick_p50_us": _percentile(waiting, 50) * us if waiting else math.nan,
        "plan400_tick_max_us": max(waiting) * us if waiting else math.nan,
        "plan400_reference_tick_p50_us": _percentile(after, 50) * us if after else math.nan,
        "plan400_reference_tick_max_us": ref_max * us,
        "plan400_tick_max_over_reference_ratio": (max(waiting) / ref_max) if waiting and after else math.nan,
    }


def link_publish_take(quick: bool = False) -> dict[str, float]:
    """What the MAVLink link costs the loop per tick: one ``publish`` of the tick's snapshot and one
    ``take_requests``, with the link's I/O thread running on a loopback socket (its own state directory).
    Figures: ``link_publish_take_us`` (mean of the pair), ``link_publish_take_pairs``. The test suite
    checks what the pair does (the latest snapshot kept, nothing queued); how long it takes is measured
    here."""
    import tempfile

    from onboard.adapters.mavlink.api import VehicleSnapshot
    from onboard.adapters.mavlink.config import MavlinkConfig
    from onboard.app.standalone import make_link
    from onboard.app.store import StateStore

    pairs = 2_000 if quick else 20_000
    with tempfile.TemporaryDirectory() as state_dir:
        link = make_link(MavlinkConfig(endpoints=("udpin:127.0.0.1:0",)), store=StateStore(state_dir))
        link.start()
        try:
            t0 = time.perf_counter()
            for i in range(pairs):
                link.publish(VehicleSnapshot(t_s=i * 0.05))
                link.take_requests()
            elapsed_s = time.perf_counter() - t0
        finally:
            link.stop()
    return {"link_publish_take_us": elapsed_s / pairs * 1e6, "link_publish_take_pairs": float(pairs)}


def run(quick: bool = False) -> dict[str, float]:
    """The parts (see the module docstring) and the link's cost per tick (:func:`link_publish_take`)."""
    cfg = load_config()
    return {
        **tick_compute(quick, cfg),
        **wakeup_lateness(quick, cfg),
        **tick_while_planning(quick, cfg),
        **link_publish_take(quick),
    }


if __name__ == "__main__":  # pragma: no cover
    import json
    import sys

    sys.stdout.write(json.dumps(run(quick="--quick" in sys.argv), indent=2) + "\n")
