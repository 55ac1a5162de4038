"""``auv-hil tune`` as a user runs it: a process over a one-run spec, its files, a bad key, an offset that
would fly training seeds as held-out, and a Ray cluster that is not there."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
import yaml

from onboard.app.runtime import build_config

pytestmark = pytest.mark.slow

# One short straight line, one seed: a trial is one run.
TINY = {
    "name": "tiny",
    "missions": [{"name": "line", "start": {"x_m": -13, "y_m": 0, "depth_m": 1, "yaw_deg": 0},
                  "goals": [{"x_m": 2, "y_m": 0, "depth_m": 1, "yaw_deg": 0}]}],
    "sweep": {"seed": [0]},
}  # fmt: skip
KEY = "control.improved.Kp5"


def _tune(*args: str, timeout: float = 120.0) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "auv_campaign", "tune", *args, "--no-progress"],
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
    )


def _spec(tmp_path: Path) -> Path:
    path = tmp_path / "tiny.yaml"
    path.write_text(yaml.safe_dump(TINY))
    return path


def test_tune_writes_the_study_and_the_best_values(tmp_path: Path) -> None:
    # GIVEN a one-run spec, three trials of Kp5 on two workers
    out = tmp_path / "out"
    proc = _tune(str(_spec(tmp_path)), "--params", KEY, "--trials", "3", "--out", str(out), "--workers", "2")
    assert proc.returncode == 0, proc.stderr
    # THEN every file is there and the summary says where
    for name in ("best.toml", "trials.csv", "tune.json", "tune.html", "study.db"):
        assert (out / name).is_file(), name
    assert f"files: {out / 'best.toml'}" in proc.stdout
    doc = json.loads((out / "tune.json").read_text())
    base, best = doc["baseline"], doc["best"]
    current = build_config(None, []).control.improved.Kp5
    # AND trial 0 flew the current value, and the best is no worse than it on the training run
    with (out / "trials.csv").open(newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 3 and all(r["state"] == "COMPLETE" for r in rows)
    assert rows[0]["number"] == "0" and rows[0]["baseline"] == "True" and float(rows[0][KEY]) == current
    assert base["trial"] == 0 and base["values"] == {KEY: current}
    assert best["train_cost"] <= base["train_cost"]
    assert best["train_cost"] == min(float(r["cost"]) for r in rows)
    assert doc["trials"]["complete"] == 3 and base["train_runs"] == 1 and best["holdout_runs"] == 1
    assert base["holdout_cost"] is not None and best["holdout_success_rate"] is not None
    # AND the held-out set is said for what it is: the listed mission again, with other noise
    assert doc["holdout"]["description"] == (
        "the spec's 1 run with every noise seed + 1000 (seeds 0 -> 1000); the same missions (the spec lists "
        "them all), so other noise only"
    )
    assert f"held-out: {doc['holdout']['description']}" in proc.stdout
    # AND best.toml is TOML the onboard takes
    snippet = (out / "best.toml").read_text()
    value = tomllib.loads(snippet)["control"]["improved"]["Kp5"]
    assert value == best["values"][KEY]
    assert (
        "# merge these keys into onboard.toml (a file of its own as --config would drop every other"
        in snippet
    )
    sets = [line.removeprefix("#   --set ") for line in snippet.splitlines() if line.startswith("#   --set ")]
    assert sets == [f"{KEY}={json.dumps(value)}"]
    assert build_config(None, sets).control.improved.Kp5 == value
    assert "data:image/png;base64," in (out / "tune.html").read_text()


def test_tune_refuses_an_unknown_key_before_any_run(tmp_path: Path) -> None:
    out = tmp_path / "out"
    proc = _tune(
        str(_spec(tmp_path)), "--params", f"{KEY},control.improved.Kd5", "--trials", "3", "--out", str(out)
    )
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "control.improved.Kd5" in lines[0] and "KD5" in lines[0], proc.stderr
    assert not out.exists()


def test_tune_refuses_a_holdout_offset_onto_a_training_seed(tmp_path: Path) -> None:
    spec = tmp_path / "two.yaml"
    spec.write_text(yaml.safe_dump(dict(TINY, sweep={"seed": [0, 7]})))
    out = tmp_path / "out"
    proc = _tune(str(spec), "--params", KEY, "--trials", "3", "--out", str(out), "--holdout-seed-offset", "7")
    assert proc.returncode == 2
    assert proc.stderr == (
        "auv-hil tune: --holdout-seed-offset 7: held-out seed 7 would also be a training seed (the spec's "
        "seeds: 0, 7): give another offset\n"
    )
    assert not out.exists()


def test_tune_on_an_unreachable_ray_cluster_is_one_line(tmp_path: Path) -> None:
    # port 9 (discard) on this machine: nothing listens, the connection is refused at once
    out = tmp_path / "out"
    proc = _tune(
        str(_spec(tmp_path)), "--params", KEY, "--trials", "3", "--out", str(out), "--ray", "127.0.0.1:9"
    )
    assert proc.returncode == 1, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(
        "auv-hil tune: cannot join the Ray cluster at 127.0.0.1:9: "
    )
    assert proc.stdout == ""
