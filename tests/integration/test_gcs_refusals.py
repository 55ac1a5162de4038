"""Issue 21 rows 1 and 10, the ground station's side: ``auv-gcs upload`` and ``auv-gcs params set`` as
processes against the real vehicle (the standalone process) whose state directory is full (a 1 MB tmpfs,
:func:`tests.integration.mavlink.test_storage.disk`; skipped with the reason where it cannot be mounted):
each prints the vehicle's reason and exits 1 (refused), and the upload says what is in force afterwards."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

from groundstation.bench_upload import start_vehicle, stop_vehicle
from tests.integration.mavlink.test_storage import WAIT_S, Disk, disk  # noqa: F401 (the fixture)

MISSION_A = "goals:\n  - {x_m: 5.0, y_m: 0.0, depth_m: 1.0}\n"
MISSION_B = "goals:\n  - {x_m: 7.0, y_m: 0.0, depth_m: 1.0}\n  - {x_m: 7.0, y_m: 3.0, depth_m: 1.0}\n"


def gcs(port: int, tmp: Path, *args: str, as_json: bool = False) -> tuple[int, str]:
    cmd = [sys.executable, "-m", "groundstation", "--connect", f"udpout:127.0.0.1:{port}", "--timeout", "20"]
    cmd += [*(["--json"] if as_json else []), "--tlog-dir", str(tmp / "tlogs"), *args]
    r = subprocess.run(
        cmd, capture_output=True, text=True, timeout=120, check=False, env={**os.environ, "COLUMNS": "300"}
    )
    return r.returncode, r.stdout + r.stderr


def last_json(out: str) -> dict[str, Any]:
    return json.loads([x for x in out.splitlines() if x.startswith("{")][-1])


def test_upload_and_params_set_that_cannot_be_saved_print_the_reason_and_exit_1(
    disk: Disk,  # noqa: F811
    tmp_path: Path,
) -> None:
    a, b = tmp_path / "a.yaml", tmp_path / "b.yaml"
    a.write_text(MISSION_A)
    b.write_text(MISSION_B)
    proc, port = start_vehicle(disk.path, timeout_s=WAIT_S)
    try:
        # GIVEN mission A and PD_KP5 -0.4 saved, then the vehicle's disk full
        assert gcs(port, tmp_path, "upload", str(a))[0] == 0
        assert gcs(port, tmp_path, "params", "set", "PD_KP5", "-0.4")[0] == 0
        disk.fill()
        # WHEN the operator uploads mission B and sets PD_KP5 -0.5
        code, out = gcs(port, tmp_path, "upload", str(b))
        # THEN each is refused with the vehicle's reason, exit 1, and the upload says what is in force
        assert code == 1, out
        assert "REFUSED" in out and "No space left on device" in out, out
        assert "in force on the vehicle: 1 mission items, 0 fence circles" in out, out
        code, out = gcs(port, tmp_path, "upload", str(b), as_json=True)
        data = last_json(out)
        assert code == 1 and not data["ok"] and "No space left on device" in data["reason"], out
        code, out = gcs(port, tmp_path, "params", "set", "PD_KP5", "-0.5")
        assert code == 1, out
        assert "PD_KP5 = -0.4 (refused -0.5" in out and "No space left on device" in out, out
        code, out = gcs(port, tmp_path, "download", as_json=True)
        assert code == 0 and last_json(out)["goals"] == 1, out  # mission A, as it was
    finally:
        stop_vehicle(proc)
