"""Closed-loop lock-step speed over real processes (``loop`` section of ``auv-bench``).

Runs the paper's scenarios through :func:`hil_sim.scenario.run_scenario` (bench + ``auv-onboard`` as real
processes on the bench hub, lock-step) and reports simulated seconds per wall second of the running part.
"""

from __future__ import annotations

import statistics
import tempfile

from hil_sim.scenario import SCENARIOS, RunOptions, run_scenario


def run(quick: bool = False) -> dict[str, float]:
    names = ["paper-straight"] if quick else ["paper-straight", "paper-turn", "paper-plan"]
    factors, ticks_per_s = [], []
    for name in names:
        with tempfile.TemporaryDirectory() as work:
            r = run_scenario(SCENARIOS[name], RunOptions(workdir=work))
        factors.append(r["realtime_factor"])
        ticks_per_s.append(r["realtime_factor"] * 20.0)
    return {
        "lockstep_realtime_factor_median": statistics.median(factors),
        "lockstep_realtime_factor_min": min(factors),
        "lockstep_ticks_per_s_median": statistics.median(ticks_per_s),
        "lockstep_scenarios": float(len(names)),
    }
