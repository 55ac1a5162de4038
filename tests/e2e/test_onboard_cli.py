"""`auv-onboard run` as a process: bad configuration is one clear line; a missing bus is waited for."""

from __future__ import annotations

import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.waiting import wait_until

pytestmark = pytest.mark.e2e

RUN = [sys.executable, "-m", "onboard", "run", "--no-mavlink"]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--set", 'bus.interface="kvaser"'], "must be one of"),
        (["--set", 'bus.channel="127.0.0.1:54701"'], "malformed remote channel"),
        (["--set", "nosuch.key=1"], "unknown key nosuch"),
        (["--set", "loop.rate_hz=500"], "rate_hz must be in [1, 200] Hz, got 500"),
        (["--mission", "/nonexistent/mission.yaml"], "No such file"),
        (["--config", "/nonexistent/onboard.toml"], "no such configuration file"),
    ],
)
def test_bad_configuration_exits_2_with_one_line(args: list[str], message: str) -> None:
    out = subprocess.run([*RUN, *args], capture_output=True, text=True, timeout=30, check=False)
    assert out.returncode == 2
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0], out.stderr
    assert "Traceback" not in out.stderr


@pytest.mark.parametrize("prog", ["onboard", "hil_sim", "groundstation"])
def test_every_program_has_help(prog: str) -> None:
    out = subprocess.run([sys.executable, "-m", prog, "--help"], capture_output=True, text=True, timeout=30)
    assert out.returncode == 0 and "usage" in out.stdout.lower()


def test_onboard_help_says_what_it_reads_sends_and_at_what_rate() -> None:
    out = subprocess.run(
        [sys.executable, "-m", "onboard", "--help"], capture_output=True, text=True, timeout=30
    )
    text = out.stdout
    assert "Reads" in text and "sends" in text and "20 Hz" in text


def test_waits_for_a_missing_bus_then_stops_cleanly_on_sigterm(tmp_path: Path) -> None:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]  # a free port where no hub listens
    log = tmp_path / "onboard.log"
    with open(log, "w") as out_file:
        proc = subprocess.Popen(
            [*RUN, "--set", f'bus.channel="ws://127.0.0.1:{port}/"', "--set", "bus.retry_log_interval_s=0.5"],
            stdout=out_file,
            stderr=subprocess.STDOUT,
            text=True,
        )
    try:
        # GIVEN it has said twice that it waits for the bus (every 0.5 s), still running, not crashed
        wait_until(
            lambda: log.read_text().count("waiting for remote bus") >= 2 or proc.poll() is not None,
            30.0,
            "waiting for remote bus, twice",
        )
        assert proc.poll() is None, log.read_text()
        proc.send_signal(signal.SIGTERM)
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    out = log.read_text()
    assert proc.returncode == 0, out
    assert "Traceback" not in out


def test_a_persisted_edit_refused_at_boot_is_reported_and_removed_from_the_file(tmp_path) -> None:
    # GIVEN a state directory whose params.json holds a value no longer allowed (45 deg: beyond the DBC's
    # FIN_CMD rudder range) and one that is fine
    import json

    state = tmp_path / "state"
    state.mkdir()
    (state / "params.json").write_text(
        json.dumps({"version": 1, "params": {"LIM_RUDDER_DEG": 45.0, "PD_KP5": -0.5}})
    )
    with socket.socket() as s:  # a hub nobody hosts: the firmware waits for the bus
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    proc = subprocess.Popen(
        [
            sys.executable, "-m", "onboard", "run", "--state-dir", str(state),
            "--set", f'bus.channel="ws://127.0.0.1:{port}/"',
            "--set", 'mavlink.endpoints=["udpin:127.0.0.1:0"]',
        ],
        stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        deadline = time.monotonic() + 20.0
        kept: dict[str, float] = {}
        while time.monotonic() < deadline:
            kept = json.loads((state / "params.json").read_text())["params"]
            if "LIM_RUDDER_DEG" not in kept:
                break
            time.sleep(0.1)
    finally:
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=20)
    # THEN the refused one is logged with the reason and dropped from the file; the good one stays
    assert kept == {"PD_KP5": -0.5}
    assert "LIM_RUDDER_DEG" in err and "dropped" in err and "Traceback" not in err
