"""Campaign throughput and where a lock-step tick goes (``campaign`` section of ``auv-bench``).

The mission: a straight line at the default 1 m/s (:data:`START` to :data:`GOAL`, about 30 s simulated
including the start from rest and the 2 s after COMPLETE), every run with a seed of its own (nothing is
resumed: no output directory, and no two runs alike).

- Throughput: the wall time of :func:`auv_campaign.execute.execute` over N runs (quick 8, full 40) with one
  worker (half the runs before the other pass, half after) and with
  :func:`~auv_campaign.execute.default_workers` workers, as missions per minute. One worker flies in this
  process (what ``--workers 1`` does; its imports are already warm); with more, the wall includes the cost
  of starting the pool (``spawn``: fresh interpreters importing the stack), uneven batches and the
  machine's other load: ``all_workers_overhead_s`` is what the all-workers wall takes beyond a perfect
  split of the one-worker wall.
- The reference: the same mission run once by ``auv-hil scenario`` over real processes (bench +
  ``auv-onboard``, ``--upload file``; quick 1, full 2, median), including its process start-up and planning
  call: ``speedup_vs_scenario`` is one worker's missions per minute over the scenario's.
- The tick split: :func:`auv_campaign.runner.fly` with its ``timings`` in this process: per tick the whole
  drive, the onboard core (``Autopilot.step``), the simulator (``Bench.period``) and the frames, the rest
  (codec, E2E, the python-can ``local`` bus, building and reading the frames' messages, the lock-step
  glue): ``tick_frames_us`` and its share of the tick, ``tick_frames_fraction`` (issue 22's aim: at most
  0.25). A second pass (the ``tick_rest_*`` figures) also times the codec with its E2E checks
  (``FrameSender.encode``, ``FrameReceiver.receive``) and the bus (``LocalBus.send``/``recv``); its timing
  wrappers are part of its "other".

Figures are measured, never asserted; the ratios compare figures of the same run. The machine's 1-minute
load average before and after is reported: other work on it weighs on every figure.
"""

from __future__ import annotations

import contextlib
import os
import statistics
import tempfile
import time
from collections.abc import Iterator, Sequence
from typing import Any

from auv_campaign.execute import Executor, default_workers, execute
from auv_campaign.runner import fly, timed
from auv_campaign.spec import RunSpec, parse_spec
from hil_sim.scenario import RunOptions, Scenario, run_scenario
from onboard.protocol.codec import FrameReceiver, FrameSender
from onboard.protocol.local_bus import LocalBus

#: The mission: (x_m, y_m, depth_m, yaw_deg) of the start and of the one goal.
START = (-15.0, 0.0, 1.0, 0.0)
GOAL = (13.0, 0.0, 1.0, 0.0)
#: Seeds of the passes (disjoint: no two runs alike).
_SPLIT_SEED, _ONE_SEED, _ALL_SEED = 10_000, 0, 5_000


def mission_runs(seeds: Sequence[int]) -> tuple[RunSpec, ...]:
    """The bench mission once per noise seed (through the campaign's own spec parser)."""
    pose = ("x_m", "y_m", "depth_m", "yaw_deg")
    data = {
        "name": "bench",
        "missions": [{"name": "line", "start": dict(zip(pose, START, strict=True)),
                      "goals": [dict(zip(pose, GOAL, strict=True))]}],
        "sweep": {"seed": list(seeds)},
        "observe_after_end_s": 2,  # as the scenario's --stop-delay: the same mission, timings comparable
    }  # fmt: skip
    return parse_spec(data, "<auv_campaign.bench>").runs


def bench_scenario() -> Scenario:
    """The bench mission as an ``auv-hil scenario`` (which flies at 1 m depth, as the mission does)."""
    return Scenario("bench-line", (START[0], START[1], START[3]), (GOAL[0], GOAL[1], GOAL[3]), "bench line")


def per_minute(count: int, wall_s: float) -> float:
    """``count`` missions in ``wall_s`` wall seconds, per minute."""
    return 60.0 * count / wall_s if wall_s > 0.0 else float("nan")


def tick_split(timings: dict[str, float]) -> dict[str, float]:
    """The per-tick figures (µs, and fractions of the tick) of a :func:`fly` ``timings`` dict."""
    ticks = timings.get("ticks", 0.0)
    if ticks <= 0:
        raise ValueError("no ticks in the timings")
    total = 1e6 * timings["drive_s"] / ticks
    core = 1e6 * timings.get("onboard_core_s", 0.0) / ticks
    sim = 1e6 * timings.get("simulator_s", 0.0) / ticks
    frames = total - core - sim
    return {
        "tick_total_us": total,
        "tick_onboard_core_us": core,
        "tick_simulator_us": sim,
        "tick_frames_us": frames,
        "tick_onboard_core_fraction": core / total,
        "tick_simulator_fraction": sim / total,
        "tick_frames_fraction": frames / total,
    }


def rest_split(timings: dict[str, float]) -> dict[str, float]:
    """The frames' part of a tick (drive minus core minus simulator), split into codec + E2E, the bus and the
    other (frame building, message objects, loop bookkeeping): µs per tick, and frames sent per tick."""
    ticks = timings["ticks"]
    rest = timings["drive_s"] - timings.get("onboard_core_s", 0.0) - timings.get("simulator_s", 0.0)
    codec, bus = timings.get("codec_e2e_s", 0.0), timings.get("bus_s", 0.0)
    return {
        "tick_rest_codec_e2e_us": 1e6 * codec / ticks,
        "tick_rest_bus_us": 1e6 * bus / ticks,
        "tick_rest_other_us": 1e6 * (rest - codec - bus) / ticks,
        "frames_per_tick": timings.get("bus_sends", 0.0) / ticks,
    }


def _add(into: dict[str, float], more: dict[str, float]) -> None:
    for key, value in more.items():
        into[key] = into.get(key, 0.0) + value


@contextlib.contextmanager
def _timed_methods(timings: dict[str, float]) -> Iterator[None]:
    """Time the codec (with E2E) and the campaign's bus (``local``), class-wide, while inside; restored on
    exit."""
    targets: list[tuple[type, str, str]] = [
        (FrameSender, "encode", "codec_e2e_s"),
        (FrameReceiver, "receive", "codec_e2e_s"),
        (LocalBus, "send", "bus_s"),
        (LocalBus, "recv", "bus_s"),
    ]
    saved: list[tuple[type, str, Any]] = []

    try:
        for cls, name, key in targets:
            saved.append((cls, name, cls.__dict__.get(name)))
            count = "bus_sends" if (cls, name) == (LocalBus, "send") else None
            setattr(cls, name, timed(getattr(cls, name), timings, key, count))
        yield
    finally:
        for cls, name, own in reversed(saved):
            if own is None:
                delattr(cls, name)  # it was inherited
            else:
                setattr(cls, name, own)


def _split_pass(runs: Sequence[RunSpec]) -> tuple[dict[str, float], list[float], list[float]]:
    """Fly ``runs`` here with timings: the summed timings, each run's wall outside its drive (set-up,
    planning, metrics) and each run's simulated time."""
    total: dict[str, float] = {}
    setup, sim = [], []
    for spec in runs:
        t: dict[str, float] = {}
        out = fly(spec, timings=t)
        setup.append(float(out.row["wall_time_s"]) - t.get("drive_s", 0.0))
        sim.append(float(out.row["sim_time_s"]))
        _add(total, t)
    return total, setup, sim


def _throughput(runs: Sequence[RunSpec], workers: int) -> tuple[float, list[dict[str, Any]]]:
    t0 = time.perf_counter()
    records = execute(runs, None, Executor("local", workers))
    return time.perf_counter() - t0, records


def _scenario(seed: int) -> tuple[float, dict[str, Any]]:
    with tempfile.TemporaryDirectory(prefix="auv-bench-campaign-") as work:
        t0 = time.perf_counter()
        result = run_scenario(bench_scenario(), RunOptions(seed=seed, workdir=work, upload="file"))
        return time.perf_counter() - t0, result


def _bad(records: list[dict[str, Any]]) -> tuple[float, float]:
    """(runs that raised, runs that did not succeed) among ``records``."""
    errors = sum(1 for r in records if r["row"].get("error"))
    misses = sum(1 for r in records if not r["row"].get("success"))
    return float(errors), float(misses)


def run(quick: bool = False) -> dict[str, float]:
    n = 8 if quick else 40
    n_split = 3 if quick else 5
    n_detail = 2 if quick else 3
    n_scenario = 1 if quick else 2
    workers = default_workers()

    load_before = os.getloadavg()[0]
    # The tick split first: it also warms this process's imports for the one-worker pass.
    split_runs = mission_runs(range(_SPLIT_SEED, _SPLIT_SEED + n_split + n_detail))
    timings, setup_s, split_sim = _split_pass(split_runs[:n_split])
    detail: dict[str, float] = {}
    with _timed_methods(detail):
        detail_timings, _, _ = _split_pass(split_runs[n_split:])
    _add(detail, detail_timings)

    # One worker before and after all workers (half the runs each): a change of the machine's load during
    # the measurement weighs on both alike.
    one = mission_runs(range(_ONE_SEED, _ONE_SEED + n))
    wall_a, rec_a = _throughput(one[: n // 2], 1)
    wall_all, rec_all = _throughput(mission_runs(range(_ALL_SEED, _ALL_SEED + n)), workers)
    wall_b, rec_b = _throughput(one[n // 2 :], 1)
    wall_1, rec_1 = wall_a + wall_b, rec_a + rec_b
    sim_times = [float(r["row"]["sim_time_s"]) for r in rec_1 + rec_all if r["row"].get("sim_time_s")]
    wall_per_run = [float(r["row"]["wall_time_s"]) for r in rec_1 if r["row"].get("wall_time_s")]

    scenario_walls, scenario_sims = [], []
    for seed in range(n_scenario):
        wall, result = _scenario(seed)
        scenario_walls.append(wall)
        scenario_sims.append(float(result["sim_time_s"]))
    scenario_s = statistics.median(scenario_walls)

    mpm_1, mpm_all = per_minute(len(rec_1), wall_1), per_minute(len(rec_all), wall_all)
    errors_1, misses_1 = _bad(rec_1)
    errors_all, misses_all = _bad(rec_all)
    drive_per_run = timings["drive_s"] / n_split
    return {
        "workers": float(workers),
        "load_avg_1min_before": load_before,
        "load_avg_1min_after": os.getloadavg()[0],
        "runs_per_measurement": float(n),
        "mission_sim_time_s": statistics.median(sim_times),
        "missions_per_min_1_worker": mpm_1,
        "missions_per_min_all_workers": mpm_all,
        "missions_per_min_per_core": mpm_all / workers,
        "scaling_all_vs_1": mpm_all / mpm_1,
        "wall_1_worker_s": wall_1,
        "wall_all_workers_s": wall_all,
        "all_workers_overhead_s": wall_all - wall_1 / workers,
        "run_wall_s_median": statistics.median(wall_per_run),
        "realtime_factor_1_worker": sum(float(r["row"]["sim_time_s"]) for r in rec_1) / wall_1,
        "realtime_factor_drive": sum(split_sim) / timings["drive_s"],
        "run_setup_s_median": statistics.median(setup_s),
        "run_setup_fraction": statistics.median(setup_s) / (statistics.median(setup_s) + drive_per_run),
        "runs_raised": errors_1 + errors_all,
        "runs_not_succeeded": misses_1 + misses_all,
        "scenario_s_per_mission": scenario_s,
        "scenario_sim_time_s": statistics.median(scenario_sims),
        "scenario_missions_per_min": 60.0 / scenario_s,
        "speedup_vs_scenario": mpm_1 / (60.0 / scenario_s),
        "speedup_all_workers_vs_scenario": mpm_all / (60.0 / scenario_s),
        **tick_split(timings),
        **rest_split(detail),
    }
