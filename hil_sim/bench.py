"""``python -m hil_sim.bench --json PATH [--quick] [--only SECTION]``: the simulator's benchmark sections.

Run by ``auv-bench`` as a subprocess (it merges the JSON of every package). Each section is a module with
``run(quick) -> dict[str, float]`` (flat, unit-suffixed figure names); a section that fails is reported as
``{"error": ...}`` and the others still run. This module imports only ``hil_sim`` (the import contract).
"""

from __future__ import annotations

import argparse
import importlib
import json
import sys
import traceback

# section name -> module with ``run(quick) -> dict[str, float]``
SECTIONS = {
    "simulator": "hil_sim.bench_sim",
    "loop": "hil_sim.bench_lockstep",  # merged by auv-bench into the onboard's loop section
}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m hil_sim.bench", description=__doc__)
    parser.add_argument("--json", required=True, help="write the sections here")
    parser.add_argument("--quick", action="store_true", help="fewer repetitions")
    parser.add_argument("--only", action="append", help="run only these sections")
    args = parser.parse_args(argv)
    result: dict[str, dict[str, float] | dict[str, str]] = {}
    for name, module in SECTIONS.items():
        if args.only and name not in args.only:
            continue
        try:
            result[name] = importlib.import_module(module).run(quick=args.quick)
        except ModuleNotFoundError as exc:
            result[name] = {"error": f"not available: {exc}"}
        except Exception as exc:  # a failing section is reported, the others still run
            traceback.print_exc()
            result[name] = {"error": repr(exc)}
    with open(args.json, "w") as f:
        json.dump(result, f, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
