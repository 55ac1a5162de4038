"""Faults in campaign specs (issue 24 item 4): ``sweep.faults`` is a list per run, parsed by the bench's own
parser (hil_sim/model/faults.py), an axis of its own with run ids and a ``faults`` column that name it."""

from __future__ import annotations

from typing import Any

import pytest

from auv_campaign.results import ID_COLUMNS
from auv_campaign.spec import AXES, RunSpec, SpecError, parse_spec
from hil_sim.model import faults as fm
from tests.unit.sim.test_faults import ISSUE_LIST

STRAIGHT = {
    "name": "straight",
    "start": {"x_m": -13, "y_m": 0, "depth_m": 1, "yaw_deg": 0},
    "goals": [{"x_m": 15, "y_m": 0, "depth_m": 1, "yaw_deg": 0}],
}


def _spec(sweep: dict[str, Any]) -> Any:
    return parse_spec({"name": "f", "missions": [STRAIGHT], "sweep": sweep}, "spec.yaml")


def test_the_issue_list_is_an_axis_whose_run_ids_and_column_name_the_fault() -> None:
    # GIVEN the issue's faults list over two seeds
    spec = _spec({"seed": [0, 1], "faults": ISSUE_LIST})
    # THEN one run per seed and entry, faults innermost, ids ending in the kinds
    assert len(spec.runs) == 2 * 7
    assert [r.run_id for r in spec.runs[:7]] == [
        f"straight_s0_c0d0_basin_default_nominal_{kind}"
        for kind in (
            "none",
            "dvl_dropout",
            "fix_outage",
            "compass_bias",
            "depth_stuck",
            "fin_stuck",
            "thrust_loss",
        )
    ]
    assert list(spec.axes) == [*AXES, "faults"]
    assert spec.axes["faults"][:2] == ["none", "dvl_dropout(start_s=10, duration_s=20)"]
    run = spec.runs[5]
    assert run.faults == (fm.FinStuck(12.0, fin="rudder", angle_deg=6.0),)
    assert run.identity()["faults"] == "fin_stuck(start_s=12, fin=rudder, angle_deg=6)"
    assert tuple(run.identity()) == ID_COLUMNS
    assert run.axis_labels()["faults"] in spec.axes["faults"]
    # AND the run survives the JSON round trip the executors use
    assert RunSpec.from_dict(run.to_dict()) == run


def test_a_spec_without_faults_keeps_its_runs_and_ids() -> None:
    spec = _spec({"seed": [0]})
    assert [r.run_id for r in spec.runs] == ["straight_s0_c0d0_basin_default_nominal"]
    assert list(spec.axes) == list(AXES) and spec.runs[0].faults == ()
    assert spec.runs[0].identity()["faults"] == "" and "faults" not in spec.runs[0].to_dict()


def test_entries_sharing_kinds_get_their_index() -> None:
    spec = _spec(
        {"faults": [[{"kind": "depth_stuck", "start_s": 1}], [{"kind": "depth_stuck", "start_s": 2}], []]}
    )
    assert [r.run_id.rsplit("_nominal_", 1)[1] for r in spec.runs] == [
        "depth_stuck-0",
        "depth_stuck-1",
        "none",
    ]


@pytest.mark.parametrize(
    ("faults", "message"),
    [
        ([[{"kind": "dvl_dropout", "start_s": -1}]], r"sweep.faults\[0\]\[0\].start_s: must be >= 0"),
        ([[], [{"kind": "fin_stuck", "start_s": 1, "fin": "rudder", "angle_deg": 6, "rate": 1}]],
         r"sweep.faults\[1\]\[0\].rate: unknown key for fin_stuck \(known: kind, start_s, duration_s, fin, "),
        ([[{"kind": "leak", "start_s": 1}]], r"sweep.faults\[0\]\[0\].kind: must be one of dvl_dropout"),
        ([{"kind": "dvl_dropout", "start_s": 1}], r"sweep.faults\[0\]: expected a list of faults"),
        ([[], []], r"sweep.faults\[1\]: same as sweep.faults\[0\]"),
        ([], r"sweep.faults: must not be empty"),
    ],
)  # fmt: skip
def test_a_bad_fault_is_refused_naming_its_key(faults: Any, message: str) -> None:
    with pytest.raises(SpecError, match=r"^spec.yaml: " + message):
        _spec({"faults": faults})
