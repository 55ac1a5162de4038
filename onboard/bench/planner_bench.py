"""Planner benchmark: planning time with 0, 5, 20 and 50 random obstacles (issue 4).

Measures and returns figures; it asserts nothing about time (benchmarks are separate from tests).
Scenario: a 120 m x 120 m area, turning radius 3 m, margin 1 m, obstacle radii 1 to 4 m, start and goal
poses drawn uniformly (re-drawn if inside an inflated obstacle); everything from a fixed seed, so runs
are repeatable. A query that ends in a PlannerError (e.g. an unreachable goal) still counts: that is
planning time too, and its share is reported.

Aims: <= 2 ms with no obstacles, <= 50 ms with 20, <= 250 ms with 50 (median).
"""

from __future__ import annotations

import math
import random
import statistics
import time

from onboard.core.planner import PlannerConfig, PlannerError, inflate, plan

OBSTACLE_COUNTS = (0, 5, 20, 50)
AREA_M = 120.0
SEED = 20240604


def _percentile(values: list[float], q: float) -> float:
    """Nearest-rank percentile, ``q`` in [0, 100]."""
    ordered = sorted(values)
    k = max(0, min(len(ordered) - 1, math.ceil(q / 100.0 * len(ordered)) - 1))
    return ordered[k]


def _query(rng: random.Random, n_obstacles: int) -> tuple[tuple[float, float, float], ...]:
    """``n_obstacles`` random circles (x_m, y_m, radius_m) in the area."""
    return tuple(
        (rng.uniform(0.0, AREA_M), rng.uniform(0.0, AREA_M), rng.uniform(1.0, 4.0))
        for _ in range(n_obstacles)
    )


def _free_pose(
    rng: random.Random, inflated: tuple[tuple[float, float, float], ...]
) -> tuple[float, float, float]:
    while True:
        x, y = rng.uniform(0.0, AREA_M), rng.uniform(0.0, AREA_M)
        if all(math.hypot(x - ox, y - oy) >= orad + 0.5 for ox, oy, orad in inflated):
            return (x, y, rng.uniform(-math.pi, math.pi))


def run(quick: bool = False) -> dict[str, float]:
    """Time ``plan`` over seeded random queries (300 per obstacle count, 30 if ``quick``).

    Returns ``plan_<n>_obstacles_median_ms``, ``..._p99_ms``, ``..._max_ms`` and ``..._error_pct`` (share of
    queries answered with a PlannerError, e.g. a goal right in front of an obstacle) for n in 0, 5, 20, 50.
    """
    config = PlannerConfig(turning_radius_m=3.0, obstacle_margin_m=1.0)
    queries = 30 if quick else 300
    rng = random.Random(SEED)
    out: dict[str, float] = {}
    for n in OBSTACLE_COUNTS:
        times_ms: list[float] = []
        errors = 0
        for _ in range(queries):
            obstacles = _query(rng, n)
            inflated = inflate(obstacles, config)
            start, goal = _free_pose(rng, inflated), _free_pose(rng, inflated)
            t0 = time.perf_counter()
            try:
                plan(start, goal, config, obstacles)
            except PlannerError:
                errors += 1
            times_ms.append((time.perf_counter() - t0) * 1e3)
        out[f"plan_{n}_obstacles_median_ms"] = statistics.median(times_ms)
        out[f"plan_{n}_obstacles_p99_ms"] = _percentile(times_ms, 99.0)
        out[f"plan_{n}_obstacles_max_ms"] = max(times_ms)
        out[f"plan_{n}_obstacles_error_pct"] = 100.0 * errors / queries
    return out


if __name__ == "__main__":
    for key, value in run(quick=False).items():
        print(f"{key:40s} {value:10.3f}")  # noqa: T201
