"""``auv-hil campaign`` and ``auv-hil tune`` (``python -m auv_campaign campaign|tune ...``).

Exit codes: 0 the campaign ran (its missions may have failed: that is its result); 1 a run raised (a bug:
its row's ``error`` says what, the other runs are kept); 2 a bad spec or command line (one line naming the
key, before any run starts); 130 interrupted (Ctrl-C): the finished runs are kept and the same command
resumes.
"""

from __future__ import annotations

import argparse
import csv
import json
import shlex
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from auv_campaign.cli_common import (
    EXIT_INTERRUPTED,
    EXIT_OK,
    EXIT_RUN_ERROR,
    EXIT_USAGE,
    add_executor_args,
    fail,
    usable_out_dir,
)
from auv_common.config import ConfigError


def campaign_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="auv-hil campaign",
        description=(
            "Fly every run of a campaign spec (missions x seeds x currents x sensor profiles x onboard "
            "overrides x vehicle variants): the real onboard core against the real simulator, both in the "
            "worker process of the run, over a virtual bus in lock-step. Writes OUT/runs/RUN_ID.json as "
            "runs finish, then OUT/runs.csv, OUT/summary.json and OUT/report.html. Re-running with the "
            "same --out resumes."
        ),
        epilog=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("spec", help="the campaign spec (YAML)")
    p.add_argument("--out", required=True, help="the output directory (created; resumed if it has runs)")
    add_executor_args(p)
    p.add_argument("--json", action="store_true", help="print the summary as one JSON object")
    p.add_argument("--only", metavar="RUN_ID", help="re-fly this one run here and print its row")
    p.add_argument(
        "--plot",
        action="store_true",
        help="with --only: draw it (OUT/runs/RUN_ID/track.png; errors.png: the paper's e_x, e_y by time)",
    )
    return p


def rerun_command(spec_path: str, out: str) -> Callable[[str], str]:
    """The one command that re-flies a run of this campaign, with its figure."""

    def command(run_id: str) -> str:
        args = ["auv-hil", "campaign", spec_path, "--out", out, "--only", run_id, "--plot"]
        return " ".join(shlex.quote(a) for a in args)

    return command


def campaign_main(argv: list[str]) -> int:
    args = campaign_parser().parse_args(argv)
    prog = "auv-hil campaign"
    from auv_campaign.spec import load_spec

    if args.workers < 1:
        return fail(prog, f"--workers must be >= 1, got {args.workers}")
    try:
        spec = load_spec(args.spec)
    except (ConfigError, OSError) as exc:
        return fail(prog, str(exc))
    out = Path(args.out)
    problem = usable_out_dir(out)
    if problem:
        return fail(prog, problem)
    if args.only:
        return _only(prog, spec, out, args.only, args.plot)
    if args.plot:
        return fail(prog, "--plot needs --only RUN_ID (report.html has the figures of a campaign)")
    return _campaign(prog, spec, out, args)


def _only(prog: str, spec: Any, out: Path, run_id: str, plot: bool) -> int:
    from auv_campaign.execute import save_run
    from auv_campaign.report import save_errors_png, save_track_png
    from auv_campaign.runner import fly
    from hil_sim.bench_program import TRUTH_COLUMNS

    runs = {r.run_id: r for r in spec.runs}
    if run_id not in runs:
        return fail(prog, f"--only {run_id}: no such run in {spec.path} ({len(runs)} runs)")
    run = runs[run_id]
    output = fly(run, keep_truth=True)
    record = output.to_json(run)
    save_run(out, record)
    folder = out / "runs" / run_id
    folder.mkdir(parents=True, exist_ok=True)
    with (folder / "truth.csv").open("w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(TRUTH_COLUMNS)
        writer.writerows(output.truth)
    result = dict(output.row, truth_log=str(folder / "truth.csv"))
    if plot:
        result["figure"] = str(save_track_png(record, folder / "track.png"))
        errors = save_errors_png(output.truth, output.reference, folder / "errors.png", run_id)
        result["errors_figure"] = str(errors)
    print(json.dumps(result))
    return EXIT_RUN_ERROR if output.row.get("error") else EXIT_OK


class _Progress:
    """A rich progress bar: done / total, successes and failures (missions), errors (bugs), ETA."""

    def __init__(self, total: int, title: str, enabled: bool) -> None:
        from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

        self.ok = self.failed = self.errors = 0
        self.progress = Progress(
            TextColumn("[bold]{task.description}"),
            BarColumn(),
            MofNCompleteColumn(),
            TextColumn("[green]{task.fields[ok]} ok [red]{task.fields[failed]} failed {task.fields[errors]}"),
            TimeRemainingColumn(),
            disable=not enabled,
            transient=False,
        )
        self.task = self.progress.add_task(title, total=total, ok=0, failed=0, errors="")

    def __enter__(self) -> _Progress:
        self.progress.__enter__()
        return self

    def __exit__(self, *exc: object) -> None:
        self.progress.__exit__(None, None, None)

    def record(self, record: dict[str, Any]) -> None:
        row = record["row"]
        if row.get("error"):
            self.errors += 1
        elif row.get("success"):
            self.ok += 1
        else:
            self.failed += 1
        errors = f"[bold red]{self.errors} errors" if self.errors else ""
        self.progress.update(self.task, advance=1, ok=self.ok, failed=self.failed, errors=errors)


def _campaign(prog: str, spec: Any, out: Path, args: argparse.Namespace) -> int:
    from auv_campaign.execute import Executor, ExecutorError, execute
    from auv_campaign.report import write_all

    executor = Executor("ray" if args.ray is not None else "local", args.workers, args.ray or None)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.monotonic()
    interrupted = False
    show = not args.no_progress and not args.json
    seen: dict[str, dict[str, Any]] = {}  # every record of this spec, resumed or flown (also on Ctrl-C)

    with _Progress(len(spec.runs), spec.name, show) as bar:

        def on_record(record: dict[str, Any]) -> None:
            seen[record["run_id"]] = record
            bar.record(record)

        try:
            execute(spec.runs, out, executor, on_record=on_record)
        except KeyboardInterrupt:
            interrupted = True
        except ExecutorError as exc:
            return fail(prog, str(exc), EXIT_RUN_ERROR)
    records = [seen[r.run_id] for r in spec.runs if r.run_id in seen]
    summary = write_all(out, records, spec.axes, spec.name, rerun_command(args.spec, str(out)), spec.legend)
    summary["wall_time_s"] = round(time.monotonic() - t0, 2)
    summary["executor"] = executor.describe()
    (out / "summary.json").write_text(json.dumps(summary, indent=2, allow_nan=False))
    if args.json:
        print(json.dumps(summary))
    else:
        rate = summary["success_rate"]
        print(
            f"{spec.name}: {summary['success']} of {summary['runs']} runs succeeded ({100 * rate:.1f} %), "
            f"{summary['false_complete']} false COMPLETE, {summary['time_limit_reached']} at the time limit, "
            f"{summary['errors']} errors, "
            f"{summary['wall_time_s']:.1f} s on {executor.describe()}"
        )
        print(f"report: {out / 'report.html'}")
    if interrupted:
        print(
            f"{prog}: interrupted: {len(records)} of {len(spec.runs)} runs kept; the same command resumes",
            file=sys.stderr,
        )
        return EXIT_INTERRUPTED
    return EXIT_RUN_ERROR if summary["errors"] else EXIT_OK


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] not in ("campaign", "tune"):
        print("usage: python -m auv_campaign {campaign,tune} ...", file=sys.stderr)
        return EXIT_USAGE
    if argv[0] == "campaign":
        return campaign_main(argv[1:])
    from auv_campaign.tune import tune_main

    return tune_main(argv[1:])
