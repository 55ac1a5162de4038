"""auv-gcs end to end against the in-process endpoint: files, --json, params, commands, tlog and plot."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from groundstation.__main__ import main
from groundstation.mission_files import MissionFileError, load
from tests.integration.mavlink.conftest import Vehicle

YAML = """goals:
  - {x_m: 20.0, y_m: 5.0, depth_m: 2.0, yaw_deg: 90}
  - {x_m: 30.0, y_m: -5.0, depth_m: 3.0}
obstacles:
  - {x_m: 10.0, y_m: 2.0, radius_m: 3.0}
"""
WPL = """QGC WPL 110
0\t1\t0\t16\t0\t0\t0\t0\t35.1\t129.04\t0\t1
1\t0\t1\t16\t0\t0\t0\tnan\t12.5\t-4\t1.5\t1
2\t0\t1\t5004\t2.5\t0\t0\t0\t5\t5\t0\t1
"""


def run(capsys: pytest.CaptureFixture[str], vehicle: Vehicle, tmp_path: Path, *args: str) -> tuple[int, dict]:
    url = f"udpout:127.0.0.1:{vehicle.port}"
    code = main(["--connect", url, "--json", "--tlog-dir", str(tmp_path / "tlogs"), "--timeout", "3", *args])
    out = capsys.readouterr().out.strip().splitlines()
    return code, json.loads(out[-1]) if out else {}


def test_cli_session(vehicle: Vehicle, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    f = tmp_path / "m.yaml"
    f.write_text(YAML)
    code, out = run(capsys, vehicle, tmp_path, "upload", str(f))
    assert code == 0 and out["ok"] and [r["items"] for r in out["results"]] == [2, 1]
    m = vehicle.link.mission()
    assert [g.x_m for g in m.goals] == [20.0, 30.0] and m.obstacles[0].radius_m == 3.0
    code, out = run(capsys, vehicle, tmp_path, "download")
    assert code == 0 and out["mission"]["goals"][0] == {
        "x_m": 20.0,
        "y_m": 5.0,
        "depth_m": 2.0,
        "yaw_deg": 90.0,
    }
    assert out["mission"]["goals"][1]["yaw_deg"] is None
    code, out = run(capsys, vehicle, tmp_path, "download", str(tmp_path / "back.yaml"))
    assert code == 0 and load(tmp_path / "back.yaml")[0] == load(f)[0]
    assert run(capsys, vehicle, tmp_path, "start")[0] == 1  # not armed: refused
    assert run(capsys, vehicle, tmp_path, "arm")[1]["result"] == "MAV_RESULT_ACCEPTED"
    assert run(capsys, vehicle, tmp_path, "start")[0] == 0
    assert run(capsys, vehicle, tmp_path, "abort")[0] == 0
    code, out = run(capsys, vehicle, tmp_path, "params", "set", "LIM_RPS", "30")
    assert code == 0 and out["value"] == 30.0
    code, out = run(capsys, vehicle, tmp_path, "params", "set", "LIM_RPS", "999")
    assert code == 1 and out["value"] == 30.0
    code, out = run(capsys, vehicle, tmp_path, "params")
    assert code == 0 and out["params"]["LIM_RPS"] == 30.0
    code, out = run(capsys, vehicle, tmp_path, "monitor", "--duration", "1.2")
    assert code == 0 and out["state"] in ("ABORT", "COMPLETE")
    code, out = run(capsys, vehicle, tmp_path, "clear")
    assert code == 0 and vehicle.link.mission().goals == ()
    tlogs = sorted((tmp_path / "tlogs").glob("*.tlog"))
    assert len(tlogs) >= 10
    biggest = max(tlogs, key=lambda p: p.stat().st_size)
    code, out = run(capsys, vehicle, tmp_path, "plot", str(biggest), "-o", str(tmp_path / "plot.png"))
    assert code == 0 and (tmp_path / "plot.png").stat().st_size > 1000


def test_cli_upload_refused_exit_code_and_wpl(vehicle: Vehicle, tmp_path: Path, capsys) -> None:
    f = tmp_path / "far.yaml"
    f.write_text("goals:\n  - {x_m: 5000.0, y_m: 0.0, depth_m: 1.0}\n")
    code, out = run(capsys, vehicle, tmp_path, "upload", str(f))
    assert code == 1 and out["results"][0]["result"] == "MAV_MISSION_INVALID_PARAM5_X"
    w = tmp_path / "m.waypoints"
    w.write_text(WPL)
    goals, fences = load(w)
    assert len(goals) == 1 and len(fences) == 1 and goals[0].x == 125000
    code, out = run(capsys, vehicle, tmp_path, "upload", str(w))
    assert code == 0
    assert vehicle.link.mission().goals[0].x_m == 12.5 and vehicle.link.mission().obstacles[0].radius_m == 2.5


def test_cli_bad_file_and_no_vehicle(tmp_path: Path, capsys) -> None:
    f = tmp_path / "bad.yaml"
    f.write_text("goals:\n  - {x_m: 1}\n")
    with pytest.raises(MissionFileError):
        load(f)
    assert main(["--json", "upload", str(f)]) == 2
    code = main(
        ["--connect", "udpout:127.0.0.1:9", "--json", "--timeout", "0.5", "--tlog-dir", str(tmp_path), "arm"]
    )
    assert code == 2 and "heartbeat" in capsys.readouterr().out
