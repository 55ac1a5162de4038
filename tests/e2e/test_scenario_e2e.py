"""End to end: `auv-hil scenario --upload file` (the start-up-file fallback) over real processes."""

from __future__ import annotations

import csv
import json
import subprocess
import sys

import pytest

pytestmark = pytest.mark.e2e


def test_paper_straight_over_real_processes(tmp_path) -> None:
    # GIVEN the default configurations WHEN the scenario runs over real processes in lock-step
    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "hil_sim",
            "scenario",
            "paper-straight",
            "--json",
            "--upload",
            "file",
            "--workdir",
            str(tmp_path),
        ],
        capture_output=True,
        text=True,
        timeout=180,
        check=False,
    )
    assert out.returncode == 0, out.stderr[-2000:]
    result = json.loads(out.stdout)
    # THEN the vehicle arrives, the metrics are there, and the truth log lets anyone recompute them
    for key in ("scenario", "completed", "final_position_error_m", "final_x_error_m", "final_y_error_m",
                "final_yaw_error_deg", "max_cross_track_m", "rms_cross_track_m", "sim_time_s", "wall_time_s",
                "realtime_factor", "ticks", "overruns", "truth_log"):  # fmt: skip
        assert key in result
    assert result["completed"] is True
    assert result["final_position_error_m"] < 0.05
    assert result["overruns"] == 0 and result["frames_rejected"] == 0
    with open(result["truth_log"]) as f:
        header = next(csv.reader(f))
    assert {"t_s", "x_m", "y_m", "depth_m", "yaw_deg"} <= set(header)
