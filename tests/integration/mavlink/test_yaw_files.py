"""Issue 21 row 16 at the file doors, as processes: a goal's yaw is NaN / absent (free) or within
[-360, 360] deg, else one line naming the goal: ``auv-onboard run --mission`` (the onboard's YAML mission
file), ``auv-hil campaign`` (a campaign spec) and ``auv-gcs upload`` of a YAML file (the ground station sends
it; the vehicle's validator refuses it with INVALID_PARAM4 and its reason names the goal). The rule is one,
``onboard.core.mission.validate.check_goal_values``: the doors ask it."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from groundstation.__main__ import main as gcs_main
from tests.integration.mavlink.conftest import Vehicle

TIMEOUT_S = 120.0  # a loaded 2-core machine starts a Python process slowly


def mission_yaml(yaw_deg: str) -> str:
    return (
        "goals:\n"
        "  - {x_m: 10.0, y_m: 0.0, depth_m: 1.0}\n"
        f"  - {{x_m: 10.0, y_m: 10.0, depth_m: 1.0, yaw_deg: {yaw_deg}}}\n"
    )


def spec_yaml(yaw_deg: str) -> str:
    return (
        "name: yaw\n"
        "missions:\n"
        "  - start: {x_m: 0, y_m: 0, depth_m: 1, yaw_deg: 0}\n"
        "    goals: [{x_m: 10, y_m: 0, depth_m: 1},\n"
        f"            {{x_m: 10, y_m: 10, depth_m: 1, yaw_deg: {yaw_deg}}}]\n"
    )


def refusal_line(err: str) -> str:
    lines = [line for line in err.strip().splitlines() if line.strip()]
    assert "Traceback" not in err, err
    assert len(lines) == 1, err  # one line
    return lines[0]


def test_onboard_mission_file_with_yaw_999_is_one_line_naming_the_goal(tmp_path: Path) -> None:
    f = tmp_path / "m.yaml"
    f.write_text(mission_yaml("999"))
    proc = subprocess.run(
        [sys.executable, "-m", "onboard", "run", "--no-mavlink", "--mission", str(f)],
        capture_output=True, text=True, timeout=TIMEOUT_S,
    )  # fmt: skip
    assert proc.returncode == 2, (proc.returncode, proc.stderr)
    line = refusal_line(proc.stderr)
    assert str(f) in line and "goal 1" in line and "yaw 999 deg" in line and "360" in line, line


def test_campaign_spec_with_yaw_999_is_one_line_naming_the_goal(tmp_path: Path) -> None:
    f = tmp_path / "spec.yaml"
    f.write_text(spec_yaml("999"))
    proc = subprocess.run(
        [sys.executable, "-m", "auv_campaign", "campaign", str(f), "--out", str(tmp_path / "out")],
        capture_output=True, text=True, timeout=TIMEOUT_S,
    )  # fmt: skip
    assert proc.returncode == 2, (proc.returncode, proc.stderr)
    line = refusal_line(proc.stderr)
    assert "missions[0].goals[1]" in line and "yaw 999 deg" in line and "360" in line, line
    assert not (tmp_path / "out" / "runs").exists()  # nothing flown


@pytest.mark.parametrize("yaw", ["360", "-360", "null", ".nan"])
def test_yaw_360_and_free_are_accepted_by_the_file_and_the_campaign(yaw: str, tmp_path: Path) -> None:
    from auv_campaign.spec import load_spec
    from onboard.app.config import load_config
    from onboard.app.mission_file import load_mission

    f = tmp_path / "m.yaml"
    f.write_text(mission_yaml(yaw))
    if yaw != ".nan":  # a YAML NaN is "not a finite number" in a file: leave the key out for a free heading
        assert len(load_mission(f, load_config().core).goals) == 2
    s = tmp_path / "spec.yaml"
    s.write_text(spec_yaml(yaw))
    if yaw != ".nan":
        assert len(load_spec(s).runs) == 1


def test_gcs_upload_of_a_yaml_file_with_yaw_999_prints_the_vehicles_reason(
    vehicle: Vehicle, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    f = tmp_path / "m.yaml"
    f.write_text(mission_yaml("999"))
    url = f"udpout:127.0.0.1:{vehicle.port}"
    code = gcs_main(["--connect", url, "--json", "--tlog-dir", str(tmp_path / "tlogs"), "upload", str(f)])
    out = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert code == 1 and out["result"] == "MAV_MISSION_INVALID_PARAM4", out
    assert "goal 1" in out["reason"] and "yaw 999 deg" in out["reason"], out
    assert vehicle.link.mission().goals == ()
