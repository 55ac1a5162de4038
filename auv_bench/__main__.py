"""auv-bench: run each package's benchmark in its own process and merge the sections.

Sections: can, planner, loop (onboard), simulator (hil_sim, plus the closed-loop lock-step speed over real
processes, reported under loop), mission_upload (groundstation, against a real vehicle-side process),
campaign (auv_campaign: missions per minute with one and with all local workers against ``auv-hil scenario``
over processes, and where the wall time of a lock-step tick goes: ``tick_frames_fraction`` is the frames'
share), links (groundstation, over processes: a 100-goal upload by one and by three concurrent ground
stations; a genuine ground station's answers and the vehicle's HEARTBEAT rate under a MAVLink flood;
control-tick overruns and the actuator watchdog under a CAN flood of the bench hub; each against the same
without the contention or flood).
Prints one table per section and writes everything to ``--json PATH``. Figures are measured, never asserted;
where a figure has a reference measured in the same run, a ratio is given too.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

PACKAGES = ("onboard.bench", "hil_sim.bench", "groundstation.bench", "auv_campaign.bench")
SECTIONS = ("can", "simulator", "planner", "loop", "mission_upload", "campaign", "links")


def _run_package(module: str, quick: bool, only: list[str] | None) -> dict[str, dict]:
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "bench.json"
        cmd = [sys.executable, "-m", module, "--json", str(out)]
        if quick:
            cmd.append("--quick")
        for name in only or []:
            cmd += ["--only", name]
        proc = subprocess.run(cmd, check=False, timeout=1800)
        if proc.returncode != 0 or not out.exists():
            return {"_error": {"error": f"{module} exited with {proc.returncode}"}}
        return json.loads(out.read_text())


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="auv-bench", description=__doc__)
    parser.add_argument("--json", help="write the merged sections to this file")
    parser.add_argument("--quick", action="store_true", help="fewer repetitions (a smoke run)")
    parser.add_argument("--only", action="append", choices=SECTIONS, help="run only these sections")
    args = parser.parse_args(argv)
    merged: dict[str, dict] = {}
    t0 = time.monotonic()
    for module in PACKAGES:
        for section, figures in _run_package(module, args.quick, args.only).items():
            if section.startswith("_"):
                merged.setdefault("errors", {})[module] = figures.get("error", "")
                continue
            merged.setdefault(section, {}).update(figures)
    merged["meta"] = {"wall_time_s": round(time.monotonic() - t0, 1), "quick": args.quick}

    from rich.console import Console
    from rich.table import Table

    console = Console()
    for section in (*SECTIONS, "errors"):
        if section not in merged:
            continue
        table = Table(title=f"auv-bench: {section}")
        table.add_column("figure")
        table.add_column("value", justify="right")
        for name, value in merged[section].items():
            table.add_row(name, f"{value:.4g}" if isinstance(value, float) else str(value))
        console.print(table)
    if args.json:
        Path(args.json).write_text(json.dumps(merged, indent=2))
        console.print(f"wrote {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
