"""Fly a scenario in one process: the real bench loop and the real onboard loop on a `virtual` bus, lock-step.

The bench (:func:`hil_sim.bench_program.run_bench`) runs in a thread; the onboard
(:class:`onboard.app.loop.ControlLoop` with the real :class:`onboard.core.autopilot.Autopilot`) runs in
another. Both
use exactly the code paths of the programs; only the bus is ``virtual`` (its own channel per run).
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import threading
from pathlib import Path
from typing import Any

from can.interfaces.virtual import VirtualBus

from hil_sim.bench_program import BenchConfig, HilConfig, InitialConfig, WaterCurrentConfig, run_bench
from hil_sim.metrics import compute_metrics, read_truth
from hil_sim.scenario import DEPTH_M, SCENARIOS
from onboard.app.config import load_config
from onboard.app.loop import ControlLoop
from onboard.app.runtime import LISTEN
from onboard.core.autopilot import Autopilot
from onboard.core.mission.model import Goal, Mission
from onboard.core.plans import last_goal_run_in_m, plan_to_goal
from onboard.protocol.codec import Codec
from onboard.protocol.port import BusPort

_ids = itertools.count()


def planned_samples(name: str, step_m: float = 0.05) -> tuple[list[list[float]], float]:
    """The planned polyline [[x, y, yaw_deg], ...] of a scenario with the default onboard config (its goal
    the mission's last: along the run-in's straight)."""
    sc = SCENARIOS[name]
    cfg = load_config()
    mis = cfg.mission
    path = plan_to_goal(
        (sc.start[0], sc.start[1], math.radians(sc.start[2])),
        (sc.goal[0], sc.goal[1], math.radians(sc.goal[2])),
        cfg.planner,
        start_depth_m=DEPTH_M,
        goal_depth_m=DEPTH_M,
        run_in_m=last_goal_run_in_m(
            cfg.planner.goal_run_in_m, cfg.guidance.speed_mps, mis.arrival_speed_mps, mis.run_in_decel_mps2
        ),
    )
    n = max(1, math.ceil(path.length_m / step_m))
    samples = []
    for i in range(n + 1):
        p = path.sample(min(i * step_m, path.length_m))
        samples.append([p.x_m, p.y_m, math.degrees(p.yaw_rad)])
    return samples, path.length_m


def run_lockstep(
    autopilot: Autopilot, loop_cfg: Any, hil_cfg: HilConfig, channel: str, timeout_s: float, what: str
) -> tuple[ControlLoop, BusPort]:
    """The real onboard loop (``autopilot``, lock-step) and the real bench on the virtual bus ``channel``,
    each in a thread, until the bench ends (its duration, a stop state); TimeoutError after ``timeout_s``
    wall seconds. The loop and its (closed) port for their statistics."""
    codec = Codec()
    port = BusPort(VirtualBus(channel=channel), lambda: 0.0, [codec.frame_id(c) for c in LISTEN], codec)
    loop = ControlLoop(port, autopilot, loop_cfg)
    stop_onboard = threading.Event()
    onboard = threading.Thread(target=loop.run_lockstep, args=(stop_onboard,), daemon=True)
    onboard.start()
    stop_bench = threading.Event()
    result: dict[str, Any] = {}

    def bench() -> None:
        result["bench"] = run_bench(hil_cfg, stop_bench, bus_override=VirtualBus(channel=channel))

    thread = threading.Thread(target=bench, daemon=True)
    thread.start()
    thread.join(timeout_s)
    stop_bench.set()
    thread.join(5)
    stop_onboard.set()
    onboard.join(5)
    port.close()
    if "bench" not in result:
        raise TimeoutError(f"{what}: the closed loop did not finish within {timeout_s} s")
    return loop, port


def fly(
    name: str,
    tmp: Path,
    controller: str = "improved",
    guidance: str = "track",
    current: tuple[float, float] = (0.0, 0.0),
    seed: int = 0,
    timeout_s: float = 120.0,
    profile: str = "basin",
    stop_delay_s: float = 2.0,
) -> dict[str, Any]:
    """Fly scenario ``name``; returns the metrics of :func:`hil_sim.scenario.compute_metrics` and more.

    The bench stops ``stop_delay_s`` simulated seconds after COMPLETE or ABORT (longer: what the vehicle
    does after the end, e.g. a glide, shows in the truth log)."""
    sc = SCENARIOS[name]
    samples, length = planned_samples(name)
    channel = f"closed-loop-{next(_ids)}-{id(tmp)}"
    truth = tmp / f"{name}-truth.csv"
    hil_cfg = HilConfig(
        bench=BenchConfig(
            time_mode="lockstep",
            sensor_profile=profile,  # type: ignore[arg-type]
            seed=seed,
            duration_s=round(2.0 * length + 8.0 + stop_delay_s, 1),
            stop_on_state=("COMPLETE", "ABORT"),
            stop_delay_s=stop_delay_s,
            truth_log=str(truth),
        ),
        initial=InitialConfig(sc.start[0], sc.start[1], DEPTH_M, sc.start[2]),
        current=WaterCurrentConfig(*current),
    )
    cfg = load_config()
    guidance_cfg = dataclasses.replace(cfg.guidance, mode=guidance)  # type: ignore[arg-type]
    if controller == "paper":  # the paper's reference-point tracking at uniform speed
        guidance_cfg = dataclasses.replace(guidance_cfg, lateral="reference", reference_accel_mps2=0.0)
    cfg = dataclasses.replace(
        cfg,
        guidance=guidance_cfg,
        control=dataclasses.replace(cfg.control, profile=controller),  # type: ignore[arg-type]
    )
    if controller == "paper":  # ... to the goal: no slow run-in (hil_sim.scenario's paper guidance)
        cfg = dataclasses.replace(cfg, mission=dataclasses.replace(cfg.mission, arrival_speed_mps=0.0))
    autopilot = Autopilot(cfg.core)
    autopilot.replace_mission(Mission((Goal(sc.goal[0], sc.goal[1], DEPTH_M, math.radians(sc.goal[2])),)))
    autopilot.request_autostart()
    loop, port = run_lockstep(autopilot, cfg.loop, hil_cfg, channel, timeout_s, name)
    metrics = compute_metrics(read_truth(truth), samples, sc.goal)
    metrics["final_state"] = autopilot.status.state.name
    metrics["final_reason"] = autopilot.status.reason
    metrics["ticks"] = loop.stats.ticks
    metrics["rejected"] = dict(port.receiver.rejected)
    metrics["truth_log"] = str(truth)
    return metrics
