"""``auv-hil scenario NAME``: the paper's experiments end to end over real processes, with metrics.

The runner starts the bench (``auv-hil run --mode lockstep``) and the firmware (``auv-onboard run`` in
lock-step) as real processes on a free port of their own, with a temporary state directory (so it never
meets another bench or a persisted mission). The vehicle starts at rest at P0 at 1 m depth and holds 1 m
(the basin), ``basin`` sensor profile; the time limit is twice the nominal duration. Metrics come from the
simulator's truth (the CSV named ``truth_log``) against the planned path, which the runner gets from
``auv-onboard plan --config ... --json --sample-step`` (the same onboard configuration the vehicle flies
with), so ``hil_sim`` still imports only ``onboard.protocol``.

How the mission reaches the vehicle (``--upload``):

- ``gcs`` (default): the firmware runs with its MAVLink endpoint on a free UDP port of 127.0.0.1
  (``udpin``; nothing is sent to 14550 where other ground stations listen) and no start-up mission; the
  runner then runs ``auv-gcs --connect udpout:127.0.0.1:PORT`` (each a process of its own: ``hil_sim``
  never imports ``groundstation``) once each: ``wait-ready`` (the vehicle's HEARTBEAT says BOOT until its
  navigation is valid, then STANDBY), ``upload FILE``, ``arm`` and ``start``. The vehicle answers every
  command with its own verdict and says why it refuses one, so nothing is repeated and no log is read: any
  refusal ends the run with a RuntimeError carrying the vehicle's reason. (``wait-ready`` goes first so
  the upload meets a running control loop.) The ground station's .tlog files stay in the work directory
  (``gcs_tlogs``).
- ``file``: the fallback: ``auv-onboard run --mission FILE --autostart --no-mavlink``.

The plan starts from the navigation pose at START; with ``gcs`` the vehicle has filtered its (still)
sensors for a few dozen ticks longer before START than with ``--autostart``, so the metrics of the two
may differ slightly (for the three scenarios with the default configuration they came out identical).
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from auv_common.cli import join_negative_values
from auv_common.process import stop_process
from hil_sim import figures
from hil_sim.figures import PaperValue
from hil_sim.metrics import compute_metrics, read_truth

DEPTH_M = 1.0
UPLOAD_MODES = ("gcs", "file")
GCS_START_TIMEOUT_S = 60.0  # wall time for wait-ready + upload + arm + start (the firmware starts first)


@dataclass(frozen=True)
class Scenario:
    name: str
    start: tuple[float, float, float]  # x_m, y_m, yaw_deg
    goal: tuple[float, float, float]
    description: str


SCENARIOS = {
    s.name: s
    for s in (
        Scenario("paper-straight", (-13.0, 0.0, 0.0), (15.0, 0.0, 0.0), "straight line (paper Fig. 7, 8)"),
        Scenario("paper-turn", (-15.0, 5.0, 0.0), (10.0, -2.0, 270.0), "added turning motion (Fig. 9, 10)"),
        Scenario("paper-plan", (0.0, 0.0, 90.0), (30.0, 20.0, 0.0), "the planning example (Fig. 5)"),
    )
}


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def mission_yaml(goal: tuple[float, float, float], depth_m: float = DEPTH_M) -> str:
    """One goal as mission YAML: the format both ``auv-gcs upload`` (groundstation/mission_files.py) and
    ``auv-onboard run --mission`` (onboard/mission/file.py) read: x_m, y_m, depth_m and yaw_deg."""
    gx, gy, gyaw = goal
    return f"goals:\n  - {{x_m: {gx}, y_m: {gy}, depth_m: {depth_m}, yaw_deg: {gyaw}}}\n"


def gcs_command(url: str, tlog_dir: str | Path, *args: str, timeout_s: float = 10.0) -> list[str]:
    """An ``auv-gcs`` invocation (a process: ``hil_sim`` does not import ``groundstation``)."""
    return [
        sys.executable,
        "-m",
        "groundstation",
        "--connect",
        url,
        "--json",
        "--tlog-dir",
        str(tlog_dir),
        "--timeout",
        f"{timeout_s:g}",
        *args,
    ]


def run_gcs(
    url: str, tlog_dir: str | Path, *args: str, log: Any = None, timeout_s: float = 10.0
) -> tuple[int, dict[str, Any]]:
    """Run one ``auv-gcs --json`` command; (exit code, its last JSON line or {}). Output goes to ``log``."""
    cmd = gcs_command(url, tlog_dir, *args, timeout_s=timeout_s)
    try:
        out = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout_s + 20.0, check=False)
    except subprocess.TimeoutExpired:
        if log is not None:
            log.write(f"$ auv-gcs {' '.join(args)}: no exit within {timeout_s + 20.0:g} s\n")
        return -1, {}
    if log is not None:
        log.write(f"$ auv-gcs {' '.join(args)} -> exit {out.returncode}\n{out.stdout}{out.stderr}")
        log.flush()
    data: dict[str, Any] = {}
    for line in reversed(out.stdout.strip().splitlines()):
        try:
            data = json.loads(line)
            break
        except ValueError:
            continue
    return out.returncode, data


def _onboard_config_path() -> str:
    """The onboard configuration file the vehicle flies with (found through the installed package)."""
    import importlib.util

    spec = importlib.util.find_spec("onboard")
    if spec is None or spec.origin is None:
        raise RuntimeError("the onboard package is not installed")
    return str(Path(spec.origin).parent / "config" / "onboard.toml")


def planned_path(sc: Scenario, config: str, step_m: float = 0.05) -> dict[str, Any]:
    """The planned path as ``auv-onboard plan --json`` prints it (a subprocess: no onboard import here)."""
    fmt = ",".join
    cmd = [
        sys.executable,
        "-m",
        "onboard",
        "plan",
        "--config",
        config,
        f"--start={fmt(str(v) for v in sc.start)}",
        f"--goal={fmt(str(v) for v in sc.goal)}",
        f"--depth={DEPTH_M},{DEPTH_M}",
        "--last-goal",  # the scenario's one goal is its last: the path the vehicle plans to it
        "--json",
        "--sample-step",
        str(step_m),
    ]
    out = subprocess.run(cmd, capture_output=True, text=True, timeout=60, check=False)
    if out.returncode != 0:
        raise RuntimeError(f"auv-onboard plan failed: {out.stderr.strip()}")
    result: dict[str, Any] = json.loads(out.stdout)
    return result


# --- running ---------------------------------------------------------------------------------------
@dataclass(frozen=True)
class RunOptions:
    controller: str = "improved"
    guidance: str = "track"
    current: tuple[float, float] = (0.0, 0.0)
    seed: int = 0
    workdir: str | None = None
    onboard_sets: tuple[str, ...] = ()
    wall_timeout_s: float = 300.0
    upload: str = "gcs"  # "gcs": auv-gcs over MAVLink; "file": auv-onboard --mission --autostart


def _profile_sets(opts: RunOptions) -> tuple[str, ...]:
    """Onboard overrides: the paper profile flies the paper's guidance too (reference-point errors, a
    reference moving at uniform speed from the first instant to the goal: no slow run-in); then the caller's
    own ``--set`` values."""
    faithful = (
        'guidance.lateral="reference"',
        "guidance.reference_accel_mps2=0.0",
        "mission.arrival_speed_mps=0.0",
    )
    return (faithful if opts.controller == "paper" else ()) + opts.onboard_sets


def upload_and_start(
    url: str,
    mission: Path,
    work: Path,
    hil: subprocess.Popen[Any] | None = None,
    timeout_s: float = GCS_START_TIMEOUT_S,
) -> dict[str, Any]:
    """``auv-gcs wait-ready``, ``upload``, ``arm`` and ``start`` against the vehicle at ``url``, once each.

    Raises RuntimeError with the vehicle's answer (result and reason) on any refusal, and when the bench
    (``hil``) ends meanwhile. Returns the ground station's facts for the metrics.
    """
    tlogs = work / "gcs-tlogs"
    t0 = time.monotonic()
    deadline = t0 + timeout_s
    info: dict[str, Any] = {"gcs_tlogs": str(tlogs), "gcs_start_attempts": 1}
    with open(work / "gcs.log", "a") as log:

        def gcs(*args: str) -> dict[str, Any]:
            if hil is not None and hil.poll() is not None:
                raise RuntimeError(f"the bench ended (exit {hil.returncode}) before auv-gcs {args[0]}")
            left = max(1.0, deadline - time.monotonic())
            extra = ("--timeout", f"{left:g}") if args[0] == "wait-ready" else ()
            code, data = run_gcs(url, tlogs, *args, *extra, log=log, timeout_s=left)
            if code != 0:
                what = data.get("error") or ": ".join(
                    str(x) for x in (data.get("result"), data.get("reason")) if x
                )
                raise RuntimeError(
                    f"auv-gcs {' '.join(args)}: exit {code}: {what or 'no answer'} (see {work}/gcs.log)"
                )
            return data

        gcs("wait-ready")
        data = gcs("upload", str(mission))
        info["gcs_upload_s"] = round(float(data["results"][0]["elapsed_s"]), 4)
        gcs("arm")
        gcs("start")
    info["gcs_wall_s"] = round(time.monotonic() - t0, 3)
    return info


def run_scenario(sc: Scenario, opts: RunOptions) -> dict[str, Any]:
    """Run one scenario over real processes and return the metrics object (see the module docstring)."""
    work = Path(opts.workdir or tempfile.mkdtemp(prefix=f"auv-{sc.name}-"))
    work.mkdir(parents=True, exist_ok=True)
    config = _onboard_config_path()
    path = planned_path(sc, config)
    speed = 1.0  # [guidance] speed_mps of the default onboard configuration
    limit_s = round(2.0 * path["length_m"] / speed + 10.0, 1)
    port = free_port()
    channel = f"ws://127.0.0.1:{port}/"
    truth = work / "truth.csv"
    mission = work / "mission.yaml"
    mission.write_text(mission_yaml(sc.goal))
    if opts.upload not in UPLOAD_MODES:
        raise RuntimeError(f"upload mode {opts.upload!r}: expected one of {', '.join(UPLOAD_MODES)}")
    mav_port = free_udp_port()
    if opts.upload == "gcs":
        # MAVLink on a free port of our own (udpin only: no packets to 14550, where other ground stations
        # listen); the ground station's heartbeat stops between commands, so losing it must not stop us.
        mission_args = [
            "--set",
            f'mavlink.endpoints=["udpin:127.0.0.1:{mav_port}"]',
            "--set",
            'mavlink.gcs_loss_action="continue"',
        ]
    else:
        mission_args = ["--mission", str(mission), "--autostart", "--no-mavlink"]
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    hil_cmd = [
        sys.executable,
        "-m",
        "hil_sim",
        "run",
        "--mode=lockstep",
        f"--channel={channel}",
        f"--start={sc.start[0]},{sc.start[1]},{DEPTH_M},{sc.start[2]}",
        f"--truth-log={truth}",
        "--stop-on=COMPLETE",
        "--stop-on=ABORT",
        "--stop-delay=2",
        f"--duration={limit_s}",
        f"--seed={opts.seed}",
        f"--current={opts.current[0]},{opts.current[1]}",
        "--profile=basin",
        f"--summary-json={work / 'bench.json'}",
    ]
    ob_cmd = [
        sys.executable,
        "-m",
        "onboard",
        "run",
        "--config",
        config,
        "--set",
        "loop.time_source=lockstep",
        "--set",
        f'bus.channel="{channel}"',
        "--set",
        f'control.profile="{opts.controller}"',
        "--set",
        f'guidance.mode="{opts.guidance}"',
        "--set",
        f'loop.telemetry_csv="{work / "telemetry.csv"}"',
        *(x for s in _profile_sets(opts) for x in ("--set", s)),
        "--state-dir",
        str(work / "state"),
        *mission_args,
        "--summary-json",
        str(work / "onboard.json"),
    ]
    hil = onboard = None
    gcs_info: dict[str, Any] = {}
    t0 = time.monotonic()
    with open(work / "hil.log", "w") as hil_log, open(work / "onboard.log", "w") as ob_log:
        try:
            hil = subprocess.Popen(hil_cmd, stdout=hil_log, stderr=subprocess.STDOUT, env=env)
            onboard = subprocess.Popen(ob_cmd, stdout=ob_log, stderr=subprocess.STDOUT, env=env)
            if opts.upload == "gcs":
                url = f"udpout:127.0.0.1:{mav_port}"
                gcs_info = upload_and_start(url, mission, work, hil)
            try:
                hil_code = hil.wait(max(1.0, opts.wall_timeout_s - (time.monotonic() - t0)))
            except subprocess.TimeoutExpired:
                hil_code = -1
        finally:
            stop_process(onboard)
            stop_process(hil)
    wall = time.monotonic() - t0
    bench = json.loads((work / "bench.json").read_text()) if (work / "bench.json").exists() else {}
    if hil_code != 0 or not truth.exists():
        log_tail = (work / "hil.log").read_text()[-800:]
        raise RuntimeError(f"the bench failed (exit {hil_code}); see {work}/hil.log:\n{log_tail}")
    onboard_summary = (
        json.loads((work / "onboard.json").read_text()) if (work / "onboard.json").exists() else {}
    )
    metrics = compute_metrics(read_truth(truth), path["samples"], sc.goal, DEPTH_M)
    metrics.pop("arrival_row")
    sim_time = float(bench.get("sim_time_s", 0.0))
    run_wall = float(bench.get("run_wall_time_s", 0.0)) or wall
    return {
        "scenario": sc.name,
        "controller": opts.controller,
        "guidance": opts.guidance,
        "current_mps_deg": list(opts.current),
        "seed": opts.seed,
        "upload": opts.upload,
        **metrics,
        "sim_time_s": sim_time,
        "time_limit_s": limit_s,
        "wall_time_s": round(wall, 3),
        "realtime_factor": sim_time / run_wall if run_wall > 0 else math.nan,
        "ticks": int(onboard_summary.get("ticks", bench.get("ticks", 0))),
        "overruns": int(onboard_summary.get("overruns", 0)),
        "frames_rejected": sum(onboard_summary.get("frames_rejected", {}).values())
        + sum(bench.get("rejected", {}).values()),
        "final_state": onboard_summary.get("final_state", bench.get("onboard_state", "")),
        "path_word": path["word"],
        "path_length_m": path["length_m"],
        "truth_log": str(truth),
        "telemetry_log": str(work / "telemetry.csv"),
        **gcs_info,
        "planned_path": path["samples"],
    }


# --- figures ---------------------------------------------------------------------------------------
def plot_scenario(result: dict[str, Any], out_dir: str | Path, paper: Sequence[PaperValue] = ()) -> list[str]:
    """The paper's figures of a :func:`run_scenario` result (:mod:`hil_sim.figures`): the path against the
    planned path (Fig. 7 / 9) and e_x, e_y in the path frame against time (Fig. 8 / 10), the paper's
    reported values (``paper``) marked. Writes ``NAME-CONTROLLER-GUIDANCE-path.png`` and ``...-error.png``
    in ``out_dir``; returns their file names."""
    out = Path(out_dir)
    truth = read_truth(result["truth_log"])
    samples = result["planned_path"]
    t_goal = float(result["arrival_time_s"]) if result.get("completed") else None
    errors = figures.path_frame_errors(
        [r["t_s"] for r in truth],
        [r["x_m"] for r in truth],
        [r["y_m"] for r in truth],
        samples,
        *_logged_reference(Path(result["telemetry_log"])),
        t_goal_s=t_goal,
    )
    name = result["scenario"]
    tag = f"{name}-{result['controller']}-{result['guidance']}"
    how = f"{result['controller']} controller, {result['guidance']} guidance"
    path_fig = figures.path_figure(samples, errors, f"{name}: path against the planned path ({how})")
    error_fig = figures.error_figure(
        samples, errors, paper, f"{name}: errors in the path frame against time ({how}); e = desired - actual"
    )
    return [
        figures.save_png(path_fig, out / f"{tag}-path.png"),
        figures.save_png(error_fig, out / f"{tag}-error.png"),
    ]


def _logged_reference(telemetry: Path) -> tuple[list[float], list[float], list[float]]:
    """(t_s, ref_x_m, ref_y_m) of the onboard's telemetry CSV (empty when there is none; rows without a
    reference are left to :func:`hil_sim.figures.path_frame_errors` to drop)."""
    if not telemetry.exists():
        return [], [], []
    t, x, y = [], [], []
    with telemetry.open(newline="") as f:
        for row in csv.DictReader(f):
            try:
                t.append(float(row["t_s"]))
                x.append(float(row["ref_x_m"]))
                y.append(float(row["ref_y_m"]))
            except (KeyError, TypeError, ValueError):
                continue
    return t, x, y


def print_result(result: dict[str, Any]) -> None:
    from rich.console import Console
    from rich.table import Table

    table = Table(title=f"{result['scenario']} ({result['controller']}, {result['guidance']})")
    table.add_column("metric")
    table.add_column("value", justify="right")
    for key, value in result.items():
        if key in ("planned_path",):
            continue
        table.add_row(key, f"{value:.4g}" if isinstance(value, float) else str(value))
    Console().print(table)


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(
        prog="auv-hil scenario",
        description=(
            "Run one of the paper's scenarios end to end: the bench and auv-onboard as real processes over "
            "the bench bus in lock-step, on a free port and a temporary state directory; metrics from the "
            "simulator's truth against the planned path."
        ),
    )
    parser.add_argument("name", choices=sorted(SCENARIOS))
    parser.add_argument("--controller", choices=["paper", "improved"], default="improved")
    parser.add_argument("--guidance", choices=["track", "los", "ilos"], default="track")
    parser.add_argument("--current", help="SPEED_MPS,DIR_DEG: the direction the water flows towards (NED)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument("--plot", metavar="DIR", help="write the paper's figures (PNG) here")
    parser.add_argument("--workdir", help="keep logs here (default: a new temporary directory)")
    parser.add_argument(
        "--upload",
        choices=UPLOAD_MODES,
        default="gcs",
        help="gcs: upload, arm and start through auv-gcs over MAVLink (default); "
        "file: auv-onboard --mission FILE --autostart without MAVLink",
    )
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="TABLE.KEY=VALUE",
        help="passed to auv-onboard run --set (an onboard configuration override)",
    )
    args = parser.parse_args(join_negative_values(argv, ("--current",)))
    current = (0.0, 0.0)
    if args.current:
        try:
            speed, direction = (float(v) for v in args.current.split(","))
        except ValueError:
            print(
                f"auv-hil scenario: --current: expected SPEED_MPS,DIR_DEG, got {args.current!r}",
                file=sys.stderr,
            )
            return 2
        current = (speed, direction)
    opts = RunOptions(
        args.controller, args.guidance, current, args.seed, args.workdir, tuple(args.set), upload=args.upload
    )
    try:
        result = run_scenario(SCENARIOS[args.name], opts)
    except RuntimeError as exc:
        print(f"auv-hil scenario: {exc}", file=sys.stderr)
        return 1
    if args.plot:
        result["figures"] = plot_scenario(result, args.plot)
    if args.json:
        print(json.dumps({k: v for k, v in result.items() if k != "planned_path"}))
    else:
        print_result(result)
    return 0
