"""One campaign run: the real onboard core against the real simulator in one process, in lock-step.

The two sides are the programs' own pieces, wired as ``auv-hil scenario`` wires them over processes, but on a
``local`` python-can bus of their own (:class:`onboard.protocol.local_bus.LocalBus`, one channel per run: each
frame is handed over without a copy) and driven from one thread:

- the bench: :class:`hil_sim.bench_program.Bench` (6-DOF model, actuator node with its watchdog, sensors)
  through :class:`hil_sim.bench_program.LockstepBench` (the same three calls ``auv-hil run --mode lockstep``
  loops over);
- the onboard: :class:`onboard.app.loop.ControlLoop` with the real :class:`onboard.core.autopilot.Autopilot`,
  fed frame by frame (:meth:`~onboard.app.loop.ControlLoop.feed`, what ``run_lockstep`` does);
- the mission goes to the vehicle as through its MAVLink door: the validator every door runs
  (:func:`onboard.core.mission.validate.check_mission`, without the vehicle's pose: leg 0 is planned at
  START from where the vehicle is), then ``ReplaceMission`` and the autostart's ARM and START, each judged
  by ``Autopilot.handle``. A mission the vehicle refuses, or cannot plan at START (it holds), is a run with
  ``planned = false`` and the vehicle's reason.

Per period: the bench offers its frames and SYNC; the onboard takes what its bus delivered (the SYNC ticks
it: commands, heartbeat, SYNC_ACK); the bench takes the onboard's frames up to the SYNC_ACK and integrates.
Frames, codec, E2E checks, counters and staleness are those of the processes; only the transport differs.

Every figure of the result comes from the simulator's truth (:mod:`auv_campaign.metrics`), never from the
onboard's own view; the onboard's final state and reason are reported next to it.
"""

from __future__ import annotations

import dataclasses
import functools
import itertools
import math
import os
import time
import uuid
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from auv_campaign.metrics import END_STATES, run_row
from auv_campaign.spec import RunSpec
from hil_sim.bench_program import (
    BENCH_LISTENS,
    Bench,
    BenchConfig,
    BenchResult,
    HilConfig,
    InitialConfig,
    LockstepBench,
    WaterCurrentConfig,
)
from hil_sim.model.params import VehicleParams
from hil_sim.model.variants import vehicle_params
from onboard.app.config import OnboardConfig
from onboard.app.loop import ControlLoop
from onboard.app.runtime import LISTEN, build_config, bus_limits_from_dbc
from onboard.core.autopilot import Autopilot
from onboard.core.executive.monitors import latest_end_s
from onboard.core.mission.model import Goal, Mission, Obstacle
from onboard.core.mission.validate import check_mission
from onboard.core.params import BusLimits
from onboard.core.planner.errors import PlannerError
from onboard.core.planner.path import Path
from onboard.core.plans import last_goal_run_in_m, plan_to_goal
from onboard.protocol.bus import open_bus
from onboard.protocol.codec import Codec
from onboard.protocol.port import BusPort

#: Onboard states that end a mission (the run goes on the spec's ``observe_after_end_s`` more simulated
#: seconds: a glide, a sink or a collision after the end shows in its figures).
STOP_STATES = END_STATES
#: Simulated seconds the vehicle may take, before moving, to get a valid navigation solution and start.
START_ALLOWANCE_S = 30.0
#: Added to the nominal path time (length / planned speed): the start from rest.
ACCELERATION_ALLOWANCE_S = 5.0
MIN_TIME_LIMIT_S = 1.0
PATH_STEP_M = 0.05  # the nominal path's sampling (as ``auv-hil scenario``)
TRACK_EVERY = 4  # truth rows kept in a run's track (every 4th: 5 Hz at 20 Hz)

_channels = itertools.count()


@dataclass
class RunOutput:
    """What a run gives back: the row (``results.COLUMNS``), the decimated track and the measured path (per
    leg the first path the onboard flew, else the nominal one)."""

    row: dict[str, Any]
    track: dict[str, list[float]] = field(default_factory=dict)
    path: list[list[float]] = field(default_factory=list)
    truth: list[list[Any]] = field(default_factory=list)  # every truth row (``TRUTH_COLUMNS``); kept on ask
    # with the truth: the onboard's guidance reference each tick, (t_s, x_m, y_m, yaw_rad) of the point
    reference: list[tuple[float, float, float, float]] = field(default_factory=list)

    def to_json(self, spec: RunSpec) -> dict[str, Any]:
        return {"run_id": spec.run_id, "spec": spec.to_dict(), "row": self.row, "track": self.track,
                "path": self.path}  # fmt: skip


class _Rows:
    """A ``csv.writer`` look-alike that keeps the truth rows in memory."""

    def __init__(self) -> None:
        self.rows: list[list[Any]] = []

    def writerow(self, row: list[Any]) -> None:
        self.rows.append(row)


def onboard_config(spec: RunSpec) -> OnboardConfig:
    """The onboard configuration of a run: the packaged file, lock-step, no telemetry file, and the run's
    overrides (``auv-onboard run --set`` syntax)."""
    return effective_onboard_config(tuple(spec.onboard_sets()))


# What runs of one worker share, built once per process (all frozen, or stateless like the codec: the
# alive counters live in each port's sender and receiver, not in the codec).
@functools.lru_cache(maxsize=64)
def effective_onboard_config(sets: tuple[str, ...]) -> OnboardConfig:
    """The packaged onboard configuration with the campaign's lock-step settings (its bus the ``local``
    one, each run on a channel of its own) and ``sets``."""
    return build_config(
        None, ['loop.time_source="lockstep"', 'loop.telemetry_csv=""', 'bus.interface="local"', *sets]
    )


@functools.lru_cache(maxsize=64)
def vehicle_variant(scale: tuple[tuple[str, float], ...], sets: tuple[tuple[str, Any], ...]) -> VehicleParams:
    """The packaged vehicle model with a variant's scales and sets."""
    return vehicle_params(dict(scale), dict(sets))


@functools.cache
def _codec() -> Codec:
    return Codec()


@functools.cache
def _bus_limits() -> BusLimits:
    return bus_limits_from_dbc()


def mission_of(spec: RunSpec) -> Mission:
    mis = spec.mission
    goals = tuple(
        Goal(x, y, d, None if yaw is None else math.radians(yaw), mis.goal_radius_m(i))
        for i, (x, y, d, yaw) in enumerate(mis.goals)
    )
    return Mission(goals, tuple(Obstacle(x, y, r) for x, y, r in mis.obstacles))


def nominal_legs(spec: RunSpec, cfg: OnboardConfig) -> list[Path]:
    """The onboard planner's paths from the spec's start pose through every goal in order (leg i starts at
    goal i-1's pose), with the run's configuration (the last goal along the run-in's straight, as the
    vehicle plans it). Raises PlannerError when a leg cannot be planned."""
    mis = spec.mission
    x, y, depth, yaw_deg = mis.start
    pose = (x, y, math.radians(yaw_deg))
    legs: list[Path] = []
    obstacles = tuple(Obstacle(ox, oy, r) for ox, oy, r in mis.obstacles)
    m = cfg.mission
    last_run_in_m = last_goal_run_in_m(
        cfg.planner.goal_run_in_m, cfg.guidance.speed_mps, m.arrival_speed_mps, m.run_in_decel_mps2
    )
    for i, (gx, gy, gdepth, gyaw) in enumerate(mis.goals):
        path = plan_to_goal(
            pose,
            (gx, gy, None if gyaw is None else math.radians(gyaw)),
            cfg.planner,
            obstacles,
            start_depth_m=depth,
            goal_depth_m=gdepth,
            run_in_m=last_run_in_m if i == len(mis.goals) - 1 else 0.0,
        )
        legs.append(path)
        end = path.sample(path.length_m)
        pose, depth = (gx, gy, end.yaw_rad), gdepth
    return legs


def path_samples(legs: list[Path]) -> list[list[float]]:
    """``[[x_m, y_m, yaw_deg], ...]`` along the legs in order, every :data:`PATH_STEP_M`."""
    samples: list[list[float]] = []
    for path in legs:
        n = max(1, math.ceil(path.length_m / PATH_STEP_M))
        for i in range(0 if not samples else 1, n + 1):
            p = path.sample(min(i * PATH_STEP_M, path.length_m))
            samples.append([p.x_m, p.y_m, math.degrees(p.yaw_rad)])
    return samples


def time_limit_s(spec: RunSpec, length_m: float, speed_mps: float, supervised_s: float = 0.0) -> float:
    """``time_limit_factor`` x the nominal path time (length / speed + the start from rest), simulated s, or
    ``supervised_s`` if longer (:func:`supervised_bound_s`: the latest the vehicle's own leg monitors end
    the mission, so a run RUNNING at the limit is one they failed to end, never one they were not given the
    time to judge); at least ``MIN_TIME_LIMIT_S`` (the bench reads 0 as "no limit")."""
    nominal = length_m / speed_mps + ACCELERATION_ALLOWANCE_S
    return max(MIN_TIME_LIMIT_S, round(spec.time_limit_factor * nominal, 2), round(supervised_s, 2))


def supervised_bound_s(spec: RunSpec, cfg: OnboardConfig, lengths_m: list[float]) -> float:
    """The latest the vehicle's leg monitors end the run's mission (simulated s, the start's allowance
    included): :func:`onboard.core.executive.monitors.latest_end_s` (the one owner of that rule) for legs of
    ``lengths_m`` (the nominal paths; one leg straight to the last goal where none was planned) towards each
    goal from the one before, in the run's true current; 0 when the monitors set no bound (ETA off)."""
    mis = spec.mission
    points = [(mis.start[0], mis.start[1])] + [(g[0], g[1]) for g in mis.goals]
    if len(lengths_m) != len(mis.goals):  # no nominal plan: one leg straight to the last goal
        points = [points[0], points[-1]]
    bearings = [math.atan2(b[1] - a[1], b[0] - a[0]) for a, b in itertools.pairwise(points)]
    direction = math.radians(spec.current_dir_deg)
    current = (spec.current_speed_mps * math.cos(direction), spec.current_speed_mps * math.sin(direction))
    bound = latest_end_s(cfg.core, list(zip(lengths_m, bearings, strict=True)), current)
    return bound + START_ALLOWANCE_S if math.isfinite(bound) else 0.0


def vehicle_of(spec: RunSpec) -> VehicleParams:
    """The simulated vehicle of a run: the packaged model with the run's variant (built once per process)."""
    return vehicle_variant(spec.vehicle_scale, spec.vehicle_set)


def fly(spec: RunSpec, keep_truth: bool = False, timings: dict[str, float] | None = None) -> RunOutput:
    """Fly one run (see the module docstring) and measure it against the path the onboard planned (per leg
    its first; the nominal leg where it planned none; the nominal path sets the time limit).

    ``timings``: if given, the wall seconds (perf counter) spent in the onboard core's step
    (``onboard_core_s``), the simulator's period (``simulator_s``) and the whole lock-step drive
    (``drive_s``; the rest is codec, E2E, bus and loop bookkeeping) are added to it, and ``ticks``.
    """
    t_wall = time.perf_counter()
    cfg = onboard_config(spec)
    mission = mission_of(spec)
    start = spec.mission.start
    try:
        legs = nominal_legs(spec, cfg)
    except PlannerError:
        legs = []
    length = (
        sum(p.length_m for p in legs)
        if legs
        else math.hypot(spec.mission.goals[-1][0] - start[0], spec.mission.goals[-1][1] - start[1])
    )
    lengths = [p.length_m for p in legs] if legs else [length]
    limit = time_limit_s(spec, length, cfg.guidance.speed_mps, supervised_bound_s(spec, cfg, lengths))
    hil = HilConfig(
        bench=BenchConfig(
            time_mode="lockstep",
            control_rate_hz=cfg.loop.rate_hz,
            sensor_profile=spec.profile,  # type: ignore[arg-type]
            seed=spec.seed,
            # The limit holds until an end state; after one, the run goes on observe_after_end_s (_drive).
            duration_s=limit + spec.observe_after_end_s,
            stop_on_state=STOP_STATES,
            stop_delay_s=spec.observe_after_end_s,
        ),
        initial=InitialConfig(*start),
        current=WaterCurrentConfig(spec.current_speed_mps, spec.current_dir_deg),
    )
    bench = Bench(hil, vehicle_of(spec), faults=spec.faults)
    autopilot = Autopilot(cfg.core, bus_limits=_bus_limits())
    check = check_mission(mission, cfg.core)
    refused = "" if check.ok else f"mission refused: {check}"
    if not refused:
        verdict = autopilot.replace_mission(mission)
        refused = "" if verdict.accepted else verdict.reason
    if not refused:
        autopilot.request_autostart()
    truth = _Rows()
    result = BenchResult()
    reference: list[tuple[float, float, float, float]] = []
    nav_errors: list[tuple[float, float, float, float]] = []
    first_plans: dict[int, Path] = {}
    if not refused:
        if timings is not None:
            _time_calls(autopilot, "step", timings, "onboard_core_s")
            _time_calls(bench, "period", timings, "simulator_s")
        _record_first_plans(autopilot, first_plans)
        if keep_truth:
            _record_reference(autopilot, reference)
        _record_nav_errors(autopilot, bench, result, nav_errors)
        t_drive = time.perf_counter()
        _drive(bench, autopilot, cfg, hil, truth, result, limit)
        if timings is not None:
            timings["drive_s"] = timings.get("drive_s", 0.0) + time.perf_counter() - t_drive
            timings["ticks"] = timings.get("ticks", 0.0) + result.ticks
    status = autopilot.status
    notes = autopilot.take_notes()
    reason = refused or status.reason
    time_limit_reached = not refused and result.stop_reason.startswith("duration")
    if time_limit_reached:
        last = f"; the vehicle's last word: {notes[-1].text}" if notes else ""
        reason = f"time limit {limit:g} s reached in {status.state.name}{last}"
    elif not refused and not result.started:  # e.g. START refused (a goal it cannot make good): its words
        last = f"; the vehicle's last word: {notes[-1].text}" if notes else ""
        reason = f"never under way: {status.reason}{last}"
    # Measured against the path the onboard planned first for each leg (it plans from where the vehicle
    # is, which may pick another word than the ideal start), the nominal leg where it planned none.
    flown = [first_plans.get(i, leg) for i, leg in enumerate(legs)]
    samples = path_samples(flown) if legs else []
    row = run_row(
        spec,
        truth.rows,
        samples,
        planned=bool(samples) and result.started,
        final_state=status.state.name,
        final_reason=reason,
        time_limit_s=limit,
        arrival_radius_m=cfg.mission.arrival_radius_m,
        limits=cfg.control.limits,
        time_limit_reached=time_limit_reached,
        legs=[path_samples([leg]) for leg in flown],
        nav_errors=nav_errors,
    )
    row["sim_time_s"] = round(bench.state.t_s, 3)
    row["ticks"] = result.ticks
    row["wall_time_s"] = round(time.perf_counter() - t_wall, 3)
    track = _track(truth.rows)
    path = [[round(p[0], 3), round(p[1], 3)] for p in samples[:: max(1, round(0.25 / PATH_STEP_M))]]
    return RunOutput(row, track, path, truth.rows if keep_truth else [], reference)


def _record_first_plans(autopilot: Autopilot, out: dict[int, Path]) -> None:
    """Keep, per goal index, the first goal path ``autopilot`` (this instance) took to fly."""
    take, done = autopilot.take_plan_request, autopilot.plan_done
    asked: dict[int, Any] = {}

    def take_plan_request() -> Any:
        req = take()
        if req is not None:
            asked[req.request_id] = req
        return req

    def plan_done(request_id: int, result: Any) -> None:
        req = asked.pop(request_id, None)
        done(request_id, result)
        path = autopilot.path
        if req is not None and req.kind == "goal" and path is not None and path is result:  # taken, not stale
            out.setdefault(req.goal_index, path)

    autopilot.take_plan_request = take_plan_request  # type: ignore[method-assign]
    autopilot.plan_done = plan_done  # type: ignore[method-assign]


def _record_reference(autopilot: Autopilot, out: list[tuple[float, float, float, float]]) -> None:
    """Keep the guidance reference point of every tick of ``autopilot`` (this instance) in ``out``."""
    inner = autopilot.step

    def step(cache: dict[type, Any], now_s: float, dt_s: float) -> Any:
        result = inner(cache, now_s, dt_s)
        r = result.reference
        if r is not None:
            out.append((now_s, r.x_m, r.y_m, r.yaw_rad))
        return result

    autopilot.step = step  # type: ignore[method-assign]


def _record_nav_errors(
    autopilot: Autopilot, bench: Bench, result: BenchResult, out: list[tuple[float, float, float, float]]
) -> None:
    """Keep, each tick of ``autopilot`` while the simulated clock runs and its position is valid, the truth's
    error from the estimate (m, north and east) and the estimate's variances (m^2): the NEES columns'
    samples. The onboard ticks on the period's sensor frames before the bench integrates it, so the
    bench's state at that moment is the truth at the estimate's time."""
    inner = autopilot.step

    def step(cache: dict[type, Any], now_s: float, dt_s: float) -> Any:
        record = inner(cache, now_s, dt_s)
        nav = record.nav
        if result.started and nav.position_valid:
            body = bench.state.body
            out.append(
                (body.x_m - nav.x_m, body.y_m - nav.y_m, nav.position_std_x_m**2, nav.position_std_y_m**2)
            )
        return record

    autopilot.step = step  # type: ignore[method-assign]


def _drive(
    bench: Bench,
    autopilot: Autopilot,
    cfg: OnboardConfig,
    hil: HilConfig,
    truth: _Rows,
    result: BenchResult,
    limit_s: float,
) -> None:
    """Fly in lock-step until the bench stops (``observe_after_end_s`` after an end state, its
    ``stop_delay_s``), the time limit ``limit_s`` comes before any end state (``result.stop_reason``
    "duration ..."), or the vehicle never gets under way."""
    channel = f"campaign-{os.getpid()}-{next(_channels)}-{uuid.uuid4().hex[:8]}"
    bus = dataclasses.replace(cfg.bus, channel=channel)  # the campaign's [bus]: local
    codec = _codec()
    bench_listen = [codec.frame_id(c) for c in BENCH_LISTENS]
    bench_port = BusPort(open_bus(bus, listen_ids=bench_listen), lambda: bench.state.t_s, bench_listen, codec)
    steps = LockstepBench(bench, bench_port, hil, truth, result)
    # The onboard checks rates as on a vehicle, on the lock-step clock: tick x control period (it runs before
    # the start too, while the simulated time stands still; a period's frames share its tick); not with a loop
    # faster than the bus contract's (SYNC and status follow the loop). The bench's port does not: before the
    # start the onboard sends its heartbeat every tick, 20x its cycle.
    onboard_listen = [codec.frame_id(c) for c in LISTEN]
    onboard_port = BusPort(
        open_bus(bus, listen_ids=onboard_listen), lambda: steps.tick * steps.period_s, onboard_listen, codec
    )
    if codec.rates_checkable(steps.period_s):
        onboard_port.receiver.check_rates(receive_period_s=steps.period_s)
    loop = ControlLoop(onboard_port, autopilot, cfg.loop)
    if loop.plans is not None:
        loop.plans.lockstep = True
    max_idle_ticks = round(START_ALLOWANCE_S * cfg.loop.rate_hz)
    # A backstop only (the bench stops at the time limit): no run can keep its worker for ever.
    max_ticks = max_idle_ticks + round((hil.bench.duration_s + 1.0) * cfg.loop.rate_hz)
    ended = False
    try:
        while True:
            steps.offer()
            for msg in onboard_port.drain():
                loop.feed(msg)
            acked = False
            for msg in bench_port.drain():
                acked = steps.take(msg) or acked
            if not acked:
                raise RuntimeError(f"the onboard did not answer SYNC {steps.tick}")
            if steps.close_period():
                return
            ended = ended or autopilot.status.state.name in STOP_STATES
            if result.started and not ended and bench.state.t_s >= limit_s - 1e-9:
                result.stop_reason = f"duration {limit_s:g} s reached"
                return
            if not result.started and (
                steps.tick >= max_idle_ticks or autopilot.status.state.name in ("HOLD", "ABORT")
            ):
                return  # it never started (e.g. no plan at START): the autopilot's status says why
            if steps.tick >= max_ticks:
                raise RuntimeError(f"the run did not end within {max_ticks} ticks")
    finally:
        loop.close()
        onboard_port.close()
        bench_port.close()


def timed(
    inner: Callable[..., Any], timings: dict[str, float], key: str, count: str | None = None
) -> Callable[..., Any]:
    """``inner`` that adds its wall time (perf counter, s) to ``timings[key]`` and, with ``count``, one to
    ``timings[count]`` per call (the benchmark's probes)."""
    clock = time.perf_counter

    def call(*args: Any, **kwargs: Any) -> Any:
        t0 = clock()
        try:
            return inner(*args, **kwargs)
        finally:
            timings[key] = timings.get(key, 0.0) + clock() - t0
            if count is not None:
                timings[count] = timings.get(count, 0.0) + 1.0

    return call


def _time_calls(obj: Any, name: str, timings: dict[str, float], key: str) -> None:
    """Wrap ``obj.name`` (on this instance only) with :func:`timed`."""
    setattr(obj, name, timed(getattr(obj, name), timings, key))


def _track(rows: list[list[Any]]) -> dict[str, list[float]]:
    keep = rows[::TRACK_EVERY]
    if rows and keep[-1] is not rows[-1]:
        keep.append(rows[-1])
    return {
        "t_s": [round(r[0], 3) for r in keep],
        "x_m": [round(r[1], 3) for r in keep],
        "y_m": [round(r[2], 3) for r in keep],
        "depth_m": [round(r[3], 3) for r in keep],
    }
