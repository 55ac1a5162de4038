"""Faults in a campaign, as a user runs one (issue 24 item 4): ``auv-hil campaign`` on a tiny spec that
sweeps ``faults``; the run ids, runs.csv's ``faults`` column, the summary's faults axis, and ``--only``'s
truth log with its fault columns."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

pytestmark = pytest.mark.slow

TINY = {
    "name": "tiny-faults",
    "missions": [
        {"name": "line", "start": {"x_m": -6, "y_m": 0, "depth_m": 1, "yaw_deg": 0},
         "goals": [{"x_m": 6, "y_m": 0, "depth_m": 1, "yaw_deg": 0}]},
    ],
    "sweep": {"faults": [
        [],
        [{"kind": "fix_outage", "start_s": 2, "duration_s": 3}],
        [{"kind": "fin_stuck", "fin": "rudder", "start_s": 3, "angle_deg": 6}],
    ]},
}  # fmt: skip


def _campaign(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "hil_sim", "campaign", *args, "--no-progress", "--workers", "1"],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )


def test_a_faults_sweep_names_each_fault_in_ids_columns_summary_and_truth(tmp_path: Path) -> None:
    # GIVEN a straight line under no fault, a fix outage and a stuck rudder
    spec = tmp_path / "faults.yaml"
    spec.write_text(yaml.safe_dump(TINY))
    out = tmp_path / "out"
    # WHEN the campaign is run
    proc = _campaign(str(spec), "--out", str(out))
    assert proc.returncode == 0, proc.stderr[-3000:]
    # THEN each run's id and faults column name its fault
    with (out / "runs.csv").open(newline="") as f:
        rows = {r["run_id"]: r for r in csv.DictReader(f)}
    base = "line_s0_c0d0_basin_default_nominal"
    assert set(rows) == {f"{base}_none", f"{base}_fix_outage", f"{base}_fin_stuck"}
    assert rows[f"{base}_none"]["faults"] == "none"
    assert rows[f"{base}_fix_outage"]["faults"] == "fix_outage(start_s=2, duration_s=3)"
    assert rows[f"{base}_fin_stuck"]["faults"] == "fin_stuck(start_s=3, fin=rudder, angle_deg=6)"
    # AND the fault-free line completes, the stuck rudder does not (it turns away: nothing names it yet)
    assert rows[f"{base}_none"]["final_state"] == "COMPLETE"
    assert rows[f"{base}_fin_stuck"]["completed"] == "false"
    assert rows[f"{base}_fin_stuck"]["false_complete"] == "false"
    # AND the summary counts per fault
    summary = json.loads((out / "summary.json").read_text())
    assert list(summary["per_axis"]["faults"]) == [
        "none",
        "fix_outage(start_s=2, duration_s=3)",
        "fin_stuck(start_s=3, fin=rudder, angle_deg=6)",
    ]
    assert all(v["runs"] == 1 for v in summary["per_axis"]["faults"].values())
    # AND a run flown again with --only writes its truth log with the fault's columns
    proc = _campaign(str(spec), "--out", str(out), "--only", f"{base}_fin_stuck")
    assert proc.returncode == 0, proc.stderr[-3000:]
    with open(json.loads(proc.stdout)["truth_log"], newline="") as f:
        truth = list(csv.DictReader(f))
    stuck = [r for r in truth if r["fault_fin_stuck"] == "1"]
    assert stuck and float(stuck[0]["t_s"]) == pytest.approx(3.0)  # active on [start_s, end)
    assert all(r["fault_fin_stuck"] == "0" for r in truth if float(r["t_s"]) < 3.0)
    assert abs(float(truth[-1]["rudder_rad"]) - 0.10472) < 1e-4  # 6 deg, whatever was commanded
