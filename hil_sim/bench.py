"""``python -m hil_sim.bench --json PATH [--quick] [--only SECTION]``: the simulator's benchmark sections.

Run by ``auv-bench`` as a subprocess (it merges the JSON of every package). This module imports only
``hil_sim`` and ``onboard.protocol`` (the import contract).
"""

from __future__ import annotations

import sys

from auv_common.cli import run_bench_sections

# section name -> module with ``run(quick) -> dict[str, float]``
SECTIONS = {
    "simulator": "hil_sim.bench_sim",
    "loop": "hil_sim.bench_lockstep",  # merged by auv-bench into the onboard's loop section
}

if __name__ == "__main__":
    sys.exit(run_bench_sections("python -m hil_sim.bench", SECTIONS))
