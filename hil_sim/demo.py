"""``auv-hil demo`` (``make demo``): the paper's turn and straight line in closed loop, next to the paper.

Runs ``paper-straight`` and ``paper-turn`` with the improved controller over real processes (bench +
firmware in lock-step on the bench bus), writes the paper's figures and prints our errors beside the
paper's reported ones (simulation: 0.13 m straight, 0.2 m / y 0.4 m turn; basin experiment: < 0.05 m,
y < 0.1 m).
"""

from __future__ import annotations

import shutil
from pathlib import Path

from hil_sim.scenario import SCENARIOS, RunOptions, plot_scenario, run_scenario

PAPER = {
    "paper-straight": ("0.13 m at goal", "< 0.05 m at goal"),
    "paper-turn": ("0.2 m at goal, y 0.4 m (max at the turn)", "final y < 0.1 m"),
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
            result["figures"] = plot_scenario(result, out)
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
        ("paper: simulation", lambda r: PAPER[r["scenario"]][0]),
        ("paper: basin experiment", lambda r: PAPER[r["scenario"]][1]),
        ("lock-step speed", lambda r: f"{r['realtime_factor']:.0f}x real time"),
    ]
    for label, cell in rows:
        table.add_row(label, *(cell(r) for r in results))
    console.print(table)
    console.print(
        "Goals: straight <= 0.05 m; turn <= 0.1 m at the goal, <= 0.3 m cross-track, yaw within 5 deg. "
        "Errors are the simulator's truth against the planned path (auv-onboard plan)."
    )
    for r in results:
        console.print(f"{r['scenario']}: figures {', '.join(r['figures'])}; truth log {r['truth_log']}")
    return 0 if all(r["completed"] for r in results) else 1
