"""``auv-hil tune``'s pieces without flying: --params parsing, ranges, the onboard keys, the override merge,
scores, the trial loop on a toy objective (baseline first, resumption with new points, Ctrl-C, refused
combinations), the held-out set, the files it writes, and the command with a stand-in executor."""

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
from auv_campaign.tune import Param, ParamError, Score, round_sig
from onboard.app.config import DEFAULT_CONFIG_PATH
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
#: The packaged onboard.toml's Kp5 (the tuned value changes; the tests of reading it follow the file).
FILE_KP5 = tomllib.loads(DEFAULT_CONFIG_PATH.read_text())["control"]["improved"]["Kp5"]


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
    assert tune.config_value(config, "control.improved.Kp5") == FILE_KP5  # onboard.toml
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
        ("control.speed_map_mps", "not a real number"),
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
        Param("control.improved.Kp5", round_sig(1.5 * FILE_KP5), round_sig(0.5 * FILE_KP5), FILE_KP5),
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
        low_ends = (f"Kp5={1.5 * FILE_KP5:g}", "KD5=-0.45")
        return "too much" if len(sets) == 2 and all(s.endswith(low_ends) for s in sets) else None

    with pytest.raises(ParamError, match="low ends of the ranges together are refused: too much"):
        tune.resolve_params([(KP5.key, None), (KD5.key, None)], config, accepts)
    assert [f"control.improved.Kp5={1.5 * FILE_KP5:g}"] in seen


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


def attrs_of(params: list[Param], sampler: str = "tpe", seed: int = 0, runs: str = "x") -> dict[str, Any]:
    return {"params": [p.to_dict() for p in params], "train_runs": runs, "sampler": sampler, "seed": seed}


#: An optuna study in a SQLite file: the integration tier (tests/conftest.py), not make check's unit tier.
STUDY = pytest.mark.integration


def new_study(
    tmp_path: Path,
    params: list[Param] = [KP5, KD5],  # noqa: B006
    *,
    seed: int = 0,
    n_trials: int = 8,
    seeds: list[int] | None = None,
) -> optuna.Study:
    def sampler(s: int) -> optuna.samplers.BaseSampler:
        if seeds is not None:
            seeds.append(s)
        return tune.make_sampler("tpe", params, seed=s, n_trials=n_trials)

    storage = f"sqlite:///{tmp_path / 'study.db'}"
    return tune.open_study(storage, "t", attrs_of(params, seed=seed), sampler)


@STUDY
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


@STUDY
def test_run_trials_resumes_to_the_total_without_a_second_baseline(tmp_path: Path) -> None:
    tune.run_trials(new_study(tmp_path), [KP5, KD5], toy, 3)
    again = new_study(tmp_path)  # the same storage: loaded
    assert len(again.trials) == 3
    tune.run_trials(again, [KP5, KD5], toy, 5)
    assert len(again.trials) == 5
    assert [bool(t.user_attrs.get("baseline")) for t in again.trials] == [True, False, False, False, False]
    tune.run_trials(again, [KP5, KD5], toy, 5)  # already there: nothing to do
    assert len(again.trials) == 5


@STUDY
def test_open_study_refuses_other_params_or_runs(tmp_path: Path) -> None:
    new_study(tmp_path)
    with pytest.raises(ParamError, match="other parameters or ranges"):
        new_study(tmp_path, [KP5])

    def sampler(s: int) -> optuna.samplers.BaseSampler:
        return tune.make_sampler("tpe", [KP5, KD5], seed=s, n_trials=8)

    storage = f"sqlite:///{tmp_path / 'study.db'}"
    with pytest.raises(ParamError, match="other training runs"):
        tune.open_study(storage, "t", attrs_of([KP5, KD5], runs="y"), sampler)


@pytest.mark.parametrize(
    ("sampler", "seed", "words"),
    [
        ("cmaes", 0, "was made with --sampler tpe, not cmaes: give --sampler tpe or another --out"),
        ("tpe", 7, "was made with --seed 0, not 7: give --seed 0 or another --out"),
    ],
)
@STUDY
def test_open_study_refuses_another_sampler_or_seed(
    tmp_path: Path, sampler: str, seed: int, words: str
) -> None:
    new_study(tmp_path)
    storage = f"sqlite:///{tmp_path / 'study.db'}"
    with pytest.raises(ParamError, match=words) as info:
        tune.open_study(
            storage, "t", attrs_of([KP5, KD5], sampler, seed), lambda s: optuna.samplers.RandomSampler(s)
        )
    assert "\n" not in str(info.value)
    stored = optuna.load_study(study_name="t", storage=storage).user_attrs
    assert (stored["sampler"], stored["seed"]) == ("tpe", 0)  # in the study, unchanged


@STUDY
def test_open_study_adopts_the_sampler_and_seed_of_an_older_study(tmp_path: Path) -> None:
    # a study made before tune stored them: taken as given, then kept
    storage = f"sqlite:///{tmp_path / 'study.db'}"
    old = optuna.create_study(storage=storage, study_name="t")
    old.set_user_attr("params", [KP5.to_dict(), KD5.to_dict()])
    old.set_user_attr("train_runs", "x")
    study = new_study(tmp_path, seed=3)
    assert (study.user_attrs["sampler"], study.user_attrs["seed"]) == ("tpe", 3)


@STUDY
def test_a_resumed_study_draws_new_points(tmp_path: Path) -> None:
    # GIVEN a study whose random start-up (10 trials for --trials 40) is under way: baseline + 2 draws
    seeds: list[int] = []
    tune.run_trials(new_study(tmp_path, n_trials=40, seeds=seeds), [KP5, KD5], toy, 3)
    # WHEN the same command resumes it to 5 trials
    again = new_study(tmp_path, n_trials=40, seeds=seeds)
    tune.run_trials(again, [KP5, KD5], toy, 5)
    # THEN its sampler was seeded with seed + the trials there, and it did not draw the first points again
    assert seeds == [0, 3] and tune.resume_seed(0, 3) == 3
    first, resumed = (
        [tune.trial_values(t) for t in again.trials[1:3]],
        [tune.trial_values(t) for t in again.trials[3:5]],
    )
    assert not any(v in first for v in resumed), (first, resumed)
    # (re-seeding with the seed itself, as before, does repeat them)
    repeat = tune.make_sampler("tpe", [KP5, KD5], seed=0, n_trials=40)
    other = optuna.create_study(sampler=repeat)
    tune.run_trials(other, [KP5, KD5], toy, 3)
    assert [tune.trial_values(t) for t in other.trials[1:3]] == first


@STUDY
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


@STUDY
def test_run_trials_keyboard_interrupt_fails_the_trial(tmp_path: Path) -> None:
    study = new_study(tmp_path)

    def evaluate(values: dict[str, float]) -> Score:
        if len(study.trials) == 3:
            raise KeyboardInterrupt
        return toy(values)

    assert tune.run_trials(study, [KP5, KD5], evaluate, 8)
    assert [t.state.name for t in study.trials] == ["COMPLETE", "COMPLETE", "FAIL"]
    assert set(tune.trial_values(study.trials[2])) == {KP5.key, KD5.key}  # what it was about to fly


@STUDY
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
    spec, held = (
        parse_spec(SPEC, "t.yaml"),
        parse_spec(SPEC, "t.yaml", seed_offset=1000, random_seed_offset=1000),
    )
    return tune.build_doc(spec, held, study, params, args, holdout, False, tmp_path)  # type: ignore[arg-type]


@STUDY
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
    sets = [line.removeprefix("#   --set ") for line in header if line.startswith("#   --set ")]
    assert len(sets) == 2
    build_config(None, sets)
    text = " ".join(line.lstrip("# ") for line in header)
    assert (
        "merge these keys into onboard.toml (a file of its own as --config would drop every other packaged "
        "setting), or use the --set lines" in text
    )
    assert "held-out = the spec's 4 runs with every noise seed + 1000 (seeds 0, 1 -> 1000, 1001)" in text

    with (tmp_path / "trials.csv").open(newline="") as f:
        rows = list(csv.DictReader(f))
    assert [r["number"] for r in rows] == [str(i) for i in range(6)]
    assert (
        rows[0]["baseline"] == "True" and float(rows[0][KP5.key]) == -0.6 and rows[0]["state"] == "COMPLETE"
    )
    assert json.loads((tmp_path / "tune.json").read_text()) == doc
    assert doc["holdout"] == {
        "seed_offset": 1000,
        "description": "the spec's 4 runs with every noise seed + 1000 (seeds 0, 1 -> 1000, 1001); the same "
        "missions (the spec lists them all), so other noise only",
        "runs": 4,
    }
    page = (tmp_path / "tune.html").read_text()
    assert page.count("data:image/png;base64,") == 3 and 'src="http' not in page
    assert "held-out success" in page and "[control.improved]" in page
    assert "the same missions (the spec lists them all), so other noise only" in page


@STUDY
def test_outputs_without_a_finished_trial(tmp_path: Path) -> None:
    study = new_study(tmp_path)
    doc = doc_of(study, [KP5], {}, tmp_path)
    assert doc["baseline"] is None and doc["best"] is None
    tune.write_outputs(tmp_path, doc, study, [KP5.key])
    assert not (tmp_path / "best.toml").exists() and "best.toml" not in doc["files"]
    assert (tmp_path / "tune.html").exists() and (tmp_path / "trials.csv").read_text().startswith("number,")


@STUDY
def test_summary_lines_name_the_files(tmp_path: Path) -> None:
    study = new_study(tmp_path)
    tune.run_trials(study, [KP5, KD5], toy, 2)
    doc = doc_of(study, [KP5, KD5], {}, tmp_path)
    lines = tune.summary_lines(doc)
    assert lines[0].startswith("t: 2 trials (tpe, seed 0)") and "refused" not in lines[0]
    assert lines[1].startswith("held-out: the spec's 4 runs with every noise seed + 1000")
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
        (
            ["--params", "control.improved.Kp5", "--holdout-seed-offset", "1"],
            "--holdout-seed-offset 1: held-out seed 1 would also be a training seed (the spec's seeds: 0, 1)",
        ),
        (
            ["--params", "control.improved.Kp5", "--holdout-seed-offset", "-1"],
            "t.yaml: sweep.seed[0]: seed + offset",
        ),
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
    assert err.startswith(f"auv-hil tune: {words}") or err.startswith(
        f"auv-hil tune: {spec.parent}/{words}"
    ), err
    assert err.count("\n") == 1, err
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


# --- the onboard's judge, refused combinations -------------------------------------------------------------
AREA = [
    Param("failsafe.area_x_min_m", -10.0, 10.0, -500.0),
    Param("failsafe.area_x_max_m", -9.0, 11.0, 500.0),
]  # every end alone and the lows / highs together load; min >= max inside does not


def test_onboard_accepts_is_the_spec_judge_without_a_key_in_front() -> None:
    assert tune.onboard_accepts(["control.improved.Kp5=-0.5"]) is None
    assert tune.onboard_accepts(["control.improved.rudder_per_curvature_radm=-1"]) == (
        "control.improved: rudder_per_curvature_radm must be >= 0 rad.m, got -1"
    )
    assert (
        tune.onboard_accepts(['control.improved.Kp5="a"'])
        == "control.improved.Kp5: expected a number, got 'a'"
    )
    assert tune.onboard_accepts(["nokey=1"]) == "--set 'nokey=1': expected TABLE.KEY=VALUE"
    assert tune.onboard_accepts(["failsafe.area_x_min_m=5", "failsafe.area_x_max_m=1"]) == (
        "failsafe: need area_x_min_m < area_x_max_m"
    )


def test_trial_check_judges_the_values_with_every_runs_overrides() -> None:
    runs = parse_spec(SPEC, "t.yaml").runs  # two runs without overrides, two with Kp5 and lookahead_m
    seen: list[list[str]] = []

    def accepts(sets: Any) -> str | None:
        seen.append(list(sets))
        return tune.onboard_accepts(sets)

    check = tune.trial_check(runs, accepts)
    assert check({AREA[0].key: -5.0, AREA[1].key: 5.0}) is None
    assert len(seen) == 2  # once per distinct set of overrides, not per run
    assert seen[1][:2] == ["control.improved.Kp5=-0.3", "guidance.lookahead_m=2.5"]
    assert check({AREA[0].key: 5.0, AREA[1].key: 1.0}) == "failsafe: need area_x_min_m < area_x_max_m"
    # a run's own override can be what breaks the rule
    spec = dict(SPEC, sweep={"seed": [0], "onboard": [{}, {"failsafe.area_x_max_m": 2.0}]})
    check = tune.trial_check(parse_spec(spec, "t.yaml").runs, tune.onboard_accepts)
    problem = check({AREA[0].key: 3.0})
    assert (
        problem is not None
        and problem.startswith("with the overrides of line_s0_c0d0_basin_o1_nominal: failsafe: need")
        and "area_x_min_m" in problem
    )


@STUDY
def test_run_trials_prunes_refused_combinations_and_goes_on(tmp_path: Path) -> None:
    study = new_study(tmp_path, AREA)
    check = tune.trial_check(parse_spec(SPEC, "t.yaml").runs, tune.onboard_accepts)
    flown: list[dict[str, float]] = []

    def evaluate(values: dict[str, float]) -> Score:
        flown.append(values)
        return Score(abs(values[AREA[0].key]) + abs(values[AREA[1].key]), 1.0, 4, 0)

    assert not tune.run_trials(study, AREA, evaluate, 12, check=check)
    states = [t.state.name for t in study.trials]
    refused = tune.refused_trials(study)
    assert states.count("COMPLETE") == 12 == len(flown) and states.count("PRUNED") == len(refused) > 0
    assert all(v[AREA[0].key] < v[AREA[1].key] for v in flown)  # no refused combination flew
    for t in refused:
        values = tune.trial_values(t)
        assert values[AREA[0].key] >= values[AREA[1].key]
        assert t.user_attrs["refused"] == "failsafe: need area_x_min_m < area_x_max_m"
    assert "errors" not in refused[0].user_attrs  # not a run error
    doc = doc_of(study, AREA, {}, tmp_path)
    assert doc["trials"]["refused"] == len(refused) and doc["trials"]["failed"] == 0
    assert f"; {len(refused)} more refused by the onboard (not flown)" in tune.summary_lines(doc)[0]
    tune.write_outputs(tmp_path, doc, study, [p.key for p in AREA])
    with (tmp_path / "trials.csv").open(newline="") as f:
        rows = [r for r in csv.DictReader(f) if r["state"] == "PRUNED"]
    assert len(rows) == len(refused) and all(
        r["refused"].startswith("failsafe: need") and r["cost"] == "" for r in rows
    )
    assert "refused by the onboard, not flown" in (tmp_path / "tune.html").read_text()


@STUDY
def test_run_trials_gives_up_after_too_many_refusals_in_a_row(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(tune, "MAX_REFUSED_IN_A_ROW", 4)
    study = new_study(tmp_path)

    with pytest.raises(tune.TooManyRefused, match=r"4 sampled combinations in a row were refused .* no"):
        tune.run_trials(study, [KP5, KD5], toy, 5, check=lambda values: "no")
    assert [t.state.name for t in study.trials] == ["PRUNED"] * 4
    assert [bool(t.user_attrs.get("baseline")) for t in study.trials] == [True, False, False, False]  # once


# --- the held-out set -----------------------------------------------------------------------------------
RANDOM = dict(SPEC, random_missions={"count": 2, "seed": 7, "area_m": 40})


def test_holdout_description_says_what_moved() -> None:
    train = parse_spec(RANDOM, "t.yaml")
    held = parse_spec(RANDOM, "t.yaml", seed_offset=50, random_seed_offset=50)
    assert tune.holdout_description(train, held, 50) == (
        "the spec's 12 runs with every noise seed + 50 (seeds 0, 1 -> 50, 51) and the random missions drawn "
        "with random_missions.seed + 50 (other missions); the 1 listed mission the same"
    )
    only_random = {k: v for k, v in RANDOM.items() if k != "missions"}
    text = tune.holdout_description(
        parse_spec(only_random, "t.yaml"),
        parse_spec(only_random, "t.yaml", seed_offset=5, random_seed_offset=5),
        5,
    )
    assert text.endswith("drawn with random_missions.seed + 5 (other missions)")
    many = dict(SPEC, sweep={"seed": list(range(10))})
    text = tune.holdout_description(
        parse_spec(many, "t.yaml"), parse_spec(many, "t.yaml", seed_offset=100), 100
    )
    assert "(seeds 0 ... 9 (10 seeds) -> 100 ... 109 (10 seeds)); the same missions" in text


def test_holdout_clash_names_the_shared_seed() -> None:
    spec = dict(SPEC, sweep={"seed": [0, 5, 10]})
    train = parse_spec(spec, "t.yaml")
    assert tune.holdout_clash(train, parse_spec(spec, "t.yaml", seed_offset=1000)) is None
    assert tune.holdout_clash(train, parse_spec(spec, "t.yaml", seed_offset=5)) == (
        "held-out seed 5, 10 would also be a training seed (the spec's seeds: 0, 5, 10): give another offset"
    )


# --- the command with a stand-in executor (no flight) -------------------------------------------------------
class FakeExecute:
    """Stands in for :func:`auv_campaign.execute.execute`: a row per run whose cost follows the run's onboard
    overrides; it checks that every run it gets is one the onboard takes."""

    def __init__(self) -> None:
        self.batches: list[list[Any]] = []

    def __call__(self, runs: Any, out_dir: Any, executor: Any, on_record: Any = None) -> list[dict[str, Any]]:
        assert out_dir is None
        self.batches.append(list(runs))
        records = []
        for run in runs:
            assert tune.onboard_accepts(run.onboard_sets()) is None, run.onboard
            err = sum(abs(float(v)) for _, v in run.onboard) / 1000.0
            row = {"run_id": run.run_id, "planned": True, "success": True, "final_position_error_m": err,
                   "rms_cross_track_m": 0.1, "control_effort_rad": 1.0, "error": ""}  # fmt: skip
            record = {"run_id": run.run_id, "row": row}
            if on_record is not None:
                on_record(record)
            records.append(record)
        return records


@pytest.fixture
def fake_execute(monkeypatch: pytest.MonkeyPatch) -> FakeExecute:
    from auv_campaign import execute

    fake = FakeExecute()
    monkeypatch.setattr(execute, "execute", fake)
    return fake


def spec_file(tmp_path: Path) -> Path:
    import yaml

    path = tmp_path / "t.yaml"
    path.write_text(yaml.safe_dump(SPEC))
    return path


AREA_PARAMS = "failsafe.area_x_min_m=-10:10,failsafe.area_x_max_m=-9:11"


@STUDY
def test_tune_main_prunes_refused_combinations_and_counts_them(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], fake_execute: FakeExecute
) -> None:
    out = tmp_path / "out"
    argv = [str(spec_file(tmp_path)), "--params", AREA_PARAMS, "--trials", "10", "--out", str(out),
            "--workers", "1", "--no-progress", "--json"]  # fmt: skip
    assert tune.tune_main(argv) == 0, capsys.readouterr().err
    doc = json.loads(capsys.readouterr().out)
    assert doc["trials"]["complete"] == 10 and doc["trials"]["refused"] > 0 and doc["trials"]["failed"] == 0
    assert len(fake_execute.batches) == 10 + 1  # the trials, then one held-out batch
    assert json.loads((out / "tune.json").read_text())["trials"]["refused"] == doc["trials"]["refused"]
    assert doc["best"]["train_errors"] == 0


@STUDY
def test_tune_main_resumes_only_with_the_same_sampler_and_seed(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], fake_execute: FakeExecute
) -> None:
    out = tmp_path / "out"
    argv = [
        str(spec_file(tmp_path)),
        "--params",
        KP5.key,
        "--out",
        str(out),
        "--workers",
        "1",
        "--no-progress",
    ]
    assert tune.tune_main([*argv, "--trials", "2"]) == 0
    capsys.readouterr()
    for extra, words in (
        (["--seed", "1"], "was made with --seed 0, not 1: give --seed 0 or another --out"),
        (["--sampler", "cmaes", "--params", f"{KP5.key},{KD5.key}"], "other parameters or ranges"),
    ):
        assert tune.tune_main([*argv, "--trials", "3", *extra]) == 2
        err = capsys.readouterr().err
        assert err.startswith(f"auv-hil tune: {out / 'study.db'}: study 't' ") and words in err, err
        assert err.count("\n") == 1
    assert tune.tune_main([*argv, "--trials", "4"]) == 0  # the same: resumed
    study = optuna.load_study(study_name="t", storage=f"sqlite:///{out / 'study.db'}")
    assert len(study.trials) == 4 and (study.user_attrs["sampler"], study.user_attrs["seed"]) == ("tpe", 0)


@STUDY
def test_tune_main_refuses_another_sampler_on_resume(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], fake_execute: FakeExecute
) -> None:
    out = tmp_path / "out"
    argv = [str(spec_file(tmp_path)), "--params", f"{KP5.key},{KD5.key}", "--out", str(out), "--workers", "1",
            "--no-progress", "--trials", "2"]  # fmt: skip
    assert tune.tune_main(argv) == 0
    capsys.readouterr()
    assert tune.tune_main([*argv, "--sampler", "cmaes"]) == 2
    err = capsys.readouterr().err
    assert "was made with --sampler tpe, not cmaes: give --sampler tpe or another --out" in err
    assert err.count("\n") == 1


def test_tune_main_turns_an_executor_error_into_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    import contextlib

    from auv_campaign import execute

    seen: list[tuple[int, str | None]] = []

    @contextlib.contextmanager
    def session(workers: int, address: str | None) -> Any:
        seen.append((workers, address))
        raise execute.ExecutorError(f"cannot join the Ray cluster at {address}: Connection refused")
        yield

    monkeypatch.setattr(execute, "ray_session", session)
    argv = [str(spec_file(tmp_path)), "--params", KP5.key, "--trials", "2", "--out", str(tmp_path / "out"),
            "--workers", "3", "--ray", "10.0.0.1:6379", "--no-progress"]  # fmt: skip
    assert tune.tune_main(argv) == 1
    err = capsys.readouterr().err
    assert err == "auv-hil tune: cannot join the Ray cluster at 10.0.0.1:6379: Connection refused\n"
    assert seen == [(3, "10.0.0.1:6379")]
