"""``auv-hil tune``'s pieces without flying: --params parsing, ranges, the onboard keys, the override merge,
scores, the trial loop on a toy objective (baseline first, resumption, Ctrl-C), and the files it writes."""

from __future__ import annotations

import csv
import json
import math
import tomllib
from pathlib import Path
from typing import Any

import optuna
import pytest

from auv_campaign import tune
from auv_campaign.spec import parse_spec
from auv_campaign.tune import Param, ParamError, Score
from onboard.app.runtime import build_config

optuna.logging.set_verbosity(optuna.logging.WARNING)

SPEC = {
    "name": "t",
    "missions": [{"name": "line", "start": {"x_m": -13, "y_m": 0, "depth_m": 1, "yaw_deg": 0},
                  "goals": [{"x_m": 2, "y_m": 0, "depth_m": 1, "yaw_deg": 0}]}],
    "sweep": {"seed": [0, 1], "onboard": [{}, {"control.improved.Kp5": -0.3, "guidance.lookahead_m": 2.5}]},
}  # fmt: skip
KP5 = Param("control.improved.Kp5", -0.9, -0.3, -0.6)
KD5 = Param("control.improved.KD5", -0.45, -0.15, -0.3)


@pytest.fixture(scope="module")
def config() -> Any:
    return build_config(None, [])


def accept_all(sets: Any) -> str | None:
    return None


# --- --params ------------------------------------------------------------------------------------------
def test_parse_params_reads_keys_and_ranges_in_order() -> None:
    assert tune.parse_params("control.improved.Kp5") == [("control.improved.Kp5", None)]
    assert tune.parse_params(" a.b , c.d=-0.9:-0.3,e.f=1.0e-3:2e-3") == [
        ("a.b", None),
        ("c.d", (-0.9, -0.3)),
        ("e.f", (1e-3, 2e-3)),
    ]


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("a.b,", "empty entry"),
        ("a.b=1", "LO:HI"),
        ("a.b=x:1", "two numbers"),
        ("a.b=1:", "two numbers"),
        ("a.b=2:1", "LO < HI"),
        ("a.b=1:1", "LO < HI"),
        ("a.b=-inf:1", "finite"),
        ("a.b,a.b=1:2", "twice"),
        ("=1:2", "KEY"),
    ],
)
def test_parse_params_refuses_with_one_line(text: str, words: str) -> None:
    with pytest.raises(ParamError, match=words) as info:
        tune.parse_params(text)
    assert "\n" not in str(info.value)


def test_default_range_keeps_the_sign_and_opens_zero() -> None:
    assert tune.default_range(-0.6) == (-0.9, -0.3)
    assert tune.default_range(2.0) == (1.0, 3.0)
    assert tune.default_range(0.0) == (-tune.ZERO_SCALE, tune.ZERO_SCALE)
    assert tune.default_range(0.0, zero_scale=2.0) == (-2.0, 2.0)
    lo, hi = tune.default_range(0.68)
    assert lo < 0.68 < hi and (lo, hi) == (0.34, 1.02)


def test_round_sig() -> None:
    assert tune.round_sig(-0.573519283) == -0.5735
    assert tune.round_sig(12345.678) == 12350.0
    assert tune.round_sig(0.0) == 0.0
    assert tune.round_sig(1.23456e-7, 3) == 1.23e-7


# --- onboard keys ---------------------------------------------------------------------------------------
def test_config_value_reads_the_file_and_the_defaults(config: Any) -> None:
    assert tune.config_value(config, "control.improved.Kp5") == -0.6  # onboard.toml
    assert tune.config_value(config, "control.improved.KD5") == -0.3  # the dataclass default
    assert tune.config_value(config, "guidance.lookahead_m") == 2.0


@pytest.mark.parametrize(
    ("key", "words"),
    [
        (
            "control.improved.Kd5",
            "no key Kd5 in \\[control.improved\\] of onboard.toml \\(did you mean KD5\\?\\)",
        ),
        ("contrl.improved.Kp5", "no table contrl of onboard.toml \\(did you mean control\\?\\)"),
        ("control.improvd.Kp5", "no table improvd in \\[control\\]"),
        ("control.improved", "is a table"),
        ("mission.max_tries", "an integer"),
        ("guidance.mode", "not a real number"),
        ("control.improved.feedforward", "not a real number"),
        ("control.improved.speed_map_mps", "not a real number"),
        ("Kp5", "dotted key"),
        ("control..Kp5", "dotted key"),
    ],
)
def test_config_value_refuses_what_is_no_real_setting(config: Any, key: str, words: str) -> None:
    with pytest.raises(ParamError, match=words) as info:
        tune.config_value(config, key)
    assert str(info.value).startswith(key + ":") and "\n" not in str(info.value)


def test_resolve_params_default_and_explicit_ranges(config: Any) -> None:
    entries = tune.parse_params("control.improved.Kp5,control.improved.KD5=-1:-0.1")
    params = tune.resolve_params(entries, config, tune.onboard_accepts)
    assert params == [
        Param("control.improved.Kp5", -0.9, -0.3, -0.6),
        Param("control.improved.KD5", -1, -0.1, -0.3),
    ]
    assert (params[0].table, params[0].leaf) == ("control.improved", "Kp5")


def test_resolve_params_zero_default_stays_where_the_onboard_allows(config: Any) -> None:
    # derivative_tau_s is 0 and must be >= 0: the default range becomes [0, ZERO_SCALE]
    (p,) = tune.resolve_params([("control.improved.derivative_tau_s", None)], config, tune.onboard_accepts)
    assert (p.low, p.high, p.baseline) == (0.0, tune.ZERO_SCALE, 0.0)
    (q,) = tune.resolve_params([("control.improved.Kp2", None)], config, tune.onboard_accepts)
    assert (q.low, q.high) == (-tune.ZERO_SCALE, tune.ZERO_SCALE)


def test_resolve_params_refuses_a_range_the_onboard_refuses(config: Any) -> None:
    with pytest.raises(ParamError, match="rudder_per_curvature_radm must be >= 0") as info:
        tune.resolve_params(
            [("control.improved.rudder_per_curvature_radm", (-1.0, 1.0))], config, tune.onboard_accepts
        )
    text = str(info.value)
    assert text.startswith("control.improved.rudder_per_curvature_radm: the range -1:1") and "\n" not in text
    assert "onboard.toml." not in text  # the loader's file path is dropped


def test_resolve_params_checks_the_ends_together(config: Any) -> None:
    seen: list[list[str]] = []

    def accepts(sets: Any) -> str | None:
        seen.append(list(sets))
        return "too much" if len(sets) == 2 and all("=-0.9" in s or "=-0.45" in s for s in sets) else None

    with pytest.raises(ParamError, match="low ends of the ranges together are refused: too much"):
        tune.resolve_params([(KP5.key, None), (KD5.key, None)], config, accepts)
    assert ["control.improved.Kp5=-0.9"] in seen


# --- runs ----------------------------------------------------------------------------------------------
def test_with_values_replaces_in_place_and_appends() -> None:
    spec = parse_spec(SPEC, "t.yaml")
    plain, tuned = spec.runs[0], spec.runs[1]
    assert plain.onboard == () and tuned.onboard[0] == ("control.improved.Kp5", -0.3)
    values = {"control.improved.Kp5": -0.45, "control.improved.KD5": -0.2}
    assert tune.with_values(plain, values).onboard == (
        ("control.improved.Kp5", -0.45),
        ("control.improved.KD5", -0.2),
    )
    merged = tune.with_values(tuned, values)
    assert merged.onboard == (
        ("control.improved.Kp5", -0.45),
        ("guidance.lookahead_m", 2.5),
        ("control.improved.KD5", -0.2),
    )
    assert merged.onboard_sets() == [
        "control.improved.Kp5=-0.45",
        "guidance.lookahead_m=2.5",
        "control.improved.KD5=-0.2",
    ]
    assert merged.run_id == tuned.run_id and tuned.onboard[0] == ("control.improved.Kp5", -0.3)  # unchanged
    build_config(None, merged.onboard_sets())  # the onboard takes them


def test_score_is_the_mean_run_cost() -> None:
    good = {"planned": True, "success": True, "final_position_error_m": 0.1, "rms_cross_track_m": 0.2,
            "control_effort_rad": 1.0, "error": ""}  # fmt: skip
    miss = dict(good, success=False)
    bug = dict(good, error="ValueError: x", success=False)
    s = tune.score([good, miss, bug])
    assert s.cost == pytest.approx((0.4 + 10.4 + 20.0) / 3)
    assert (s.success_rate, s.runs, s.errors) == (pytest.approx(1 / 3), 3, 1)
    empty = tune.score([])
    assert math.isnan(empty.cost) and empty.runs == 0


def test_runs_fingerprint_follows_the_runs() -> None:
    a = parse_spec(SPEC, "t.yaml").runs
    b = parse_spec(SPEC, "t.yaml", seed_offset=1000).runs
    assert tune.runs_fingerprint(a) == tune.runs_fingerprint(parse_spec(SPEC, "other.yaml").runs)
    assert tune.runs_fingerprint(a) != tune.runs_fingerprint(b)


# --- the trial loop -------------------------------------------------------------------------------------
def toy(values: dict[str, float]) -> Score:
    """A bowl with its minimum at Kp5 = -0.45, KD5 = -0.2."""
    kp, kd = values[KP5.key], values[KD5.key]
    return Score(1.0 + (kp + 0.45) ** 2 + (kd + 0.2) ** 2, 1.0, 3, 0)


def new_study(tmp_path: Path, params: list[Param] = [KP5, KD5]) -> optuna.Study:  # noqa: B006
    sampler = tune.make_sampler("tpe", params, seed=0, n_trials=8)
    storage = f"sqlite:///{tmp_path / 'study.db'}"
    return tune.open_study(
        storage, "t", sampler, {"params": [p.to_dict() for p in params], "train_runs": "x"}
    )


def test_run_trials_baseline_first_then_rounded_samples(tmp_path: Path) -> None:
    study = new_study(tmp_path)
    seen: list[int] = []
    assert not tune.run_trials(study, [KP5, KD5], toy, 8, on_trial=lambda t: seen.append(t.number))
    trials = study.trials
    assert seen == list(range(8)) and len(trials) == 8
    assert trials[0].user_attrs["baseline"] and tune.trial_values(trials[0]) == {KP5.key: -0.6, KD5.key: -0.3}
    for t in trials[1:]:
        for key, value in tune.trial_values(t).items():
            assert value == tune.round_sig(value)
            assert -0.91 <= value <= -0.14, key
    best, base = tune.best_trial(study), tune.baseline_trial(study)
    assert best is not None and base is not None and base.number == 0
    assert best.value is not None and base.value is not None and best.value <= base.value
    assert best.user_attrs["success_rate"] == 1.0 and best.user_attrs["runs"] == 3


def test_run_trials_resumes_to_the_total_without_a_second_baseline(tmp_path: Path) -> None:
    tune.run_trials(new_study(tmp_path), [KP5, KD5], toy, 3)
    again = new_study(tmp_path)  # the same storage: loaded
    assert len(again.trials) == 3
    tune.run_trials(again, [KP5, KD5], toy, 5)
    assert len(again.trials) == 5
    assert [bool(t.user_attrs.get("baseline")) for t in again.trials] == [True, False, False, False, False]
    tune.run_trials(again, [KP5, KD5], toy, 5)  # already there: nothing to do
    assert len(again.trials) == 5


def test_open_study_refuses_other_params_or_runs(tmp_path: Path) -> None:
    new_study(tmp_path)
    with pytest.raises(ParamError, match="other parameters or ranges"):
        new_study(tmp_path, [KP5])
    sampler = tune.make_sampler("tpe", [KP5, KD5], seed=0, n_trials=8)
    attrs = {"params": [KP5.to_dict(), KD5.to_dict()], "train_runs": "y"}
    with pytest.raises(ParamError, match="other training runs"):
        tune.open_study(f"sqlite:///{tmp_path / 'study.db'}", "t", sampler, attrs)


def test_run_trials_stops_after_the_current_trial(tmp_path: Path) -> None:
    study = new_study(tmp_path)
    stop = tune._StopFlag()

    def evaluate(values: dict[str, float]) -> Score:
        if len(study.trials) == 2:
            stop.handler(2, None)  # Ctrl-C during trial 1: it finishes
        return toy(values)

    assert tune.run_trials(study, [KP5, KD5], evaluate, 8, stop=stop)
    assert [t.state.name for t in study.trials] == ["COMPLETE", "COMPLETE"]
    with pytest.raises(KeyboardInterrupt):
        stop.handler(2, None)  # the second Ctrl-C: now


def test_run_trials_keyboard_interrupt_fails_the_trial(tmp_path: Path) -> None:
    study = new_study(tmp_path)

    def evaluate(values: dict[str, float]) -> Score:
        if len(study.trials) == 3:
            raise KeyboardInterrupt
        return toy(values)

    assert tune.run_trials(study, [KP5, KD5], evaluate, 8)
    assert [t.state.name for t in study.trials] == ["COMPLETE", "COMPLETE", "FAIL"]
    assert set(tune.trial_values(study.trials[2])) == {KP5.key, KD5.key}  # what it was about to fly


def test_run_trials_baseline_is_retried_if_it_never_finished(tmp_path: Path) -> None:
    study = new_study(tmp_path)

    def broken(values: dict[str, float]) -> Score:
        raise RuntimeError("boom")

    with pytest.raises(RuntimeError, match="boom"):
        tune.run_trials(study, [KP5, KD5], broken, 3)
    assert [t.state.name for t in study.trials] == ["FAIL"]
    tune.run_trials(study, [KP5, KD5], toy, 2)
    base = tune.baseline_trial(study)
    assert base is not None and base.number == 1 and tune.trial_values(base) == {KP5.key: -0.6, KD5.key: -0.3}


def test_tpe_startup_trials() -> None:
    assert [tune.tpe_startup_trials(n) for n in (1, 3, 12, 40, 400)] == [2, 2, 3, 10, 10]


# --- products ------------------------------------------------------------------------------------------
def test_best_toml_is_toml_under_its_tables() -> None:
    values = {"control.improved.Kp5": -0.4251, "guidance.lookahead_m": 2.5, "control.improved.KD5": -0.311}
    text = tune.best_toml(values, ["tuned", "", "cost 0.1"])
    assert text.startswith("# tuned\n#\n# cost 0.1\n")
    data = tomllib.loads(text)
    assert data == {
        "control": {"improved": {"Kp5": -0.4251, "KD5": -0.311}},
        "guidance": {"lookahead_m": 2.5},
    }
    assert text.count("[control.improved]") == 1
    assert tomllib.loads(tune.best_toml({"a.b": 1e-7}))["a"]["b"] == 1e-7


def doc_of(
    study: optuna.Study, params: list[Param], holdout: dict[int, Score], tmp_path: Path
) -> dict[str, Any]:
    args = type("A", (), {"sampler": "tpe", "seed": 0, "holdout_seed_offset": 1000, "trials": 8})()
    spec = parse_spec(SPEC, "t.yaml")
    return tune.build_doc(spec, study, params, args, holdout, False, tmp_path)  # type: ignore[arg-type]


def test_outputs_tell_train_and_held_out_of_baseline_and_best(tmp_path: Path) -> None:
    study = new_study(tmp_path)
    tune.run_trials(study, [KP5, KD5], toy, 6)
    best = tune.best_trial(study)
    assert best is not None and best.number != 0
    holdout = {0: Score(1.5, 0.5, 4, 0), best.number: Score(1.2, 0.75, 4, 0)}
    doc = doc_of(study, [KP5, KD5], holdout, tmp_path)
    assert doc["baseline"]["values"] == {KP5.key: -0.6, KD5.key: -0.3}
    assert doc["best"]["trial"] == best.number and doc["best"]["holdout_cost"] == 1.2
    assert doc["baseline"]["holdout_success_rate"] == 0.5 and doc["trials"]["complete"] == 6
    tune.write_outputs(tmp_path, doc, study, [KP5.key, KD5.key])

    snippet = (tmp_path / "best.toml").read_text()
    data = tomllib.loads(snippet)["control"]["improved"]
    assert data == {"Kp5": doc["best"]["values"][KP5.key], "KD5": doc["best"]["values"][KD5.key]}
    header = [line for line in snippet.splitlines() if line.startswith("#")]
    assert any("baseline (#0)" in line and "1.5000" in line and "50.0 %" in line for line in header)
    assert any(f"best (#{best.number})" in line and "1.2000" in line for line in header)
    sets = [line.split("--set ")[1] for line in header if "--set " in line]
    assert len(sets) == 2
    build_config(None, sets)

    with (tmp_path / "trials.csv").open(newline="") as f:
        rows = list(csv.DictReader(f))
    assert [r["number"] for r in rows] == [str(i) for i in range(6)]
    assert (
        rows[0]["baseline"] == "True" and float(rows[0][KP5.key]) == -0.6 and rows[0]["state"] == "COMPLETE"
    )
    assert json.loads((tmp_path / "tune.json").read_text()) == doc
    page = (tmp_path / "tune.html").read_text()
    assert page.count("data:image/png;base64,") == 3 and 'src="http' not in page
    assert "held-out success" in page and "[control.improved]" in page


def test_outputs_without_a_finished_trial(tmp_path: Path) -> None:
    study = new_study(tmp_path)
    doc = doc_of(study, [KP5], {}, tmp_path)
    assert doc["baseline"] is None and doc["best"] is None
    tune.write_outputs(tmp_path, doc, study, [KP5.key])
    assert not (tmp_path / "best.toml").exists() and "best.toml" not in doc["files"]
    assert (tmp_path / "tune.html").exists() and (tmp_path / "trials.csv").read_text().startswith("number,")


def test_summary_lines_name_the_files(tmp_path: Path) -> None:
    study = new_study(tmp_path)
    tune.run_trials(study, [KP5, KD5], toy, 2)
    doc = doc_of(study, [KP5, KD5], {}, tmp_path)
    lines = tune.summary_lines(doc)
    assert lines[0].startswith("t: 2 trials (tpe, seed 0)")
    assert any(line.startswith("baseline (#0)") and line.rstrip().endswith("-") for line in lines)
    assert lines[-1].startswith("files: ") and str(tmp_path / "best.toml") in lines[-1]


# --- the command line, before any run ---------------------------------------------------------------------
@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["--params", "control.improved.Kd5"], "--params control.improved.Kd5: no key Kd5"),
        (["--params", "guidance.mode"], "--params guidance.mode: not a real number"),
        (["--params", "control.improved.Kp5=1"], "--params control.improved.Kp5=1: expected"),
        (["--params", "control.improved.Kp5", "--trials", "0"], "--trials must be >= 1"),
        (["--params", "control.improved.Kp5", "--workers", "0"], "--workers must be >= 1"),
        (["--params", "control.improved.Kp5", "--holdout-seed-offset", "0"], "--holdout-seed-offset 0 would"),
    ],
)
def test_tune_main_refuses_before_any_run(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], args: list[str], words: str
) -> None:
    import yaml

    spec = tmp_path / "t.yaml"
    spec.write_text(yaml.safe_dump(SPEC))
    out = tmp_path / "out"
    argv = [str(spec), "--out", str(out), "--no-progress", *args]
    if "--trials" not in args:
        argv += ["--trials", "2"]
    assert tune.tune_main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"auv-hil tune: {words}") and err.count("\n") == 1, err
    assert not out.exists()


def test_tune_main_refuses_a_bad_spec(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    argv = [
        str(tmp_path / "none.yaml"),
        "--params",
        "control.improved.Kp5",
        "--trials",
        "2",
        "--out",
        str(tmp_path),
    ]
    assert tune.tune_main(argv) == 2
    assert "no such spec file" in capsys.readouterr().err
