"""Campaigns as a user runs them: ``auv-hil campaign`` as a process, its files, executors, resumption,
Ctrl-C, bad specs; and a campaign run against the same scenario over real processes."""

from __future__ import annotations

import csv
import json
import math
import os
import re
import shutil
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import pytest
import yaml

from auv_campaign.report import paper_errors
from auv_campaign.runner import fly
from auv_campaign.spec import load_spec, parse_spec
from hil_sim.scenario import SCENARIOS, RunOptions, run_scenario

pytestmark = pytest.mark.slow

# Three short runs: a straight line over two seeds, and a turn past an obstacle in a cross current.
SMALL = {
    "name": "small",
    "missions": [
        {"name": "line", "start": {"x_m": -6, "y_m": 0, "depth_m": 1, "yaw_deg": 0},
         "goals": [{"x_m": 6, "y_m": 0, "depth_m": 1, "yaw_deg": 0}]},
        {"name": "dodge", "start": {"x_m": -10, "y_m": 0, "depth_m": 1, "yaw_deg": 0},
         "goals": [{"x_m": 8, "y_m": 2, "depth_m": 1, "yaw_deg": 0}],
         "obstacles": [{"x_m": 0, "y_m": 0, "radius_m": 1.0}]},
    ],
    "sweep": {"seed": [0, 1], "current": [[0.1, 90]]},
}  # fmt: skip


def _write_spec(tmp: Path, data: dict[str, Any], name: str = "spec.yaml") -> Path:
    path = tmp / name
    path.write_text(yaml.safe_dump(data))
    return path


def _campaign(*args: str, timeout: float = 240.0) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "hil_sim", "campaign", *args, "--no-progress"],
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
    )


def _rows(out: Path) -> dict[str, dict[str, str]]:
    with (out / "runs.csv").open(newline="") as f:
        return {r["run_id"]: r for r in csv.DictReader(f)}


def _without_timing(rows: dict[str, dict[str, str]]) -> dict[str, dict[str, str]]:
    return {k: {c: v for c, v in r.items() if c != "wall_time_s"} for k, r in rows.items()}


def test_campaign_run_and_process_scenario_end_within_1_mm_and_0_1_deg(tmp_path: Path) -> None:
    # GIVEN the paper's turn as a one-run campaign, and the same scenario over real processes
    sc = SCENARIOS["paper-turn"]
    spec = parse_spec(
        {"name": "turn", "missions": [{"name": "turn",
         "start": {"x_m": sc.start[0], "y_m": sc.start[1], "depth_m": 1, "yaw_deg": sc.start[2]},
         "goals": [{"x_m": sc.goal[0], "y_m": sc.goal[1], "depth_m": 1, "yaw_deg": sc.goal[2]}]}],
         "observe_after_end_s": 2},  # the scenario's --stop-delay: the same length of truth
        "turn.yaml",
    )  # fmt: skip
    run = fly(spec.runs[0], keep_truth=True)
    procs = run_scenario(sc, RunOptions(workdir=str(tmp_path / "scenario"), upload="file"))
    # THEN both arrive at the same place with the same heading
    row = run.row
    assert row["completed"] and procs["completed"]
    assert abs(row["final_position_error_m"] - procs["final_position_error_m"]) <= 1e-3
    assert abs(row["final_heading_error_deg"] - procs["final_yaw_error_deg"]) <= 0.1
    assert abs(row["max_cross_track_m"] - procs["max_cross_track_m"]) <= 1e-3
    assert row["final_state"] == procs["final_state"] == "COMPLETE"
    # ... because they fly the same frames through the same code: the truth logs agree tick by tick
    with open(procs["truth_log"], newline="") as f:
        rows = list(csv.reader(f))
    x_at, y_at = rows[0].index("x_m"), rows[0].index("y_m")  # by name: the log gains columns (faults)
    truth = [(float(r[x_at]), float(r[y_at])) for r in rows[1:]]
    assert len(truth) == len(run.truth)
    worst = max(math.hypot(a[0] - b[1], a[1] - b[2]) for a, b in zip(truth, run.truth, strict=True))
    assert worst <= 1e-3


def test_same_results_with_one_worker_two_workers_and_ray(tmp_path: Path) -> None:
    spec = _write_spec(tmp_path, SMALL)
    results = {}
    for name, extra in (
        ("one", ["--workers", "1"]),
        ("two", ["--workers", "2"]),
        ("ray", ["--ray", "--workers", "2"]),
    ):
        out = tmp_path / name
        proc = _campaign(str(spec), "--out", str(out), *extra)
        assert proc.returncode == 0, proc.stderr[-3000:]
        assert (out / "report.html").exists() and (out / "summary.json").exists()
        results[name] = _without_timing(_rows(out))
    assert len(results["one"]) == 4
    assert results["one"] == results["two"] == results["ray"]
    summary = json.loads((tmp_path / "ray" / "summary.json").read_text())
    assert summary["runs"] == 4 and summary["errors"] == 0
    assert summary["executor"].startswith("ray")
    # the truth says the dodge kept clear of its obstacle, and the straight line had none
    rows = results["one"]
    assert all(r["min_clearance_m"] == "" for k, r in rows.items() if k.startswith("line"))
    assert all(float(r["min_clearance_m"]) > 0.0 for k, r in rows.items() if k.startswith("dodge"))


def test_resume_skips_finished_runs_and_flies_the_missing_one(tmp_path: Path) -> None:
    spec = _write_spec(tmp_path, SMALL)
    out = tmp_path / "out"
    assert _campaign(str(spec), "--out", str(out), "--workers", "2").returncode == 0
    files = sorted((out / "runs").glob("*.json"))
    assert len(files) == 4
    mtimes = {f.name: f.stat().st_mtime_ns for f in files}
    files[0].unlink()
    time.sleep(0.05)
    proc = _campaign(str(spec), "--out", str(out), "--workers", "1", "--json")
    assert proc.returncode == 0, proc.stderr
    after = {f.name: f.stat().st_mtime_ns for f in sorted((out / "runs").glob("*.json"))}
    assert set(after) == set(mtimes)
    assert [n for n in after if after[n] != mtimes[n]] == [files[0].name]
    assert json.loads(proc.stdout)["runs"] == 4


def test_ctrl_c_keeps_finished_runs_and_the_same_command_resumes(tmp_path: Path) -> None:
    data = dict(SMALL, sweep={"seed": list(range(12))})
    spec = _write_spec(tmp_path, data)
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "hil_sim", "campaign", str(spec), "--out", str(out), "--workers", "1"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 120
        while len(list((out / "runs").glob("*.json"))) < 2 and time.monotonic() < deadline:
            time.sleep(0.05)
        proc.send_signal(signal.SIGINT)
        _stdout, stderr = proc.communicate(timeout=180)  # the run under way ends first: a loaded machine
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, stderr
    assert "interrupted" in stderr and "resumes" in stderr
    kept = list((out / "runs").glob("*.json"))
    assert 2 <= len(kept) < 24
    assert len(_rows(out)) == len(kept)  # the report covers what finished
    done = _campaign(str(spec), "--out", str(out), "--workers", "2", "--json")
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["runs"] == 24


@pytest.mark.parametrize(
    ("patch", "named"),
    [
        ({"sweep": {"profile": ["basin", "ocean"]}}, "sweep.profile[1]"),
        ({"sweep": {"onboard": [{}, {"control.improved.NOPE": 1}]}}, "sweep.onboard[1]"),
        ({"sweep": {"vehicle": [{"scale": {"fin_lif": 0.7}}]}}, "sweep.vehicle[0]"),
        ({"time_limit_factor": -1}, "time_limit_factor"),
    ],
)
def test_a_bad_spec_is_one_line_naming_the_key_before_any_run(
    tmp_path: Path, patch: dict, named: str
) -> None:
    spec = _write_spec(tmp_path, {**SMALL, **patch})
    out = tmp_path / "out"
    proc = _campaign(str(spec), "--out", str(out), timeout=60)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and named in lines[0], proc.stderr
    assert not (out / "runs").exists()


def test_only_refies_one_run_with_its_truth_and_figure(tmp_path: Path) -> None:
    spec = _write_spec(tmp_path, SMALL)
    out = tmp_path / "out"
    assert _campaign(str(spec), "--out", str(out), "--workers", "2").returncode == 0
    run_id = "dodge_s1_c0.1d90_basin_default_nominal"
    before = _rows(out)[run_id]
    proc = _campaign(str(spec), "--out", str(out), "--only", run_id, "--plot")
    assert proc.returncode == 0, proc.stderr
    again = json.loads(proc.stdout)
    assert Path(again["figure"]).stat().st_size > 10_000
    assert Path(again["errors_figure"]).stat().st_size > 10_000  # the paper's e_x, e_y against time
    assert Path(again["truth_log"]).exists()
    assert math.isclose(
        again["final_position_error_m"], float(before["final_position_error_m"]), rel_tol=1e-5
    )
    report = (out / "report.html").read_text()
    assert "--only" in report  # the report says how to re-fly its worst runs


def test_sea_fixes_give_no_false_complete_and_errors_within_twice_their_noise(tmp_path: Path) -> None:
    # GIVEN the sea profile: 2 m position fixes every 5 s, stated in each POSITION_FIX frame (issue 11 saw
    # 20/20 COMPLETE 1.8-25 m off while the filter assumed 0.3 m fixes)
    spec = parse_spec(
        {"name": "sea", "missions": [{"name": "turn",
         "start": {"x_m": -15, "y_m": 5, "depth_m": 1, "yaw_deg": 0},
         "goals": [{"x_m": 10, "y_m": -2, "depth_m": 1, "yaw_deg": 270}]}],
         "sweep": {"seed": [0, 1, 2, 3, 4], "profile": ["sea"]}},
        "sea.yaml",
    )  # fmt: skip
    rows = [fly(run).row for run in spec.runs]
    # THEN judged by the truth: no false COMPLETE, every final error within twice the fix noise, and a vehicle
    # that cannot confirm its arrival to the 0.5 m radius says so and holds
    assert not any(r["false_complete"] for r in rows)
    assert max(r["final_position_error_m"] for r in rows) <= 2 * 2.0
    for r in rows:
        if r["final_state"] != "COMPLETE":
            assert r["final_state"] == "HOLD" and "cannot be confirmed" in r["final_reason"]


def test_join_a_running_ray_cluster_by_its_address(tmp_path: Path) -> None:
    # GIVEN a Ray cluster started the way an operator starts one (its own head process, token auth on)

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    ray_bin = str(Path(sys.executable).parent / "ray")
    ray_tmp = tempfile.mkdtemp(prefix="ray-", dir="/tmp")  # short: Ray's socket paths must fit 107 chars
    env = {**os.environ, "RAY_AUTH_MODE": "token", "RAY_USAGE_STATS_ENABLED": "0", "PYTHONUNBUFFERED": "1"}
    head = subprocess.Popen(
        [ray_bin, "start", "--head", "--block", f"--port={port}", "--num-cpus=2", "--include-dashboard=false",
         f"--temp-dir={ray_tmp}"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env, start_new_session=True,
    )  # fmt: skip
    try:
        address = None
        deadline = time.monotonic() + 60
        assert head.stdout is not None
        while address is None and time.monotonic() < deadline:
            line = head.stdout.readline()
            if not line:
                break  # the head ended
            found = re.search(r"ray start --address='([^']+)'", line)
            address = found.group(1) if found else None
        assert address, "the Ray head did not start"
        spec = _write_spec(tmp_path, SMALL)
        out = tmp_path / "out"
        proc = subprocess.run(
            [sys.executable, "-m", "hil_sim", "campaign", str(spec), "--out", str(out), "--ray", address,
             "--no-progress", "--json"],
            capture_output=True, text=True, timeout=180, check=False, env=env,
        )  # fmt: skip
        # THEN the runs went to the cluster and gave what the local executor gives
        assert proc.returncode == 0, proc.stderr[-3000:]
        assert json.loads(proc.stdout)["executor"] == f"ray ({address})"
        local = tmp_path / "local"
        assert _campaign(str(spec), "--out", str(local), "--workers", "2").returncode == 0
        assert _without_timing(_rows(out)) == _without_timing(_rows(local))
    finally:  # the head and every Ray process it started share its process group: stop them all
        os.killpg(head.pid, signal.SIGTERM)
        try:
            head.wait(30)
        except subprocess.TimeoutExpired:
            os.killpg(head.pid, signal.SIGKILL)
            head.wait(10)
        shutil.rmtree(ray_tmp, ignore_errors=True)


def test_an_out_that_is_a_file_is_one_line_before_any_run(tmp_path: Path) -> None:
    spec = _write_spec(tmp_path, SMALL)
    taken = tmp_path / "taken"
    taken.write_text("not a directory")
    tune = ["tune", str(spec), "--params", "control.improved.Kp5", "--trials", "2"]
    for cmd in (["campaign", str(spec)], tune):
        proc = subprocess.run(
            [sys.executable, "-m", "hil_sim", *cmd, "--out", str(taken), "--no-progress"],
            capture_output=True, text=True, timeout=60, check=False,
        )  # fmt: skip
        assert proc.returncode == 2, proc.stderr
        lines = proc.stderr.strip().splitlines()
        assert len(lines) == 1 and "--out" in lines[0] and "Traceback" not in proc.stderr
    assert taken.read_text() == "not a directory"


def test_the_papers_law_completes_its_straight_and_turn_with_the_shape_of_figs_8_and_10() -> None:
    # GIVEN the paper's law (paper gains, uniform 1 m/s reference from rest, errors at the reference), with
    # the propeller held at the reference speed (hil_sim/campaigns/paper_law.yaml, onboard o1)
    spec = load_spec(Path(__file__).parents[2] / "hil_sim" / "campaigns" / "paper_law.yaml")
    runs = {r.run_id: r for r in spec.runs}
    for mission in ("straight", "turn"):
        # THEN over the spec's 10 seeds it completes, near the goal (the paper: 0.13 m and 0.2 m; issue 23
        # item 6: within twice that). One seed is a coin toss for the turn: the law differentiates the noisy
        # error, and its final error per seed moves with anything that moves the noise (the packaged fix
        # sigma 10 -> 6 -> 4 -> 8 mm: seed 0 at 0.23, 0.29, 0.43, 0.07 m; the median 0.12-0.18 m)
        rows = [fly(runs[f"{mission}_s{seed}_c0d0_basin_o1_nominal"]).row for seed in range(10)]
        errors_m = sorted(r["final_position_error_m"] for r in rows)
        completed = [r for r in rows if r["final_state"] == "COMPLETE"]
        assert len(completed) >= 9, [r["final_reason"] for r in rows]  # the figure: 9/10
        assert statistics.median(errors_m) <= 0.2, errors_m
        out = fly(runs[f"{mission}_s0_c0d0_basin_o1_nominal"], keep_truth=True)
        # and the along-track error grows at the start (the vehicle starts at rest), then shrinks
        t_s, e_x, _ = paper_errors(out.truth, out.reference)
        peak = max(range(len(e_x)), key=lambda i: e_x[i] if t_s[i] - t_s[0] < 20.0 else -math.inf)
        assert e_x[peak] > 2.0 and 3.0 < t_s[peak] - t_s[0] < 20.0
        assert min(e_x[peak:]) < 0.75 * e_x[peak]


def test_a_run_on_the_local_bus_is_the_run_on_pythons_virtual_bus(monkeypatch: pytest.MonkeyPatch) -> None:
    # GIVEN the dodge run (obstacle, cross current) flown on the campaign's bus, python-can-based "local"
    # (frames handed over without a copy), and again on python-can's own "virtual" bus (a copy per frame)
    import dataclasses

    from auv_campaign import runner

    spec = parse_spec(SMALL, "<test>").runs[-1]
    opened: list[str] = []
    open_bus = runner.open_bus

    def noting_the_bus(*args: Any, **kwargs: Any) -> Any:
        bus = open_bus(*args, **kwargs)
        opened.append(type(bus).__name__)
        return bus

    monkeypatch.setattr(runner, "open_bus", noting_the_bus)
    local = fly(spec, keep_truth=True)
    campaign_config = runner.effective_onboard_config

    def on_virtual(sets: tuple[str, ...]) -> Any:
        cfg = campaign_config(sets)
        return dataclasses.replace(cfg, bus=dataclasses.replace(cfg.bus, interface="virtual"))

    monkeypatch.setattr(runner, "effective_onboard_config", on_virtual)
    virtual = fly(spec, keep_truth=True)
    assert opened == ["LocalBus", "LocalBus", "VirtualBus", "VirtualBus"]
    # THEN the two runs are the same, row for row and figure for figure (only the wall time differs)
    assert local.row["planned"] and local.row["ticks"] > 100
    assert local.truth == virtual.truth and local.reference == virtual.reference
    assert {k: v for k, v in local.row.items() if k != "wall_time_s"} == {
        k: v for k, v in virtual.row.items() if k != "wall_time_s"
    }


def test_no_run_is_running_at_its_time_limit_the_limit_is_never_shorter_than_the_vehicles_own_bound() -> None:
    # GIVEN the paper's turn in a 1.2 m/s current (strong_current.yaml): towards 90 deg the vehicle re-plans
    # wide turns and flies 78 m of path for a 32 m goal; towards 180 it misses the goal and loops back (at
    # the base both were RUNNING at the 73.4 s limit, twice the nominal time)
    from auv_campaign.runner import onboard_config, supervised_bound_s
    from onboard.core.executive.monitors import latest_end_s

    spec = load_spec(Path(__file__).parents[2] / "hil_sim" / "campaigns" / "strong_current.yaml")
    runs = {r.run_id: r for r in spec.runs}
    for run_id in ("turn_s0_c1.2d90_basin_default_nominal", "turn_s0_c1.2d180_basin_default_nominal"):
        run = runs[run_id]
        # WHEN it is flown
        row = fly(run).row
        # THEN the limit is at least the latest the vehicle's own monitors end it (each goal's ETA in the true
        # current, a window, the start), and the run ends before it: COMPLETE, or HOLD with the figure
        cfg, towards = onboard_config(run), math.radians(run.current_dir_deg)
        current = (1.2 * math.cos(towards), 1.2 * math.sin(towards))
        own = latest_end_s(cfg.core, [(31.7, math.atan2(-7.0, 25.0))], current)
        assert row["time_limit_s"] >= supervised_bound_s(run, cfg, [31.0]) > own > 73.4, row
        assert not row["time_limit_reached"], row["final_reason"]
        assert row["final_state"] in ("COMPLETE", "HOLD"), row["final_reason"]
        if row["final_state"] == "HOLD":
            figure = r"goal 0: .*(MIS_ETA_FACTOR|MIS_PROG_MPS|MIS_XTRACK|MIS_MG_MIN_MPS)"
            assert re.search(figure, row["final_reason"]), row["final_reason"]
