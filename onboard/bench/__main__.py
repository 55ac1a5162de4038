"""``python -m onboard.bench --json PATH [--quick] [--only SECTION]``: the onboard package's sections."""

from __future__ import annotations

import sys

from auv_common.cli import run_bench_sections

# section name -> module with ``run(quick) -> dict[str, float]``
SECTIONS = {
    "can": "onboard.bench.can_bench",
    "planner": "onboard.bench.planner_bench",
    "loop": "onboard.bench.loop_bench",
}

if __name__ == "__main__":
    sys.exit(run_bench_sections("python -m onboard.bench", SECTIONS))
