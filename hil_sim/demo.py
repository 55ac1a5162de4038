"""``auv-hil demo`` (``make demo``): the paper's turn and straight line in closed loop, next to the paper.

Runs ``paper-straight`` and ``paper-turn`` with the improved controller over real processes (bench +
firmware in lock-step on the bench bus), writes the paper's figures (:mod:`hil_sim.figures`: the path, and
e_x / e_y in the path frame with the paper's values marked) and prints our errors beside the paper's
reported ones (:data:`PAPER`: simulation 0.13 m straight, 0.2 m / y 0.4 m turn; basin experiment < 0.05 m,
y < 0.1 m).
"""

from __future__ import annotations

import shutil
from pathlib import Path

from hil_sim.figures import PaperValue, paper_text
from hil_sim.scenario import SCENARIOS, RunOptions, plot_scenario, run_scenario

# What the paper reports (Sec. 5, 6): the table prints it and the error figures mark it.
PAPER = {
    "paper-straight": (PaperValue("simulation", 0.13), PaperValue("basin", 0.05, below=True)),
    "paper-turn": (
        PaperValue("simulation", 0.2),
        PaperValue("simulation", 0.4, axis="y", at_goal=False, where="max at the turn"),
        PaperValue("basin", 0.1, axis="y", below=True),
    ),
}


def main(out_dir: str = "out/demo") -> int:
    from rich.console import Console
    from rich.table import Table

    console = Console()
    out = Path(out_dir)
    results = []
    for name in ("paper-straight", "paper-turn"):
        with console.status(f"flying {name} (bench + firmware in lock-step)..."):
            work = out / "runs" / name  # the logs beside the figures, replaced by each run (none in /tmp)
            shutil.rmtree(work, ignore_errors=True)
            work.mkdir(parents=True)
            result = run_scenario(SCENARIOS[name], RunOptions(controller="improved", workdir=str(work)))
            result["figures"] = plot_scenario(result, out, PAPER[name])
        results.append(result)
    table = Table(title="ISiMI100 closed loop vs the paper (improved controller, track guidance, basin)")
    table.add_column("")
    for r in results:
        table.add_column(r["scenario"], justify="right")
    rows = [
        ("completed", lambda r: "yes" if r["completed"] else "NO"),
        ("ours: error at goal", lambda r: f"{r['final_position_error_m']:.3f} m"),
        (
            "ours: x / y error at goal",
            lambda r: f"{r['final_x_error_m']:+.3f} / {r['final_y_error_m']:+.3f} m",
        ),
        (
            "ours: max / rms cross-track",
            lambda r: f"{r['max_cross_track_m']:.3f} / {r['rms_cross_track_m']:.3f} m",
        ),
        ("ours: yaw error at goal", lambda r: f"{r['final_yaw_error_deg']:+.2f} deg"),
        ("paper: simulation", lambda r: paper_text(PAPER[r["scenario"]], "simulation")),
        ("paper: basin experiment", lambda r: paper_text(PAPER[r["scenario"]], "basin")),
        ("lock-step speed", lambda r: f"{r['realtime_factor']:.0f}x real time"),
    ]
    for label, cell in rows:
        table.add_row(label, *(cell(r) for r in results))
    console.print(table)
    console.print(
        "Goals: straight <= 0.05 m; turn <= 0.1 m at the goal, <= 0.3 m cross-track, yaw within 5 deg. "
        "Errors are the simulator's truth against the planned path (auv-onboard plan)."
    )
    console.print(
        "Figures: *-path.png: the track over the planned path from start to goal (a straight line's lateral "
        "axis is exaggerated, the factor in its label). *-error.png: the paper's e_x, e_y in the path frame "
        "(e = desired - actual): e_y is the cross-track to the planned path (the table's cross-track; the "
        "paper's values drawn as +- bands); e_x is how far the guidance reference point is ahead of the "
        "vehicle along the path: metres at first, because the reference speeds up from rest faster than "
        "the vehicle (its title gives the peak), and not an error of the track."
    )
    for r in results:
        console.print(f"{r['scenario']}: figures {', '.join(r['figures'])}; truth log {r['truth_log']}")
    return 0 if all(r["completed"] for r in results) else 1
