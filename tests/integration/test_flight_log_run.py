"""The flight log of a real `auv-onboard run` (with the bench `auv-hil run` in real time, both processes):
one MCAP file in the state directory, written while it flies, closed with its footer on SIGINT, drawn by
`auv-gcs plot`."""

from __future__ import annotations

import itertools
import json
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from mcap.reader import make_reader

from groundstation.__main__ import main as gcs_main
from groundstation.plot import read_flight_log
from hil_sim.scenario import free_port, free_udp_port
from tests.e2e.procs import processes
from tests.waiting import wait_until

pytestmark = pytest.mark.e2e

START = (-13.0, 0.0, 0.0)  # x, y (m), yaw (deg): paper-straight
MISSION = """goals:
  - {x_m: 15.0, y_m: 0.0, depth_m: 1.0, yaw_deg: 0.0}
obstacles:
  - {x_m: 0.0, y_m: 6.0, radius_m: 1.5}
"""


def _running(logs: Path) -> Path | None:
    """The flight log once it shows the vehicle RUNNING (the log is flushed every second as it flies)."""
    files = sorted(logs.glob("flight-*.mcap"))
    if not files:
        return None
    try:
        data = read_flight_log(files[0])
    except ValueError:  # not a tick written yet
        return None
    return files[0] if any(e["to_state"] == "RUNNING" for e in data.events) else None


def _ticks_logged(logs: Path) -> int:
    """The /telemetry messages of the flight log flushed so far."""
    files = sorted(logs.glob("flight-*.mcap"))
    try:
        return len(read_flight_log(files[0]).telemetry) if files else 0
    except ValueError:
        return 0


def test_a_real_run_logs_every_tick_and_closes_the_file_on_sigint(tmp_path: Path, capsys) -> None:
    # GIVEN the bench in real time and the firmware with MAVLink, a mission with a fence and --autostart
    channel = f"ws://127.0.0.1:{free_port()}/"
    mission = tmp_path / "mission.yaml"
    mission.write_text(MISSION)
    state = tmp_path / "state"
    logs = state / "logs"
    hil_cmd = [
        sys.executable, "-m", "hil_sim", "run", "--mode=realtime", f"--channel={channel}",
        f"--start={START[0]},{START[1]},1.0,{START[2]}", "--duration=30", "--profile=basin",
    ]  # fmt: skip
    onboard_cmd = [
        sys.executable, "-m", "onboard", "run",
        "--set", f'bus.channel="{channel}"',
        "--set", f'mavlink.endpoints=["udpin:127.0.0.1:{free_udp_port()}"]',
        "--state-dir", str(state), "--mission", str(mission), "--autostart",
    ]  # fmt: skip
    with processes() as procs, open(tmp_path / "procs.log", "w") as out:
        procs.append(subprocess.Popen(hil_cmd, stdout=out, stderr=subprocess.STDOUT))
        onboard = subprocess.Popen(onboard_cmd, stdout=out, stderr=subprocess.STDOUT)
        procs.append(onboard)
        # WHEN it flies (the log itself says when: RUNNING in /events) until 40 ticks more are logged (2 s
        # at 20 Hz; the log is flushed every second), then gets SIGINT
        wait_until(lambda: _running(logs) is not None or onboard.poll() is not None, 30.0, "RUNNING logged")
        assert _running(logs) is not None, (tmp_path / "procs.log").read_text()[-3000:]
        flying_from = _ticks_logged(logs)
        wait_until(
            lambda: _ticks_logged(logs) >= flying_from + 40 or onboard.poll() is not None,
            30.0,
            "40 ticks more",
        )
        onboard.send_signal(signal.SIGINT)
        code = onboard.wait(10.0)
    assert code == 0, (tmp_path / "procs.log").read_text()[-3000:]
    # THEN one file, number 1, that mcap's reader opens with its summary (the footer written)
    files = sorted(logs.glob("*.mcap"))
    assert len(files) == 1 and files[0].name.startswith("flight-000001-20"), files
    with open(files[0], "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None and summary.statistics is not None
        topics = {c.id: c.topic for c in summary.channels.values()}
        counts = {topics[i]: n for i, n in summary.statistics.channel_message_counts.items()}
        ticks = [m for _s, _c, m in reader.iter_messages(topics=["/telemetry"])]
        events = [json.loads(m.data) for _s, _c, m in reader.iter_messages(topics=["/events"])]
        meta = {m.name: m.metadata for m in reader.iter_metadata()}
    assert set(counts) >= {"/telemetry", "/path", "/mission", "/events"}, counts
    assert counts["/telemetry"] == len(ticks) >= 40
    # AND /telemetry one message per tick in the loop's time order (how regularly the loop ticks under load
    # is auv-bench's, section loop: lateness and overruns)
    assert all(a.log_time < b.log_time for a, b in itertools.pairwise(ticks)), "ticks out of order"
    # AND the state events: ARMED by --autostart, then RUNNING once navigation is valid
    changes = [(e["from_state"], e["to_state"]) for e in events if e["kind"] == "state"]
    assert ("ARMED", "RUNNING") in changes, changes
    assert meta["flight_log"]["vehicle"] == "ISiMI100" and meta["flight_log"]["start_utc"].endswith("Z")
    assert meta["flight_log"]["config"].endswith("onboard.toml") and "loop.rate_hz" in meta["config"]
    assert meta["flight_log_end"]["dropped_ticks"] == "0"
    log_text = (tmp_path / "procs.log").read_text()
    assert "Traceback" not in log_text and "flight log off" not in log_text
    # AND `auv-gcs plot` draws it: every tick's position, the planned path, the goal, the fence, the states
    png = tmp_path / "flight.png"
    assert gcs_main(["--json", "plot", str(files[0]), "-o", str(png)]) == 0
    drawn = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert drawn["ok"] and png.stat().st_size > 10_000, drawn
    fixed = [m for m in ticks if json.loads(m.data)["x_m"] is not None]  # none before the first fix
    assert drawn["ticks"] == len(ticks) and drawn["positions"] == len(fixed) >= len(ticks) - 5
    assert drawn["path_points"] >= 28 / 0.5 and drawn["paths"] >= 1  # 28 m to the goal, every 0.5 m
    assert drawn["goals"] == 1 and drawn["obstacles"] == 1 and drawn["state_changes"] >= 1
    assert drawn["truncated"] == 0
