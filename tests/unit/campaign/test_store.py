"""The store of finished runs: what counts as done on resumption (a complete record of this very run, spec and
fingerprint) and what is flown again."""

from __future__ import annotations

import json
from pathlib import Path

from auv_campaign.execute import fingerprint, finished, run_path, save_run
from auv_campaign.results import COLUMNS
from auv_campaign.spec import parse_spec

SPEC = parse_spec(
    {"name": "t", "missions": [{"name": "m", "start": {"x_m": 0, "y_m": 0, "depth_m": 1, "yaw_deg": 0},
     "goals": [{"x_m": 10, "y_m": 0, "depth_m": 1, "yaw_deg": 0}]}],
     "sweep": {"onboard": [{}, {"control.improved.Kp5": -0.5}]}},
    "t.yaml",
)  # fmt: skip


def _record(spec=SPEC.runs[0]) -> dict:  # type: ignore[no-untyped-def]
    row = {c: None for c in COLUMNS} | spec.identity() | {"error": "", "success": True}
    return {"run_id": spec.run_id, "spec": spec.to_dict(), "row": row, "track": {}, "path": [],
            "fingerprint": fingerprint(spec)}  # fmt: skip


def test_a_complete_record_of_this_run_is_done(tmp_path: Path) -> None:
    save_run(tmp_path, _record())
    assert finished(tmp_path, SPEC.runs[0]) is not None


def test_the_fingerprint_follows_the_effective_onboard_configuration() -> None:
    a, b = SPEC.runs
    assert fingerprint(a) == fingerprint(a) and fingerprint(a) != fingerprint(b)


def test_anything_else_is_flown_again(tmp_path: Path) -> None:
    spec = SPEC.runs[0]
    cases = {
        "another fingerprint (a changed onboard.toml, model or code)": _record() | {"fingerprint": "0" * 16},
        "another spec under this id": _record() | {"spec": {**spec.to_dict(), "seed": 9}},
        "a run that raised": _record() | {"row": _record()["row"] | {"error": "RuntimeError: x"}},
        "a row without its columns": _record() | {"row": {"success": True}},
        "a row of another run": _record() | {"row": _record()["row"] | {"run_id": "other"}},
    }
    for why, record in cases.items():
        save_run(tmp_path, record)
        assert finished(tmp_path, spec) is None, why
    for text in ("[]", "{", ""):
        run_path(tmp_path, spec.run_id).write_text(text)
        assert finished(tmp_path, spec) is None, text
    assert json.loads(json.dumps(_record()))  # the record itself is plain JSON
