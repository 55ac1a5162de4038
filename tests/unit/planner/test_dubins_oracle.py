"""Dubins words against independent reference tables (tests/data, see its README).

The tables use x right, y up and counter-clockwise headings; read in our NED frame (x north, y east, yaw
from x towards y) the same numbers give the same lengths with the turn letters swapped (L <-> R). Every
lookup below goes through :func:`ned_word` so the swap is explicit.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path as FsPath

import pytest

from onboard.core.planner import PlannerConfig, dubins, plan

DATA = FsPath(__file__).resolve().parents[2] / "data"
WORDS = ("LSL", "LSR", "RSL", "RSR", "RLR", "LRL")


def ned_word(table_word: str) -> str:
    """The NED name of a word from the maths-frame table: L and R swap."""
    return table_word.translate(str.maketrans("LR", "RL"))


def _rows(name: str) -> list[dict[str, str]]:
    with (DATA / name).open(newline="") as f:
        return list(csv.DictReader(f))


def _poses(row: dict[str, str]) -> tuple[tuple[float, float, float], tuple[float, float, float], float]:
    start = (float(row["x0"]), float(row["y0"]), math.radians(float(row["th0_deg"])))
    goal = (float(row["x1"]), float(row["y1"]), math.radians(float(row["th1_deg"])))
    return start, goal, float(row["radius"])


ORACLE = _rows("dubins_oracle_cases.csv")
EDGE = _rows("dubins_edge_cases.csv")


def _end_circles_coincide(
    start: tuple[float, float, float], goal: tuple[float, float, float], r: float, turn: int
) -> bool:
    from onboard.core.planner.geometry import circle_center

    c0 = circle_center(*start, r, turn)
    c1 = circle_center(*goal, r, turn)
    return math.hypot(c1[0] - c0[0], c1[1] - c0[1]) < 1e-9


def test_letter_swap_is_explicit() -> None:
    # GIVEN the maths-frame word "LSR" WHEN read in NED THEN it is "RSL"
    assert ned_word("LSR") == "RSL"
    assert ned_word("RLR") == "LRL"


@pytest.mark.parametrize("row", ORACLE, ids=[f"oracle{i}" for i in range(len(ORACLE))])
def test_every_word_matches_oracle(row: dict[str, str]) -> None:
    start, goal, r = _poses(row)
    for w in WORDS:
        got = dubins.word(start, goal, r, ned_word(w))
        if row[w] == "":
            assert got is None, f"{w} should not exist"
        else:
            assert got is not None, f"{w} should exist"
            assert got.length_m == pytest.approx(float(row[w]), abs=1e-6), w


@pytest.mark.parametrize("row", ORACLE, ids=[f"oracle{i}" for i in range(len(ORACLE))])
def test_shortest_and_csc_only_match_oracle(row: dict[str, str]) -> None:
    start, goal, r = _poses(row)
    full = plan(start, goal, PlannerConfig(turning_radius_m=r))
    assert full.length_m == pytest.approx(float(row["length"]), abs=1e-6)
    assert full.word == ned_word(row["word"])
    csc = plan(start, goal, PlannerConfig(turning_radius_m=r, csc_only=True))
    assert csc.length_m == pytest.approx(float(row["best_csc_length"]), abs=1e-6)
    assert csc.word == ned_word(row["best_csc_word"])


@pytest.mark.parametrize("row", EDGE, ids=[r["name"] for r in EDGE])
def test_edge_case_true_length(row: dict[str, str]) -> None:
    start, goal, r = _poses(row)
    path = plan(start, goal, PlannerConfig(turning_radius_m=r))
    assert path.length_m == pytest.approx(float(row["true_length"]), abs=1e-6)
    allowed = {ned_word(w) for w in row["true_words_at_min"].split("|")}
    assert path.word in allowed
    # ... and it really ends at the goal (no extra loop, no missing turn).
    x, y, yaw = path.end_pose
    assert math.hypot(x - goal[0], y - goal[1]) < 1e-6
    assert abs(math.remainder(yaw - goal[2], 2 * math.pi)) < 1e-9


@pytest.mark.parametrize("row", EDGE, ids=[r["name"] for r in EDGE])
def test_edge_case_every_word(row: dict[str, str]) -> None:
    start, goal, r = _poses(row)
    for w in WORDS:
        got = dubins.word(start, goal, r, ned_word(w))
        if row[w] == "":
            assert got is None, f"{w} should not exist"
            continue
        assert got is not None, f"{w} should exist"
        ned = ned_word(w)
        if ned in dubins.CCC_WORDS and _end_circles_coincide(start, goal, r, 1 if ned[0] == "R" else -1):
            # Both end circles coincide: the CCC family is degenerate and the reference's middle arc (0 or
            # 2*pi) depends on rounding in acos(1). Same path up to whole loops; never the shortest.
            loops = (got.length_m - float(row[w])) / (2 * math.pi * r)
            assert loops == pytest.approx(round(loops), abs=1e-9)
            assert got.length_m >= float(row["true_length"]) - 1e-9
        else:
            assert got.length_m == pytest.approx(float(row[w]), abs=1e-6), w


def test_identical_pose_is_zero_length_not_a_loop() -> None:
    # GIVEN start == goal WHEN planning THEN a zero-length path that samples to the start pose
    path = plan((5.0, 5.0, math.radians(30)), (5.0, 5.0, math.radians(30)), PlannerConfig(turning_radius_m=2))
    assert path.length_m == 0.0
    assert path.segments == ()
    assert path.virtual_goals == ()
    s = path.sample(3.0)
    assert (s.x_m, s.y_m) == (5.0, 5.0)
    assert s.yaw_rad == pytest.approx(math.radians(30))


def test_heading_wrap_359_equals_minus_1() -> None:
    a = plan((0, 0, math.radians(359)), (10, 0, math.radians(-1)), PlannerConfig(turning_radius_m=2))
    assert a.length_m == pytest.approx(10.000003563, abs=1e-6)


def test_paper_example_has_two_virtual_goals() -> None:
    # Paper Fig. 5: P0 = [0, 0, 90 deg] -> Pf = [30, 20, 0 deg]: two virtual goals between start and goal.
    for r in (2.0, 3.0, 5.0):
        path = plan((0.0, 0.0, math.radians(90)), (30.0, 20.0, 0.0), PlannerConfig(turning_radius_m=r))
        assert len(path.virtual_goals) == 2
        assert path.word == "LSL"  # RSR in the table's maths frame
        # The virtual goals are the tangent points: the straight runs between them.
        (ax, ay), (bx, by) = path.virtual_goals
        straight = path.segments[1]
        assert straight.kind == "S"
        assert straight.length_m == pytest.approx(math.hypot(bx - ax, by - ay))
