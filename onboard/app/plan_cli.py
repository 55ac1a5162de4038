"""``auv-onboard plan``: plan a homing path from the command line (NED frame, degrees at this edge only).

    auv-onboard plan --start X,Y,YAW_DEG --goal X,Y[,YAW_DEG] --radius R [--obstacle X,Y,R ...]
                     [--weights WD,WPSI,WDR] [--margin M] [--csc-only] [--depth START,GOAL]
                     [--config FILE [--last-goal]] [--sample-step M] [--json] [--plot FILE.png]

``--goal X,Y`` (no yaw) leaves the arrival heading free. ``--config`` reads the ``[planner]`` table of the
onboard TOML file (the one the vehicle flies with); flags given on the command line override it. With
``--last-goal`` the goal is planned as the vehicle plans its mission's last goal: along a straight as long as
the run-in's deceleration (the file's ``[mission]`` and ``[guidance]`` tables,
``onboard.core.plans.last_goal_run_in_m``) where that fits. ``--radius`` is required unless the config
file is given. Negative numbers work in both spellings (``--start -15,5,0`` and ``--start=-15,5,0``). Bad
input: exit code 2 and one line on stderr.

``--json`` prints one object: ``length_m``, ``word``, ``virtual_goals`` ([[x, y], ...]), ``segments``,
``cost``, ``cost_terms``, ``start_depth_m``, ``end_depth_m``, and with ``--sample-step`` the polyline
``samples`` ([[x, y, yaw_deg], ...]) and ``sample_depths_m``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
from typing import Any, NoReturn

from auv_common.cli import join_negative_values
from auv_common.config import ConfigError, from_table, load_toml
from onboard.core.planner.config import PlannerConfig
from onboard.core.planner.cost import cost_terms
from onboard.core.planner.errors import PlannerError
from onboard.core.planner.path import ArcSegment, Path, Segment
from onboard.core.planner.planner import GoalPose, Pose, candidates, inflate
from onboard.core.plans import last_goal_run_in_m, plan_to_goal

PROG = "auv-onboard plan"
_VALUE_OPTIONS = ("--start", "--goal", "--obstacle", "--weights", "--depth", "--radius", "--margin")


class _UsageError(Exception):
    """A command-line error: reported as one line, exit code 2."""


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:
        raise _UsageError(message)


def _parser() -> argparse.ArgumentParser:
    p = _Parser(prog=PROG, description="Plan a homing path (paper section 3) in the NED frame.")
    p.add_argument(
        "--start", required=True, metavar="X,Y,YAW_DEG", help="start pose: north m, east m, yaw deg"
    )
    p.add_argument(
        "--goal", required=True, metavar="X,Y[,YAW_DEG]", help="goal pose; omit yaw for a free heading"
    )
    p.add_argument("--radius", type=float, metavar="R", help="minimum turning radius (m)")
    p.add_argument(
        "--obstacle", action="append", default=[], metavar="X,Y,R", help="obstacle circle (m); repeat"
    )
    p.add_argument("--weights", metavar="WD,WPSI,WDR", help="cost weights of eq. (2)")
    p.add_argument("--margin", type=float, metavar="M", help="obstacle clearance margin (m)")
    p.add_argument("--csc-only", action="store_true", help="only the paper's four tangent words (no CCC)")
    p.add_argument("--depth", metavar="START,GOAL", help="start and goal depth (m, positive down)")
    p.add_argument(
        "--config", metavar="FILE", help="onboard TOML file; its [planner] table sets the defaults"
    )
    p.add_argument(
        "--last-goal",
        action="store_true",
        help="plan the goal as the mission's last: along the run-in's straight (with --config)",
    )
    p.add_argument("--sample-step", type=float, metavar="M", help="also output samples every M metres")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--plot", metavar="FILE.png", help="draw circles, obstacles, candidates and the path")
    return p


def _numbers(text: str, what: str, counts: tuple[int, ...]) -> list[float]:
    try:
        vals = [float(v) for v in text.split(",")]
    except ValueError:
        raise _UsageError(f"{what}: expected comma-separated numbers, got {text!r}") from None
    if len(vals) not in counts:
        want = " or ".join(str(c) for c in counts)
        raise _UsageError(f"{what}: expected {want} numbers, got {text!r}")
    if not all(math.isfinite(v) for v in vals):
        raise _UsageError(f"{what}: numbers must be finite, got {text!r}")
    return vals


def _run_in_m(args: argparse.Namespace) -> float:
    """The last goal's run-in (m) of the ``--config`` file with ``--last-goal`` (0: the planner's own)."""
    if args.config is None or not args.last_goal:
        return 0.0
    from onboard.core.config import CoreConfig  # the tables the vehicle reads, checked as it does

    data = load_toml(args.config)
    tables = {k: v for k, v in data.items() if k in ("planner", "guidance", "mission")}
    try:
        core = from_table(CoreConfig, tables, args.config)
    except ConfigError as exc:
        raise _UsageError(str(exc)) from None
    m = core.mission
    return last_goal_run_in_m(
        core.planner.goal_run_in_m, core.guidance.speed_mps, m.arrival_speed_mps, m.run_in_decel_mps2
    )


def _config(args: argparse.Namespace) -> PlannerConfig:
    if args.config is not None:
        table = load_toml(args.config).get("planner")
        cfg = from_table(PlannerConfig, table, f"{args.config} [planner]")
    elif args.radius is None:
        raise _UsageError("--radius is required (or give --config with a [planner] table)")
    else:
        cfg = PlannerConfig(turning_radius_m=args.radius)
    changes: dict[str, Any] = {}
    if args.radius is not None:
        changes["turning_radius_m"] = args.radius
    if args.margin is not None:
        changes["obstacle_margin_m"] = args.margin
    if args.weights is not None:
        wd, wpsi, wdr = _numbers(args.weights, "--weights", (3,))
        changes.update(weight_distance=wd, weight_yaw=wpsi, weight_rudder=wdr)
    if args.csc_only:
        changes["csc_only"] = True
    return dataclasses.replace(cfg, **changes) if changes else cfg


def _xy(x: float, y: float) -> list[float]:
    return [round(x, 9), round(y, 9)]


def _segment_json(seg: Segment) -> dict[str, Any]:
    x0, y0, yaw0, _ = seg.pose_at(0.0)
    x1, y1, yaw1, _ = seg.pose_at(seg.length_m)
    out: dict[str, Any] = {
        "kind": seg.kind,
        "length_m": seg.length_m,
        "start": _xy(x0, y0),
        "end": _xy(x1, y1),
        "start_yaw_deg": math.degrees(yaw0),
        "end_yaw_deg": math.degrees(yaw1),
    }
    if isinstance(seg, ArcSegment):
        out.update(
            center=_xy(seg.center_x_m, seg.center_y_m),
            radius_m=seg.radius_m,
            turn=seg.turn,
            sweep_deg=math.degrees(seg.sweep_rad),
        )
    return out


def _samples(path: Path, step_m: float) -> list[Any]:
    n = max(1, math.ceil(path.length_m / step_m - 1e-9))
    out = (
        [path.sample(0.0)]
        if path.length_m <= 0.0
        else [path.sample(min(i * step_m, path.length_m)) for i in range(n + 1)]
    )
    return out


def _result_json(path: Path, config: PlannerConfig, step_m: float | None) -> dict[str, Any]:
    terms = cost_terms(path.segments, config)
    doc: dict[str, Any] = {
        "length_m": path.length_m,
        "word": path.word,
        "virtual_goals": [_xy(x, y) for x, y in path.virtual_goals],
        "segments": [_segment_json(s) for s in path.segments],
        "cost": path.cost,
        "cost_terms": {
            "distance_m": terms.distance_m,
            "yaw_change_rad": terms.yaw_change_rad,
            "rudder_rad_m": terms.rudder_rad_m,
        },
        "radius_m": config.turning_radius_m,
        "start_depth_m": path.start_depth_m,
        "end_depth_m": path.end_depth_m,
    }
    if step_m is not None:
        samples = _samples(path, step_m)
        doc["samples"] = [[s.x_m, s.y_m, math.degrees(s.yaw_rad)] for s in samples]
        doc["sample_depths_m"] = [s.depth_m for s in samples]
    return doc


def _text(path: Path) -> str:
    lines = [
        f"word {path.word or '(none: start == goal)'}  length {path.length_m:.3f} m  cost {path.cost:.3f}"
    ]
    lines.append("virtual goals: " + ", ".join(f"({x:.3f}, {y:.3f})" for x, y in path.virtual_goals))
    for seg in path.segments:
        x0, y0, _, _ = seg.pose_at(0.0)
        lines.append(f"  {seg.kind}  {seg.length_m:8.3f} m  from ({x0:.3f}, {y0:.3f})")
    if path.start_depth_m != path.end_depth_m:
        lines.append(f"depth {path.start_depth_m:.2f} m -> {path.end_depth_m:.2f} m")
    return "\n".join(lines)


def _run(argv: list[str]) -> int:
    args = _parser().parse_args(join_negative_values(argv, _VALUE_OPTIONS))
    sx, sy, syaw = _numbers(args.start, "--start", (3,))
    goal_vals = _numbers(args.goal, "--goal", (2, 3))
    start: Pose = (sx, sy, math.radians(syaw))
    goal: GoalPose = (goal_vals[0], goal_vals[1], math.radians(goal_vals[2]) if len(goal_vals) == 3 else None)
    obstacles = [tuple(_numbers(o, "--obstacle", (3,))) for o in args.obstacle]
    obs3 = [(o[0], o[1], o[2]) for o in obstacles]
    d0, d1 = _numbers(args.depth, "--depth", (2,)) if args.depth is not None else (0.0, 0.0)
    if args.sample_step is not None and not (math.isfinite(args.sample_step) and args.sample_step > 0.0):
        raise _UsageError(f"--sample-step must be a positive number of metres, got {args.sample_step!r}")
    config = _config(args)
    run_in_m = _run_in_m(args)
    path = plan_to_goal(start, goal, config, obs3, start_depth_m=d0, goal_depth_m=d1, run_in_m=run_in_m)
    if args.plot is not None:
        from onboard.app.plan_plot import plot_plan

        plot_plan(
            args.plot,
            start,
            goal,
            config,
            path,
            candidates(start, goal, config, obs3),
            obs3,
            inflate(obs3, config),
        )
    if args.json:
        print(json.dumps(_result_json(path, config, args.sample_step)))
    else:
        print(_text(path))
        if args.sample_step is not None:
            for s in _samples(path, args.sample_step):
                print(
                    f"{s.s_m:9.3f} {s.x_m:10.3f} {s.y_m:10.3f} "
                    f"{math.degrees(s.yaw_rad):8.2f} {s.depth_m:7.2f}"
                )
    return 0


def main(argv: list[str] | None = None) -> int:
    """Run ``auv-onboard plan`` with ``argv`` (the arguments after ``plan``); returns the exit code."""
    args = sys.argv[1:] if argv is None else list(argv)
    try:
        return _run(args)
    except (_UsageError, PlannerError, ConfigError, OSError) as exc:
        msg = " ".join(str(exc).split())
        if isinstance(exc, PlannerError) and not isinstance(exc, ConfigError):
            msg = f"{exc.reason}: {msg}"
        print(f"{PROG}: error: {msg}", file=sys.stderr)
        return 2
    except SystemExit as exc:  # --help
        return exc.code if isinstance(exc.code, int) else 0


if __name__ == "__main__":
    sys.exit(main())
