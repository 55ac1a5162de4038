"""``auv-hil run`` as a real process: lock-step determinism over the hub, the CLI's help and errors, SIGTERM.

The lock-step runs pair the bench (hosting its python-can-remote hub on a free loopback port) with the
scripted commander process (``scripted_commander.py``), which answers every SYNC with commands that depend on
the tick and on the sensor frames. Same seed: byte-identical truth logs; another seed: a different log. One
log file per process in the test's tmp dir; every process is terminated, then killed, in a ``finally``.
"""

from __future__ import annotations

import json
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import pytest

from auv_common.process import stop_process
from onboard.protocol.bus import DEFAULT_HUB_PORT, DEFAULT_REMOTE_CHANNEL, BusConfig, open_bus
from onboard.protocol.codec import Codec
from onboard.protocol.messages import FinStatus
from onboard.protocol.port import BusPort

pytestmark = pytest.mark.e2e

COMMANDER = Path(__file__).with_name("scripted_commander.py")
RATE_HZ = 20.0  # the packaged bench.toml control rate
DURATION_S = 20.0
RUN_TIMEOUT_S = 60.0  # wall clock for one lock-step run (about 3 s on an idle machine)
START = "-13,0,1,0"  # the paper's straight-line start, 1 m deep


def _hil() -> list[str]:
    """The installed ``auv-hil`` entry point (or the module, when the venv's script is not beside python)."""
    script = Path(sys.executable).with_name("auv-hil")
    return [str(script)] if script.exists() else [sys.executable, "-m", "hil_sim"]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@contextmanager
def _cleanup() -> Iterator[list[subprocess.Popen[bytes]]]:
    procs: list[subprocess.Popen[bytes]] = []
    try:
        yield procs
    finally:
        for proc in procs:
            stop_process(proc, 3.0)


def _spawn(procs: list[subprocess.Popen[bytes]], argv: list[str], log_base: Path) -> subprocess.Popen[bytes]:
    """Start a process with its stdout / stderr in ``log_base``.out / .err."""
    with log_base.with_suffix(".out").open("wb") as out, log_base.with_suffix(".err").open("wb") as err:
        proc = subprocess.Popen(argv, stdout=out, stderr=err, cwd=log_base.parent)
    procs.append(proc)
    return proc


def _tail(path: Path, lines: int = 15) -> str:
    text = path.read_text(errors="replace") if path.exists() else "(no file)"
    return f"--- {path.name} ---\n" + "\n".join(text.splitlines()[-lines:])


@dataclass
class LockstepRun:
    name: str
    truth: Path
    bench: subprocess.Popen[bytes]
    commander: subprocess.Popen[bytes]
    dir: Path

    def wait(self, deadline: float) -> None:
        for proc, who in ((self.bench, "bench"), (self.commander, "commander")):
            try:
                proc.wait(max(0.1, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                pytest.fail(f"{self.name}: {who} still running at the deadline\n{self.logs()}")

    def logs(self) -> str:
        return "\n".join(
            _tail(self.dir / f"{who}.{ext}") for who in ("bench", "commander") for ext in ("err", "out")
        )


def _start_lockstep(procs: list[subprocess.Popen[bytes]], root: Path, name: str, seed: int) -> LockstepRun:
    run_dir = root / name
    run_dir.mkdir()
    url = f"ws://127.0.0.1:{_free_port()}/"
    truth = run_dir / "truth.csv"
    bench = _spawn(
        procs,
        [
            *_hil(),
            "run",
            "--mode",
            "lockstep",
            "--channel",
            url,
            "--truth-log",
            str(truth),
            "--duration",
            str(DURATION_S),
            "--start",
            START,
            "--seed",
            str(seed),
        ],
        run_dir / "bench",
    )
    ticks = round(DURATION_S * RATE_HZ)
    commander = _spawn(
        procs,
        [sys.executable, str(COMMANDER), "--channel", url, "--ticks", str(ticks), "--depth", "1.0"],
        run_dir / "commander",
    )
    return LockstepRun(name, truth, bench, commander, run_dir)


def test_lockstep_runs_over_real_processes_repeat_byte_for_byte(tmp_path: Path) -> None:
    # GIVEN three bench + commander pairs on their own hubs, two with seed 7 and one with seed 8
    with _cleanup() as procs:
        runs = [
            _start_lockstep(procs, tmp_path, name, seed)
            for name, seed in (("seed7-a", 7), ("seed7-b", 7), ("seed8", 8))
        ]
        # WHEN they all run 20 simulated seconds in lock-step (concurrently: wall-clock load must not matter)
        deadline = time.monotonic() + RUN_TIMEOUT_S
        for run in runs:
            run.wait(deadline)
    ticks = round(DURATION_S * RATE_HZ)
    for run in runs:
        assert run.bench.returncode == 0, f"{run.name}: bench exited {run.bench.returncode}\n{run.logs()}"
        assert run.commander.returncode == 0, f"{run.name}: commander failed\n{run.logs()}"
        summary = json.loads((run.dir / "commander.out").read_text().strip().splitlines()[-1])
        assert summary["answered"] == ticks and summary["rejected"] == {}, summary
        rows = run.truth.read_text().splitlines()
        assert len(rows) == 1 + ticks, f"{run.name}: {len(rows) - 1} rows"
        assert float(rows[-1].split(",")[0]) == pytest.approx(DURATION_S)
    a, b, c = (run.truth.read_bytes() for run in runs)
    # THEN the same seed gives the same truth log, byte for byte
    assert a == b, "two lock-step runs with the same seed differ"
    # AND another seed (other sensor noise, fed back by the commander) gives another log
    assert a != c, "a different seed gave the same truth log"


def test_run_help_explains_both_time_modes() -> None:
    out = subprocess.run([*_hil(), "run", "--help"], capture_output=True, text=True, timeout=30, check=False)
    assert out.returncode == 0, out.stderr
    text = " ".join(out.stdout.split())
    assert "realtime" in text and "lockstep" in text
    assert "--mode" in text and "SYNC" in text


@pytest.mark.parametrize(
    "args",
    [
        ["--channel", "notaurl"],
        ["--channel", "ws://192.0.2.1:54701/"],  # not loopback: the bench bus must not leave the machine
        ["--start", "1,2"],
        ["--current", "nan,0"],
    ],
    ids=["malformed-channel", "non-loopback-hub", "short-start", "nan-current"],
)
def test_bad_configuration_exits_2_with_one_line(args: list[str], tmp_path: Path) -> None:
    # GIVEN a bad option WHEN the bench starts
    out = subprocess.run(
        [*_hil(), "run", *args], capture_output=True, text=True, timeout=30, check=False, cwd=tmp_path
    )
    # THEN it stops at once with exit code 2 and one clear line on stderr, no traceback
    assert out.returncode == 2, out.stderr
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("auv-hil: "), out.stderr
    assert "Traceback" not in out.stderr


def _port_free(port: int) -> bool:
    with socket.socket() as s:
        try:
            s.bind(("127.0.0.1", port))
        except OSError:
            return False
    return True


def test_default_config_starts_the_hub_and_stops_on_sigterm(tmp_path: Path) -> None:
    if not _port_free(DEFAULT_HUB_PORT):
        pytest.skip(f"port {DEFAULT_HUB_PORT} is in use")
    with _cleanup() as procs:
        # GIVEN `auv-hil run` with the packaged configuration (real time, hub on the default port)
        bench = _spawn(procs, [*_hil(), "run"], tmp_path / "bench")
        err_log = tmp_path / "bench.err"
        deadline = time.monotonic() + 20.0
        while "hub listening" not in err_log.read_text(errors="replace"):
            if bench.poll() is not None:
                if "in use" in err_log.read_text(errors="replace"):
                    pytest.skip(f"port {DEFAULT_HUB_PORT} was taken meanwhile")
                pytest.fail(f"bench exited {bench.returncode}\n{_tail(err_log)}")
            assert time.monotonic() < deadline, f"hub did not come up\n{_tail(err_log)}"
            time.sleep(0.1)
        # THEN a client on the default channel hears its status frames
        codec = Codec()
        bus = open_bus(BusConfig(interface="remote", channel=DEFAULT_REMOTE_CHANNEL), timeout_s=5.0)
        port = BusPort(bus, time.monotonic, [codec.frame_id(FinStatus)], codec)
        try:
            heard = None
            until = time.monotonic() + 5.0
            while heard is None and time.monotonic() < until:
                heard = port.recv(0.2)
        finally:
            port.close()
        assert isinstance(heard, FinStatus), f"no FIN_STATUS from the bench\n{_tail(err_log)}"
        # WHEN it gets SIGTERM THEN it stops by itself, cleanly (the bound is how long the test waits for it)
        bench.send_signal(signal.SIGTERM)
        try:
            code = bench.wait(30.0)
        except subprocess.TimeoutExpired:
            pytest.fail(f"bench did not stop within 30 s of SIGTERM\n{_tail(err_log)}")
    stderr = err_log.read_text(errors="replace")
    assert code == 0, stderr
    assert "Traceback" not in stderr
    assert "bench stopped" in stderr
