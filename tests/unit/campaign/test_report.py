"""Unit tests of the campaign products: runs.csv, summary.json and report.html, on hand-built runs."""

from __future__ import annotations

import csv
import html
import json
import logging
import math
import re
from pathlib import Path
from typing import Any

import pytest

from auv_campaign import report
from auv_campaign.results import COLUMNS, severity

AXES: dict[str, list[str]] = {
    "mission": ["m0", "r0"],
    "seed": ["s0", "s1"],
    "current": ["c0d0", "c0.3d90"],
    "profile": ["basin"],
    "onboard": ["default"],
    "vehicle": ["nominal"],
}
RERUN_PREFIX = "auv-hil campaign --rerun"


def rerun(run_id: str) -> str:
    return f"{RERUN_PREFIX} {run_id}"


def make_run(
    mission: str,
    seed: int,
    speed: float,
    direction: float,
    *,
    path: list[list[float]] | None = None,
    track: bool = True,
    **row: Any,
) -> dict[str, Any]:
    """A run record as the campaign writes it; ``row`` overrides the defaults of a clean success."""
    run_id = f"{mission}_s{seed}_c{speed:g}d{direction:g}_basin_default_nominal_{row.pop('tag', '')}"
    values: dict[str, Any] = dict.fromkeys(COLUMNS)
    values.update(
        run_id=run_id,
        mission=mission,
        seed=seed,
        current_speed_mps=speed,
        current_dir_deg=direction,
        profile="basin",
        onboard="default",
        vehicle="nominal",
        planned=True,
        completed=True,
        success=True,
        false_complete=False,
        final_position_error_m=0.5,
        final_course_error_deg=2.0,
        final_heading_error_deg=5.0,
        final_depth_error_m=0.1,
        max_cross_track_m=1.0,
        rms_cross_track_m=0.4,
        min_clearance_m=None,
        time_to_goal_s=60.0,
        control_effort_rad=0.05,
        final_state="COMPLETE",
        final_reason="goal reached",
        time_limit_s=200.0,
        sim_time_s=61.0,
        ticks=1220,
        wall_time_s=1.5,
        error="",
    )
    values.update(row)
    n = 3000  # more than the report draws: it must decimate
    xs = [30.0 * i / (n - 1) for i in range(n)]
    spec = {
        "run_id": run_id,
        "mission": {
            "name": mission,
            "start": [0.0, 0.0, 2.0, 0.0],
            "goals": [[15.0, 5.0, 2.0, None], [30.0, 0.0, 2.0, 90.0]],
            "obstacles": [[15.0, -5.0, 2.0]],
        },
        "seed": seed,
        "current_speed_mps": speed,
        "current_dir_deg": direction,
        "profile": "basin",
    }
    return {
        "run_id": run_id,
        "spec": spec,
        "row": values,
        "track": {
            "t_s": [0.1 * i for i in range(n)] if track else [],
            "x_m": xs if track else [],
            "y_m": [0.0] * n if track else [],  # a straight line north: the plot must not collapse
            "depth_m": [2.0] * n if track else [],
        },
        "path": [[0.0, 0.0], [30.0, 0.0]] if path is None else path,
    }


@pytest.fixture
def runs() -> list[dict[str, Any]]:
    """A success, a miss, a false complete, a not-planned run (path []) and an error run."""
    return [
        make_run("m0", 0, 0.0, 0.0, tag="ok"),
        make_run(
            "m0",
            1,
            0.3,
            90.0,
            tag="miss",
            completed=False,
            success=False,
            final_position_error_m=12.5,
            final_course_error_deg=40.0,
            max_cross_track_m=8.0,
            rms_cross_track_m=3.0,
            time_to_goal_s=None,
            final_state="ABORTED",
            final_reason="time limit <b>late</b>",
        ),
        make_run(
            "m0",
            0,
            0.3,
            90.0,
            tag="false",
            success=False,
            false_complete=True,
            final_position_error_m=3.0,
            min_clearance_m=1.5,
        ),
        make_run(
            "r0",
            0,
            0.0,
            0.0,
            tag="noplan",
            path=[],
            track=False,
            planned=False,
            completed=False,
            success=False,
            final_position_error_m=None,
            final_course_error_deg=None,
            final_heading_error_deg=None,
            final_depth_error_m=None,
            max_cross_track_m=None,
            rms_cross_track_m=None,
            time_to_goal_s=None,
            control_effort_rad=None,
            final_state="IDLE",
            final_reason="rejected: <b>bad</b> goal",
        ),
        make_run(
            "r0",
            1,
            0.3,
            90.0,
            tag="err",
            completed=False,
            success=False,
            final_position_error_m=None,
            final_course_error_deg=float("nan"),
            time_to_goal_s=None,
            final_state=None,
            final_reason=None,
            error="RuntimeError('boom')",
        ),
    ]


def rows_of(runs: list[dict[str, Any]]) -> list[dict[str, Any]]:
    return [run["row"] for run in runs]


def test_csv_header_rows_and_cells(tmp_path: Path, runs: list[dict[str, Any]]) -> None:
    path = tmp_path / "runs.csv"
    report.write_csv(rows_of(runs), path)
    with path.open(newline="") as f:
        table = list(csv.reader(f))
    assert tuple(table[0]) == COLUMNS
    assert len(table) == 1 + len(runs)
    col = {name: i for i, name in enumerate(COLUMNS)}
    ok, miss, _, noplan, err = table[1:]
    assert ok[col["success"]] == "true" and miss[col["success"]] == "false"
    assert ok[col["min_clearance_m"]] == ""  # None
    assert noplan[col["final_position_error_m"]] == ""
    assert err[col["final_course_error_deg"]] == ""  # NaN
    assert ok[col["seed"]] == "0" and ok[col["ticks"]] == "1220"
    assert miss[col["final_position_error_m"]] == "12.5"
    assert miss[col["final_reason"]] == "time limit <b>late</b>"  # CSV keeps the raw text


def test_csv_float_format(tmp_path: Path) -> None:
    path = tmp_path / "runs.csv"
    report.write_csv([{"run_id": "a", "wall_time_s": 1.0 / 3.0, "sim_time_s": 2.0}], path)
    line = path.read_text().splitlines()[1].split(",")
    assert line[COLUMNS.index("wall_time_s")] == "0.333333"
    assert line[COLUMNS.index("sim_time_s")] == "2"


def test_axis_labels() -> None:
    row = {"mission": "m0", "seed": 3, "current_speed_mps": 0.3, "current_dir_deg": 90.0, "profile": "sea"}
    assert report.axis_label(row, "current") == "c0.3d90"
    assert report.axis_label({"current_speed_mps": 0.0, "current_dir_deg": 0.0}, "current") == "c0d0"
    assert report.axis_label(row, "seed") == "s3"
    assert report.axis_label(row, "mission") == "m0"
    assert report.axis_label(row, "profile") == "sea"


def test_summary_counts_and_per_axis(runs: list[dict[str, Any]]) -> None:
    s = report.summarize(rows_of(runs), AXES, "unit", rerun_command=rerun)
    assert s["name"] == "unit"
    assert (s["runs"], s["errors"], s["planned"], s["completed"]) == (5, 1, 4, 2)
    assert (s["success"], s["false_complete"]) == (1, 1)
    assert s["success_rate"] == pytest.approx(0.2)
    assert list(s["per_axis"]) == list(AXES)
    mission = s["per_axis"]["mission"]
    assert list(mission) == ["m0", "r0"]
    assert mission["m0"]["runs"] == 3 and mission["m0"]["success"] == 1
    assert mission["m0"]["success_rate"] == pytest.approx(1 / 3)
    assert mission["m0"]["false_complete"] == 1
    assert mission["m0"]["median_final_position_error_m"] == pytest.approx(3.0)  # of 0.5, 12.5, 3.0
    assert mission["m0"]["median_max_cross_track_m"] == pytest.approx(1.0)  # of 1, 8, 1
    assert mission["r0"] == {
        "runs": 2,
        "success": 0,
        "success_rate": 0.0,
        "false_complete": 0,
        "median_final_position_error_m": None,
        "median_max_cross_track_m": 1.0,  # the error run's; the not-planned one has none
    }
    current = s["per_axis"]["current"]
    assert (current["c0d0"]["runs"], current["c0.3d90"]["runs"]) == (2, 3)
    assert current["c0d0"]["success_rate"] == pytest.approx(0.5)
    assert s["per_axis"]["seed"]["s0"]["runs"] == 3 and s["per_axis"]["seed"]["s1"]["runs"] == 2
    assert s["per_axis"]["profile"] == {
        "basin": {
            "runs": 5,
            "success": 1,
            "success_rate": 0.2,
            "false_complete": 1,
            "median_final_position_error_m": 3.0,
            "median_max_cross_track_m": 1.0,
        }
    }


def test_summary_keeps_unlisted_labels_and_empty_ones(runs: list[dict[str, Any]]) -> None:
    s = report.summarize(rows_of(runs), {"mission": ["x9", "m0"]}, "unit")
    assert list(s["per_axis"]["mission"]) == ["x9", "m0", "r0"]
    assert s["per_axis"]["mission"]["x9"]["runs"] == 0
    assert s["per_axis"]["mission"]["x9"]["success_rate"] == 0.0


def test_summary_metrics(runs: list[dict[str, Any]]) -> None:
    m = report.summarize(rows_of(runs), AXES, "unit")["metrics"]
    assert set(m) == set(report.METRIC_COLUMNS)
    assert m["final_position_error_m"]["median"] == pytest.approx(3.0)
    assert m["final_position_error_m"]["max"] == pytest.approx(12.5)
    assert m["final_position_error_m"]["p90"] == pytest.approx(10.6)  # linear between 3.0 and 12.5
    assert m["final_course_error_deg"]["max"] == pytest.approx(40.0)  # the NaN is left out
    assert m["min_clearance_m"] == {"median": 1.5, "p90": 1.5, "max": 1.5}
    assert m["time_to_goal_s"]["median"] == pytest.approx(60.0)
    empty = report.summarize([], AXES, "empty")
    assert empty["runs"] == 0 and empty["success_rate"] == 0.0 and empty["worst"] == []
    assert empty["metrics"]["max_cross_track_m"] == {"median": None, "p90": None, "max": None}


def test_worst_ordered_by_cost_at_most_ten(runs: list[dict[str, Any]]) -> None:
    extra = [make_run("m0", 0, 0.0, 0.0, tag=f"x{i}", final_position_error_m=0.1 * i) for i in range(10)]
    rows = rows_of(runs + extra)
    worst = report.summarize(rows, AXES, "unit", rerun_command=rerun)["worst"]
    assert len(worst) == report.WORST_COUNT
    costs = [w["cost"] for w in worst]
    assert costs == sorted(costs, reverse=True)
    # Ranked by the uncapped severity (issue 23: the capped cost tied a 55 m miss with a 14 m one).
    assert costs[0] == pytest.approx(max(severity(r) for r in rows))
    ranked = sorted(rows, key=lambda r: (-severity(r), r["run_id"]))[: report.WORST_COUNT]
    assert [w["run_id"] for w in worst] == [r["run_id"] for r in ranked]
    assert worst[0]["rerun"] == rerun(worst[0]["run_id"])
    assert set(worst[0]) == {
        "run_id",
        "cost",
        "success",
        "final_state",
        "final_reason",
        "final_position_error_m",
        "rerun",
    }
    # Without a rerun command the entry is there but empty.
    assert report.summarize(rows, AXES, "unit")["worst"][0]["rerun"] is None


def test_summary_is_strict_json(runs: list[dict[str, Any]]) -> None:
    rows = rows_of(runs)
    rows[0] = {**rows[0], "final_position_error_m": float("nan"), "rms_cross_track_m": float("inf")}
    s = report.summarize(rows, AXES, "unit", rerun_command=rerun)
    text = json.dumps(s, allow_nan=False)
    assert json.loads(text) == s


def _tables(page: str) -> str:
    return " ".join(re.findall(r"<table>.*?</table>", page, flags=re.DOTALL))


def test_report_html(tmp_path: Path, runs: list[dict[str, Any]]) -> None:
    summary = report.write_all(tmp_path, runs, AXES, "unit <campaign>", rerun)
    assert (tmp_path / "runs.csv").is_file()
    assert json.loads((tmp_path / "summary.json").read_text()) == summary
    page = (tmp_path / "report.html").read_text()

    for run in runs:  # five runs: all are among the ten worst
        assert html.escape(rerun(run["run_id"])) in page
    assert f"<code>{html.escape(rerun(runs[1]['run_id']))}</code>" in page
    assert "&lt;b&gt;bad&lt;/b&gt;" in page and "&lt;b&gt;late&lt;/b&gt;" in page
    assert "<b>" not in page
    assert "unit &lt;campaign&gt;" in page

    multi_valued = sum(1 for labels in summary["per_axis"].values() if len(labels) > 1)
    assert multi_valued == 3  # mission, seed, current
    expected = multi_valued + len(report.HISTOGRAMS) + len(summary["worst"])
    assert page.count("<img ") == expected
    assert page.count('src="data:image/png;base64,') == expected
    assert "http://" not in page and "https://" not in page and "<script" not in page

    tables = _tables(page)
    assert tables
    assert not re.search(r"\bnan\b", tables, flags=re.IGNORECASE)
    for axis in AXES:  # every axis is in the table, with one value or more
        assert f"<td>{axis}</td>" in tables
    assert len(page) < 2_000_000


def test_report_of_no_runs(tmp_path: Path) -> None:
    summary = report.write_all(tmp_path, [], AXES, "empty", rerun)
    assert summary["runs"] == 0
    page = (tmp_path / "report.html").read_text()
    bars = sum(1 for labels in AXES.values() if len(labels) > 1)
    assert page.count("<img ") == bars + len(report.HISTOGRAMS)
    assert (tmp_path / "runs.csv").read_text().splitlines() == [",".join(COLUMNS)]


def test_report_of_a_run_not_loaded(tmp_path: Path, runs: list[dict[str, Any]]) -> None:
    summary = report.summarize(rows_of(runs), AXES, "unit", rerun_command=rerun)
    path = report.write_report(tmp_path, runs[:1], summary, rerun)  # the summary names five runs
    page = path.read_text()
    assert page.count("<img ") == 3 + len(report.HISTOGRAMS) + len(runs)
    assert html.escape(rerun(runs[4]["run_id"])) in page


def test_histogram_of_a_wide_span_and_of_zeros() -> None:
    wide = report._histogram_img([0.0, 0.01, 0.1, 1.0, 10.0, 100.0], "wide", "m")
    same = report._histogram_img([2.0, 2.0, 2.0], "same", "m")
    negative = report._histogram_img([-1.0, 0.0, 50.0], "signed", "m")
    for img in (wide, same, negative):
        assert img.startswith("<img ") and "base64," in img


def test_plot_limits_have_a_minimum_span() -> None:
    (e_lo, e_hi), (n_lo, n_hi) = report.plot_limits([0.0, 0.0, 0.0], [0.0, 0.1, 0.2])
    assert e_hi - e_lo == pytest.approx(2.0) and n_hi - n_lo == pytest.approx(2.0)
    assert (e_lo + e_hi) / 2 == pytest.approx(0.0) and (n_lo + n_hi) / 2 == pytest.approx(0.1)
    (e_lo, e_hi), (n_lo, n_hi) = report.plot_limits([0.0, 0.0, math.nan], [0.0, 30.0, 5.0])
    assert e_hi - e_lo == pytest.approx(n_hi - n_lo) == pytest.approx(33.0)
    assert report.plot_limits([], []) == ((-1.0, 1.0), (-1.0, 1.0))


def test_decimate_keeps_the_ends() -> None:
    values = [float(i) for i in range(5001)]
    kept = report.decimate(values, 2000)
    assert len(kept) <= 2000 and kept[0] == 0.0 and kept[-1] == 5000.0
    assert report.decimate(values[:10], 2000) == values[:10]
    odd = report.decimate([float(i) for i in range(4002)], 2000)
    assert len(odd) <= 2000 and odd[-1] == 4001.0


def test_load_runs_sorted_and_skips_corrupt(
    tmp_path: Path, runs: list[dict[str, Any]], caplog: pytest.LogCaptureFixture
) -> None:
    folder = tmp_path / "runs"
    folder.mkdir()
    for name, run in (("zz.json", runs[0]), ("aa.json", runs[3]), ("mm.json", runs[1])):
        (folder / name).write_text(json.dumps(run))
    (folder / "broken.json").write_text('{"run_id": "x", "row": {')  # truncated
    (folder / "list.json").write_text("[1, 2]")  # JSON, but not a run
    (folder / "notes.txt").write_text("not a run")
    with caplog.at_level(logging.WARNING, logger="auv_campaign.report"):
        loaded = report.load_runs(tmp_path)
    assert [r["run_id"] for r in loaded] == sorted(r["run_id"] for r in (runs[0], runs[1], runs[3]))
    by_id = {r["run_id"]: r for r in loaded}
    assert by_id[runs[1]["run_id"]]["row"]["final_reason"] == "time limit <b>late</b>"
    assert "skipped 2" in caplog.text and "broken.json" in caplog.text
    assert report.load_runs(tmp_path / "nowhere") == []


def test_report_says_what_the_labels_stand_for(tmp_path: Path, runs: list[dict[str, Any]]) -> None:
    legend = {"vehicle": {"nominal": "packaged isimi100.toml", "v1": "scale fin_lift=0.7 <weak fins>"}}
    summary = report.write_all(tmp_path, runs, AXES, "legend", rerun, legend)
    assert summary["legend"] == legend
    assert json.loads((tmp_path / "summary.json").read_text())["legend"] == legend
    page = (tmp_path / "report.html").read_text()
    assert "What the labels stand for" in page
    assert "scale fin_lift=0.7 &lt;weak fins&gt;" in page


def test_paper_errors_are_reference_minus_truth_in_the_path_frame() -> None:
    # GIVEN truth rows (t, x, y) and the reference heading east (yaw 90 deg), 1 m ahead, 0.5 m north of it
    truth = [[0.0, 0.0, 0.0], [0.1, 0.0, 0.1], [0.2, 0.0, 0.2]]
    east = math.pi / 2
    reference = [(0.1, 0.5, 1.1, east), (0.2, 0.5, 1.2, east)]
    t_s, e_x, e_y = report.paper_errors(truth, reference)
    # THEN e_x = 1 m along, e_y = -0.5 m (the reference to port of a vehicle heading east)
    assert t_s == [0.1, 0.2]
    assert e_x == pytest.approx([1.0, 1.0]) and e_y == pytest.approx([-0.5, -0.5])
    assert report.paper_errors([], reference) == ([], [], [])
