"""``auv-onboard plan`` CLI: called as ``main(argv)`` and once as a real process."""

from __future__ import annotations

import itertools
import json
import math
import subprocess
import sys
from pathlib import Path as FsPath

import pytest

from onboard.app.plan_cli import main

ROOT = FsPath(__file__).resolve().parents[3]


def _json(capsys: pytest.CaptureFixture[str], argv: list[str]) -> dict[str, object]:
    assert main(argv) == 0
    out = capsys.readouterr().out
    doc = json.loads(out)
    assert isinstance(doc, dict)
    return doc


def test_json_paper_example(capsys: pytest.CaptureFixture[str]) -> None:
    doc = _json(capsys, ["--start", "0,0,90", "--goal", "30,20,0", "--radius", "2", "--json"])
    assert doc["word"] == "LSL"
    assert doc["length_m"] == pytest.approx(36.428226608, abs=1e-6)
    assert len(doc["virtual_goals"]) == 2  # type: ignore[arg-type]
    assert [s["kind"] for s in doc["segments"]] == ["L", "S", "L"]  # type: ignore[union-attr,index]
    assert doc["cost"] == pytest.approx(doc["length_m"])
    assert "samples" not in doc


@pytest.mark.parametrize(
    "argv",
    [
        ["--start", "-15,5,0", "--goal", "10,-2,270", "--radius", "3"],
        ["--start=-15,5,0", "--goal=10,-2,270", "--radius=3"],
        ["--goal", "10,-2,270", "--start", "-15,5,0", "--radius", "3"],
    ],
)
def test_negative_numbers_both_spellings(capsys: pytest.CaptureFixture[str], argv: list[str]) -> None:
    doc = _json(capsys, [*argv, "--json", "--sample-step", "0.5"])
    samples = doc["samples"]
    assert isinstance(samples, list)
    assert samples[0] == pytest.approx([-15.0, 5.0, 0.0], abs=1e-9)
    x, y, yaw_deg = samples[-1]
    assert (x, y) == pytest.approx((10.0, -2.0), abs=1e-6)
    assert math.remainder(yaw_deg - 270.0, 360.0) == pytest.approx(0.0, abs=1e-6)
    steps = [math.hypot(b[0] - a[0], b[1] - a[1]) for a, b in itertools.pairwise(samples)]
    assert max(steps) <= 0.5 + 1e-9


def test_obstacles_weights_depth(capsys: pytest.CaptureFixture[str]) -> None:
    doc = _json(
        capsys,
        [
            "--start", "0,0,0", "--goal", "40,0,0", "--radius", "3",
            "--obstacle", "20,0.5,3", "--obstacle", "-10,-10,1",
            "--weights", "1,0.5,0", "--depth", "2,8", "--json", "--sample-step", "5",
        ],
    )  # fmt: skip
    assert doc["length_m"] > 40.0  # type: ignore[operator]
    assert len(str(doc["word"])) > 3
    assert doc["start_depth_m"] == 2.0 and doc["end_depth_m"] == 8.0
    assert doc["sample_depths_m"][-1] == pytest.approx(8.0)  # type: ignore[index]


def test_config_file_and_override(tmp_path: FsPath, capsys: pytest.CaptureFixture[str]) -> None:
    cfg = tmp_path / "onboard.toml"
    cfg.write_text("[loop]\nrate_hz = 20\n\n[planner]\nturning_radius_m = 5.0\ncsc_only = true\n")
    doc = _json(capsys, ["--start", "0,0,90", "--goal", "30,20,0", "--config", str(cfg), "--json"])
    assert doc["radius_m"] == 5.0
    assert doc["length_m"] == pytest.approx(37.008741108, abs=1e-6)
    doc = _json(
        capsys, ["--start", "0,0,90", "--goal", "30,20,0", "--config", str(cfg), "--radius", "3", "--json"]
    )
    assert doc["radius_m"] == 3.0
    assert doc["length_m"] == pytest.approx(36.618501247, abs=1e-6)


@pytest.mark.parametrize(
    "argv",
    [
        ["--start", "0,0", "--goal", "1,1,0", "--radius", "2"],
        ["--start", "0,0,0", "--goal", "1,1,0", "--radius", "0"],
        ["--start", "0,0,0", "--goal", "1,1,0", "--radius", "nan"],
        ["--start", "0,0,x", "--goal", "1,1,0", "--radius", "2"],
        ["--start", "0,0,0", "--goal", "1,1,0"],
        ["--start", "0,0,0", "--goal", "10,0,0", "--radius", "2", "--obstacle", "10,0,1"],
        ["--start", "0,0,0", "--goal", "10,0,0", "--radius", "2", "--obstacle", "5,5"],
        ["--start", "0,0,0", "--goal", "10,0,0", "--radius", "2", "--sample-step", "0"],
        ["--start", "0,0,0", "--goal", "10,0,0", "--radius", "2", "--config", "/nonexistent.toml"],
        ["--start", "0,0,0", "--goal", "10,0,0", "--radius", "2", "--bogus"],
    ],
)
def test_bad_input_exit_2_one_line(capsys: pytest.CaptureFixture[str], argv: list[str]) -> None:
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1
    assert lines[0].startswith("auv-onboard plan: error:")
    assert "Traceback" not in captured.err


def test_bad_config_key(tmp_path: FsPath, capsys: pytest.CaptureFixture[str]) -> None:
    cfg = tmp_path / "onboard.toml"
    cfg.write_text("[planner]\nturn_radius = 5.0\n")
    assert main(["--start", "0,0,0", "--goal", "10,0,0", "--config", str(cfg)]) == 2
    assert "unknown key turn_radius" in capsys.readouterr().err


def test_plot_file_written(tmp_path: FsPath, capsys: pytest.CaptureFixture[str]) -> None:
    png = tmp_path / "plan.png"
    argv = [
        "--start",
        "-15,5,0",
        "--goal",
        "10,-2,270",
        "--radius",
        "3",
        "--obstacle",
        "0,2,2",
        "--plot",
        str(png),
    ]
    assert main(argv) == 0
    assert "word" in capsys.readouterr().out
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.integration  # a process of its own
def test_runs_as_module() -> None:
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "onboard.app.plan_cli",
            "--start",
            "-15,5,0",
            "--goal=10,-2,270",
            "--radius",
            "3",
            "--json",
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout)["length_m"] > 0.0
    bad = subprocess.run(
        [sys.executable, "-m", "onboard.app.plan_cli", "--start", "0,0", "--goal", "1,1,1", "--radius", "2"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert bad.returncode == 2
    assert len(bad.stderr.strip().splitlines()) == 1


def test_last_goal_plans_along_the_run_ins_straight(capsys: pytest.CaptureFixture[str]) -> None:
    # GIVEN the packaged onboard.toml (5 m goal run-in; the run-in slows 1 -> 0.25 m/s at 0.025 m/s^2)
    toml = str(FsPath(__file__).resolve().parents[3] / "onboard" / "config" / "onboard.toml")
    argv = ["--start=-15,5,0", "--goal=10,-2,270", "--config", toml, "--json"]
    # WHEN the paper's turn is planned as the mission's last goal THEN it ends in 18.75 m of straight (the
    # run-in's deceleration: the path the vehicle flies), without the flag in the planner's 5 m
    last = _json(capsys, [*argv, "--last-goal"])["segments"][-1]  # type: ignore[index]
    assert last["kind"] == "S" and last["length_m"] == pytest.approx(18.75)  # type: ignore[index]
    last = _json(capsys, argv)["segments"][-1]  # type: ignore[index]
    assert last["kind"] == "S" and last["length_m"] == pytest.approx(5.0)  # type: ignore[index]
