"""``auv-hil tune``: tune onboard settings (gains) with optuna over the runs of a campaign spec.

::

    auv-hil tune SPEC.yaml --params control.improved.Kp5,control.improved.KD5=-0.6:-0.1 --trials 30 --out DIR

- Parameters: dotted keys of ``onboard.toml`` whose value is a real number (``float``). ``KEY`` alone
  searches the default range: the current value (the packaged ``onboard.toml``, with its defaults) times
  [0.5, 1.5], sign kept (-0.6 gives [-0.9, -0.3]); a current value of 0 gives [-1, 1] x
  :data:`ZERO_SCALE` (or [0, 1] x it where the onboard refuses negative values). ``KEY=LO:HI`` gives the
  range (same units as the key). Both ends of every range are judged by the onboard's own loader before any
  run. Sampled values are rounded to :data:`SIGNIFICANT_DIGITS` significant digits before they fly (what
  flew is what is recorded and written).
- Objective (minimised): the mean :func:`auv_campaign.results.run_cost` over the training runs: the spec's
  runs with the trial's values added to each run's onboard overrides (replacing the spec's own value of a
  tuned key). Trials run one after the other; each trial's runs in parallel on the executor (``--workers``
  local processes, or ``--ray``), with no per-run files. Before a trial flies, its values with each run's
  own overrides go through the onboard's loader: a combination that breaks a rule across keys (e.g.
  ``failsafe.area_x_min_m < area_x_max_m``) is not flown, the trial is told to optuna as pruned (refused, not
  a bug) and counted in the summary; :data:`MAX_REFUSED_IN_A_ROW` refused trials in a row stop the study
  (exit 2: narrow the ranges).
- Trial 0 is the baseline: the current values, enqueued so that the hand-tuned settings are measured with
  the same cost. The samplers: ``tpe`` (default; :class:`optuna.samplers.TPESampler`, multivariate, with
  :func:`tpe_startup_trials` random trials first, the baseline included) or ``cmaes``
  (:class:`optuna.samplers.CmaEsSampler` starting at the centre of the ranges, which is the baseline for
  default ranges; needs the ``cmaes`` package and at least 2 parameters to be CMA-ES rather than random
  sampling), both seeded by ``--seed`` + the number of trials already in the study (:func:`resume_seed`: a
  resumed study draws new points rather than the first ones again).
- The study lives in ``DIR/study.db`` (SQLite, optuna's RDB storage, named after the spec): the same
  command with the same ``--out`` resumes it; ``--trials`` is the number of finished trials wanted in all.
  A study over other parameters, ranges or training runs, or made with another ``--sampler`` or ``--seed``,
  is refused (another ``--out``).
- Held-out: the spec's runs with every sweep noise seed + ``--holdout-seed-offset`` and its random missions
  drawn with ``random_missions.seed`` + the offset (other missions); the listed missions stay the same, so
  for a spec with listed missions only the held-out runs are the same missions with other noise. Currents,
  profiles, overrides and vehicle variants are alike. An offset that makes a held-out seed a training seed
  is refused. The baseline and the best trial are flown on it at the end: the train cost of the best is
  optimistic (it was selected on it), the held-out cost is the honest one. tune.json (``holdout``),
  tune.html and best.toml say what it was.
- Writes ``DIR/best.toml`` (the best values as an ``onboard.toml`` snippet to merge into ``onboard.toml``, a
  comment header with the train and held-out results and the equivalent ``--set`` arguments),
  ``DIR/trials.csv``, ``DIR/tune.json`` and ``DIR/tune.html`` (self-contained).

Exit codes (those of ``auv-hil campaign``): 0 done; 1 a run raised (a bug; it cost as a failure) or the
executor could not start (one line, e.g. no Ray cluster at the address); 2 a bad spec or command line (one
line, before any run), or too many sampled combinations refused in a row; 130 Ctrl-C: the current trial
finishes (Ctrl-C again stops it at once), the held-out evaluation still runs (Ctrl-C skips it), the outputs
are written from the finished trials and the same command resumes.
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import dataclasses
import difflib
import hashlib
import html
import itertools
import json
import math
import signal
import sys
import textwrap
import time
import typing
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import FrameType
from typing import TYPE_CHECKING, Any

from auv_campaign.cli_common import (
    EXIT_INTERRUPTED,
    EXIT_OK,
    EXIT_RUN_ERROR,
    add_executor_args,
    fail,
    usable_out_dir,
)
from auv_campaign.results import run_cost
from auv_campaign.spec import CampaignSpec, RunSpec, set_argument
from auv_common.config import ConfigError

if TYPE_CHECKING:
    import optuna

PROG = "auv-hil tune"
#: The default range of a key: its current value times these (sign kept).
DEFAULT_FACTORS = (0.5, 1.5)
#: The default range of a key whose current value is 0: [-1, 1] times this (in the key's own units).
ZERO_SCALE = 0.1
#: Sampled values are rounded to this many significant digits before they fly.
SIGNIFICANT_DIGITS = 4
SAMPLERS = ("tpe", "cmaes")
DEFAULT_HOLDOUT_OFFSET = 1000
FILES = ("best.toml", "trials.csv", "tune.json", "tune.html")
#: The trial's user attribute that marks the baseline (the enqueued current values).
BASELINE_ATTR = "baseline"
#: The trial's user attribute of a trial the onboard refused (the loader's message); the trial is PRUNED.
REFUSED_ATTR = "refused"
#: This many refused trials in a row stop the study (the ranges are mostly refused combinations).
MAX_REFUSED_IN_A_ROW = 50


class ParamError(ValueError):
    """A bad ``--params`` entry: one line naming it."""


class TooManyRefused(ParamError):
    """:data:`MAX_REFUSED_IN_A_ROW` sampled combinations in a row were refused by the onboard."""


# ----------------------------------------------------------------------------------------------------
# Parameters: parsing, ranges, the onboard configuration


@dataclass(frozen=True)
class Param:
    """One tuned key: its dotted ``key`` in ``onboard.toml``, the searched range [``low``, ``high``] and the
    current (``baseline``) value, all in the key's units."""

    key: str
    low: float
    high: float
    baseline: float

    @property
    def table(self) -> str:
        """The TOML table of the key (``control.improved`` for ``control.improved.Kp5``)."""
        return self.key.rpartition(".")[0]

    @property
    def leaf(self) -> str:
        """The key within its table (``Kp5``)."""
        return self.key.rpartition(".")[2]

    def to_dict(self) -> dict[str, Any]:
        return {"key": self.key, "low": self.low, "high": self.high, "baseline": self.baseline}


def round_sig(value: float, digits: int = SIGNIFICANT_DIGITS) -> float:
    """``value`` rounded to ``digits`` significant digits (0 stays 0)."""
    if value == 0.0 or not math.isfinite(value):
        return value
    return float(f"{value:.{digits}g}")


def parse_params(text: str) -> list[tuple[str, tuple[float, float] | None]]:
    """``KEY[=LO:HI][,KEY[=LO:HI]...]`` -> [(key, (lo, hi) or None)], in order; syntax only (the keys are
    judged by :func:`resolve_params`). Raises :class:`ParamError` (empty entry, a bad or empty range,
    lo >= hi, a key twice)."""
    out: list[tuple[str, tuple[float, float] | None]] = []
    for raw in text.split(","):
        item = raw.strip()
        if not item:
            raise ParamError(f"{text!r}: empty entry (expected KEY[=LO:HI][,KEY...])")
        key, sep, rng = (s.strip() for s in item.partition("="))
        if not key:
            raise ParamError(f"{item}: expected KEY[=LO:HI]")
        bounds: tuple[float, float] | None = None
        if sep:
            lo_s, colon, hi_s = rng.partition(":")
            try:
                if not colon:
                    raise ValueError
                lo, hi = float(lo_s), float(hi_s)
            except ValueError:
                raise ParamError(f"{item}: expected {key}=LO:HI with two numbers, got {rng!r}") from None
            if not (math.isfinite(lo) and math.isfinite(hi)):
                raise ParamError(f"{item}: the range must be finite")
            if not lo < hi:
                raise ParamError(f"{item}: expected LO < HI, got {lo:g}:{hi:g}")
            bounds = (lo, hi)
        if any(key == k for k, _ in out):
            raise ParamError(f"{key}: given twice")
        out.append((key, bounds))
    return out


def default_range(value: float, zero_scale: float = ZERO_SCALE) -> tuple[float, float]:
    """The default search range of a key whose current value is ``value``: ``value`` x [0.5, 1.5] with its
    sign kept (the ends ordered, rounded to 6 significant digits), or [-zero_scale, zero_scale] for 0."""
    if value == 0.0:
        return -zero_scale, zero_scale
    a, b = (round_sig(value * f, 6) for f in DEFAULT_FACTORS)
    return (a, b) if a < b else (b, a)


def _did_you_mean(name: str, names: Sequence[str]) -> str:
    same_case = [n for n in names if n.lower() == name.lower()]
    close = same_case or difflib.get_close_matches(name, names, n=3, cutoff=0.6)
    return f" (did you mean {' or '.join(close)}?)" if close else ""


def config_value(config: Any, key: str) -> float:
    """The current value of the dotted ``key`` in the onboard configuration ``config`` (nested frozen
    dataclasses); raises :class:`ParamError` unless it names a real-valued (``float``) setting."""
    parts = key.split(".")
    if len(parts) < 2 or not all(parts):
        raise ParamError(f"{key}: expected a dotted key TABLE.KEY of onboard.toml")
    node, path = config, ""
    for part in parts[:-1]:
        fields = [f.name for f in dataclasses.fields(node) if f.init]
        tables = [n for n in fields if dataclasses.is_dataclass(getattr(node, n))]
        if part not in tables:
            where = f" in [{path}]" if path else ""
            raise ParamError(f"{key}: no table {part}{where} of onboard.toml{_did_you_mean(part, tables)}")
        node, path = getattr(node, part), f"{path}.{part}" if path else part
    leaf = parts[-1]
    names = [f.name for f in dataclasses.fields(node) if f.init]
    if leaf not in names:
        raise ParamError(f"{key}: no key {leaf} in [{path}] of onboard.toml{_did_you_mean(leaf, names)}")
    value = getattr(node, leaf)
    annotation = typing.get_type_hints(type(node)).get(leaf)
    if dataclasses.is_dataclass(value):
        raise ParamError(f"{key}: is a table, not a number")
    if annotation is not float or isinstance(value, bool) or not isinstance(value, float):
        kind = "an integer" if annotation is int else f"not a real number (it is {value!r})"
        raise ParamError(f"{key}: {kind}: tune tunes real-valued settings only")
    return value


def resolve_params(
    entries: Sequence[tuple[str, tuple[float, float] | None]],
    config: Any,
    accepts: Callable[[Sequence[str]], str | None],
) -> list[Param]:
    """The parameters of ``entries`` (:func:`parse_params`) against the onboard configuration ``config``.

    ``accepts(sets)`` is the onboard's own judge: ``None`` if the ``--set`` arguments load, else the
    problem. Every end of every range (alone, then all lows together and all highs together) must load; a
    default range around 0 that the onboard refuses below 0 becomes [0, ZERO_SCALE]. Raises
    :class:`ParamError`.
    """
    params: list[Param] = []
    for key, bounds in entries:
        value = config_value(config, key)
        hint = ""
        if bounds is None:
            lo, hi = default_range(value)
            if value == 0.0 and accepts([set_argument(key, lo)]) is not None:
                lo = 0.0
            bounds, hint = (lo, hi), f" (the default range; give {key}=LO:HI)"
        for end in bounds:
            problem = accepts([set_argument(key, end)])
            if problem is not None:
                rng = f"{bounds[0]:g}:{bounds[1]:g}"
                raise ParamError(f"{key}: the range {rng}{hint} ends in a refused value: {problem}")
        params.append(Param(key, bounds[0], bounds[1], value))
    for name, index in (("low", 0), ("high", 1)):
        sets = [set_argument(p.key, (p.low, p.high)[index]) for p in params]
        problem = accepts(sets)
        if problem is not None:
            raise ParamError(f"the {name} ends of the ranges together are refused: {problem}")
    return params


_ONBOARD = "onboard"  # the key spec._check_onboard puts in front of a problem (removed again)


def onboard_accepts(sets: Sequence[str]) -> str | None:
    """The onboard loader's verdict on ``--set`` arguments over the packaged ``onboard.toml``: ``None``, or
    the problem (``TABLE: what`` without the file's path). The judge is the campaign spec's own
    (:func:`auv_campaign.spec.check_onboard_sets`), with no key of the spec in front."""
    from auv_campaign.spec import SpecError, check_onboard_sets

    try:
        check_onboard_sets(_ONBOARD, list(sets))
    except SpecError as exc:
        text = str(exc)
        for prefix in (f"{_ONBOARD}.", f"{_ONBOARD}: "):
            if text.startswith(prefix):
                return text.removeprefix(prefix)
        return text
    return None


# ----------------------------------------------------------------------------------------------------
# Runs and scores


def with_values(run: RunSpec, values: Mapping[str, Any]) -> RunSpec:
    """``run`` with ``values`` (dotted key -> value) in its onboard overrides: a key the run already sets
    gets the new value in its place, the others are appended in ``values``' order."""
    merged = [(k, values[k] if k in values else v) for k, v in run.onboard]
    merged += [(k, v) for k, v in values.items() if k not in dict(run.onboard)]
    return dataclasses.replace(run, onboard=tuple(merged))


@dataclass(frozen=True)
class Score:
    """What a set of runs gave: the mean :func:`run_cost`, the fraction that succeeded, how many ran and how
    many raised (a bug)."""

    cost: float
    success_rate: float
    runs: int
    errors: int


def score(rows: Sequence[Mapping[str, Any]]) -> Score:
    """The :class:`Score` of result rows (``results.COLUMNS``); no rows gives cost NaN."""
    n = len(rows)
    if not n:
        return Score(math.nan, math.nan, 0, 0)
    cost = sum(run_cost(dict(r)) for r in rows) / n
    ok = sum(1 for r in rows if r.get("success") and not r.get("error"))
    errors = sum(1 for r in rows if r.get("error"))
    return Score(cost, ok / n, n, errors)


def trial_check(
    runs: Sequence[RunSpec], accepts: Callable[[Sequence[str]], str | None]
) -> Callable[[Mapping[str, Any]], str | None]:
    """The judge of a trial's values before they fly: ``check(values)`` is ``None`` if the onboard takes them
    with the overrides of every run (``accepts``, e.g. :func:`onboard_accepts`, once per distinct set of
    overrides of the runs), else the first problem (``RUN_ID: problem``): a sampled combination may break a
    rule across keys that each end of the ranges kept."""
    firsts: dict[tuple[tuple[str, Any], ...], RunSpec] = {}
    for run in runs:
        firsts.setdefault(tuple((k, json.dumps(v)) for k, v in run.onboard), run)

    def check(values: Mapping[str, Any]) -> str | None:
        for run in firsts.values():
            problem = accepts(with_values(run, values).onboard_sets())
            if problem is not None:
                return problem if not run.onboard else f"with the overrides of {run.run_id}: {problem}"
        return None

    return check


def runs_fingerprint(runs: Sequence[RunSpec]) -> str:
    """A short hash of the runs (their full specs): a study is resumed only over the same training runs."""
    text = json.dumps([r.to_dict() for r in runs], sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _seeds_text(seeds: Sequence[int]) -> str:
    if len(seeds) <= 6:
        return ", ".join(map(str, seeds))
    return f"{seeds[0]} ... {seeds[-1]} ({len(seeds)} seeds)"


def holdout_clash(train: CampaignSpec, held: CampaignSpec) -> str | None:
    """``None``, or the problem when a held-out noise seed is also a training one (the offset moved a seed of
    the spec onto another of its seeds)."""
    train_seeds = {r.seed for r in train.runs}
    same = sorted({r.seed for r in held.runs} & train_seeds)
    if not same:
        return None
    return (
        f"held-out seed {_seeds_text(same)} would also be a training seed (the spec's seeds: "
        f"{_seeds_text(sorted(train_seeds))}): give another offset"
    )


def holdout_description(train: CampaignSpec, held: CampaignSpec, offset: int) -> str:
    """What the held-out runs are, in words: every noise seed + ``offset``, the random missions drawn with
    their seed + ``offset``, the listed missions the same (for a spec of listed missions only: the same
    missions with other noise)."""
    seeds = sorted({r.seed for r in train.runs})
    text = (
        f"the spec's {_plural(len(train.runs), 'run')} with every noise seed + {offset} "
        f"(seeds {_seeds_text(seeds)} -> {_seeds_text([s + offset for s in seeds])})"
    )
    train_missions = list(dict.fromkeys(r.mission for r in train.runs))
    held_missions = set(r.mission for r in held.runs)
    kept = sum(1 for m in train_missions if m in held_missions)
    redrawn = len(train_missions) - kept
    if not redrawn:
        return text + "; the same missions (the spec lists them all), so other noise only"
    text += f" and the random missions drawn with random_missions.seed + {offset} (other missions)"
    return text + (f"; the {_plural(kept, 'listed mission')} the same" if kept else "")


# ----------------------------------------------------------------------------------------------------
# The study


def tpe_startup_trials(n_trials: int) -> int:
    """Random trials (the baseline included) before TPE models the results: a quarter, in [2, 10]."""
    return max(2, min(10, n_trials // 4))


def make_sampler(name: str, params: Sequence[Param], seed: int, n_trials: int) -> optuna.samplers.BaseSampler:
    """The seeded sampler ``tpe`` (multivariate) or ``cmaes`` (its mean starts at the centre of the ranges:
    the baseline for default ranges; needs the ``cmaes`` package, raises ImportError without it)."""
    import optuna

    if name == "cmaes":
        import cmaes  # noqa: F401  (optuna would only fail at the second trial)

        return optuna.samplers.CmaEsSampler(seed=seed, warn_independent_sampling=False)
    return optuna.samplers.TPESampler(
        seed=seed, n_startup_trials=tpe_startup_trials(n_trials), multivariate=True
    )


def study_attrs(
    params: Sequence[Param], train: Sequence[RunSpec], sampler: str = "tpe", seed: int = 0
) -> dict[str, Any]:
    """What a resumed study must match: the parameters with their ranges, the training runs, the sampler's
    name and ``--seed``."""
    return {
        "params": [p.to_dict() for p in params],
        "train_runs": runs_fingerprint(train),
        "sampler": sampler,
        "seed": seed,
    }


def resume_seed(seed: int, n_trials_in_study: int) -> int:
    """The sampler's seed for a session that finds ``n_trials_in_study`` trials (any state) in the study:
    ``seed`` + that. A fresh study gets ``seed`` itself; a resumed one a seed of its own, so the sampler does
    not draw its first points again (and the same commands still give the same study)."""
    return seed + n_trials_in_study


_REFUSALS = {
    "params": "was run over other parameters or ranges",
    "train_runs": "was run over other training runs (the spec changed)",
}


def open_study(
    storage: str | optuna.storages.BaseStorage,
    name: str,
    attrs: Mapping[str, Any],
    sampler: Callable[[int], optuna.samplers.BaseSampler],
) -> optuna.Study:
    """Create or load the study ``name`` in ``storage`` (minimise). ``attrs`` (:func:`study_attrs`) are
    stored in a new study; a loaded one must have the same, else :class:`ParamError` (one line; a key it
    lacks, from an older tune, is taken as given). The study's sampler is ``sampler(seed)`` with the seed
    :func:`resume_seed` of ``attrs["seed"]`` and the trials already there."""
    import optuna

    placeholder = optuna.samplers.RandomSampler(seed=0)  # replaced below, once the trials are counted
    study = optuna.create_study(
        storage=storage, study_name=name, sampler=placeholder, direction="minimize", load_if_exists=True
    )
    old = study.user_attrs
    for k, v in attrs.items():
        if k not in old:
            study.set_user_attr(k, v)
        elif json.loads(json.dumps(old[k])) != json.loads(json.dumps(v)):
            what, hint = _REFUSALS.get(k), "use another --out"
            if what is None:
                what, hint = f"was made with --{k} {old[k]}, not {v}", f"give --{k} {old[k]} or another --out"
            raise ParamError(f"{storage}: study {name!r} {what}: {hint}")
    study.sampler = sampler(resume_seed(int(attrs.get("seed", 0)), len(study.get_trials(deepcopy=False))))
    return study


def complete_trials(study: optuna.Study) -> list[optuna.trial.FrozenTrial]:
    from optuna.trial import TrialState

    return study.get_trials(deepcopy=False, states=(TrialState.COMPLETE,))


def ensure_baseline(study: optuna.Study, params: Sequence[Param]) -> None:
    """Enqueue the current values (marked ``baseline``) unless a finished or waiting trial has them, or the
    onboard refused them (a pruned baseline: they would be refused again)."""
    from optuna.trial import TrialState

    states = (TrialState.COMPLETE, TrialState.WAITING, TrialState.PRUNED)
    for t in study.get_trials(deepcopy=False, states=states):
        if t.user_attrs.get(BASELINE_ATTR):
            return
    study.enqueue_trial({p.key: p.baseline for p in params}, user_attrs={BASELINE_ATTR: True})


def suggest(trial: optuna.Trial, params: Sequence[Param]) -> dict[str, float]:
    """The trial's values to fly: sampled in each range, rounded (:func:`round_sig`); the baseline exact."""
    import warnings

    exact = bool(trial.user_attrs.get(BASELINE_ATTR))
    values: dict[str, float] = {}
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Fixed parameter")  # a baseline outside a given range
        for p in params:
            x = trial.suggest_float(p.key, p.low, p.high)
            values[p.key] = float(x) if exact else round_sig(float(x))
    return values


def run_trials(
    study: optuna.Study,
    params: Sequence[Param],
    evaluate: Callable[[dict[str, float]], Score],
    n_trials: int,
    *,
    stop: Callable[[], bool] = lambda: False,
    on_trial: Callable[[optuna.trial.FrozenTrial], None] | None = None,
    check: Callable[[Mapping[str, Any]], str | None] | None = None,
) -> bool:
    """Run trials one after the other until ``n_trials`` are finished in the study (the baseline first, see
    :func:`ensure_baseline`) or ``stop()`` says so after a trial. ``evaluate(values)`` flies one trial.
    A KeyboardInterrupt in it (or any exception once ``stop()`` is true) marks that trial failed and ends
    the loop. Returns True if interrupted (stopped or KeyboardInterrupt) before ``n_trials``.

    ``check(values)`` (:func:`trial_check`) judges the values before they fly: a problem makes the trial
    PRUNED with the problem in its ``refused`` user attribute (optuna's samplers then steer away from it),
    not flown and not counted; :data:`MAX_REFUSED_IN_A_ROW` of them in a row raise :class:`TooManyRefused`.
    """
    from optuna.trial import TrialState

    ensure_baseline(study, params)
    refused_in_a_row = 0
    while len(complete_trials(study)) < n_trials:
        if stop():
            return True
        trial = study.ask()
        values = suggest(trial, params)
        trial.set_user_attr("values", values)
        problem = None if check is None else check(values)
        if problem is not None:
            trial.set_user_attr(REFUSED_ATTR, problem)
            study.tell(trial, state=TrialState.PRUNED)
            refused_in_a_row += 1
            if refused_in_a_row >= MAX_REFUSED_IN_A_ROW:
                raise TooManyRefused(
                    f"{refused_in_a_row} sampled combinations in a row were refused by the onboard "
                    f"(the last: {problem}): narrow the --params ranges"
                )
            continue
        refused_in_a_row = 0
        try:
            result = evaluate(values)
        except KeyboardInterrupt:
            study.tell(trial, state=TrialState.FAIL)
            return True
        except Exception:
            study.tell(trial, state=TrialState.FAIL)
            if stop():  # e.g. a worker killed by the same Ctrl-C
                return True
            raise
        for name, value in (("success_rate", result.success_rate), ("runs", result.runs),
                            ("errors", result.errors)):  # fmt: skip
            trial.set_user_attr(name, value)
        frozen = study.tell(trial, result.cost)
        if on_trial is not None:
            on_trial(frozen)
    return False


def trial_values(trial: optuna.trial.FrozenTrial) -> dict[str, float]:
    """The values a trial flew (its params for a trial that did not finish)."""
    values = trial.user_attrs.get("values")
    return dict(values) if isinstance(values, dict) else {k: float(v) for k, v in trial.params.items()}


def baseline_trial(study: optuna.Study) -> optuna.trial.FrozenTrial | None:
    for t in complete_trials(study):
        if t.user_attrs.get(BASELINE_ATTR):
            return t
    return None


def best_trial(study: optuna.Study) -> optuna.trial.FrozenTrial | None:
    """The finished trial of least cost (the earliest among equals: the baseline wins a tie)."""
    done = complete_trials(study)
    return min(
        done, key=lambda t: (float(t.value if t.value is not None else math.inf), t.number), default=None
    )


# ----------------------------------------------------------------------------------------------------
# Products


def refused_trials(study: optuna.Study) -> list[optuna.trial.FrozenTrial]:
    """The trials the onboard refused before they flew (PRUNED, with the problem in ``refused``)."""
    from optuna.trial import TrialState

    pruned = study.get_trials(deepcopy=False, states=(TrialState.PRUNED,))
    return [t for t in pruned if REFUSED_ATTR in t.user_attrs]


def trial_rows(trials: Sequence[optuna.trial.FrozenTrial], keys: Sequence[str]) -> list[dict[str, Any]]:
    """One row per trial for ``trials.csv``: number, state, cost, success_rate, runs, errors, baseline, the
    onboard's problem with a refused (PRUNED) trial, and one column per key (the values flown, or sampled
    for a refused trial)."""
    rows = []
    for t in trials:
        values = trial_values(t)
        row: dict[str, Any] = {
            "number": t.number,
            "state": t.state.name,
            "cost": t.value,
            "success_rate": t.user_attrs.get("success_rate"),
            "runs": t.user_attrs.get("runs"),
            "errors": t.user_attrs.get("errors"),
            "baseline": bool(t.user_attrs.get(BASELINE_ATTR)),
            "refused": t.user_attrs.get(REFUSED_ATTR),
        }
        row.update({k: values.get(k) for k in keys})
        rows.append(row)
    return rows


def write_trials_csv(rows: Sequence[Mapping[str, Any]], keys: Sequence[str], path: Path) -> None:
    columns = ["number", "state", "cost", "success_rate", "runs", "errors", "baseline", "refused", *keys]
    with path.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=columns)
        writer.writeheader()
        for row in rows:
            writer.writerow({c: "" if row.get(c) is None else row.get(c) for c in columns})


def outcome(trial: optuna.trial.FrozenTrial, holdout: Score | None) -> dict[str, Any]:
    """The tune.json entry of a trial: values, train cost / success rate / runs / errors, held-out ditto
    (None when the held-out evaluation was skipped)."""
    return {
        "trial": trial.number,
        "values": trial_values(trial),
        "train_cost": trial.value,
        "train_success_rate": trial.user_attrs.get("success_rate"),
        "train_runs": trial.user_attrs.get("runs"),
        "train_errors": trial.user_attrs.get("errors"),
        "holdout_cost": None if holdout is None else holdout.cost,
        "holdout_success_rate": None if holdout is None else holdout.success_rate,
        "holdout_runs": None if holdout is None else holdout.runs,
        "holdout_errors": None if holdout is None else holdout.errors,
    }


def _num(value: Any, fmt: str = ".4f") -> str:
    return "-" if value is None else format(value, fmt)


def _pct(value: Any) -> str:
    return "-" if value is None else f"{100.0 * value:.1f} %"


def results_lines(doc: Mapping[str, Any]) -> list[str]:
    """The train vs held-out table of baseline and best (plain text, for the summary and best.toml)."""
    lines = [
        f"{'':<16}{'train cost':>11}{'success':>10}{'runs':>6}   {'held-out':>9}{'success':>10}{'runs':>6}"
    ]
    for label in ("baseline", "best"):
        o = doc.get(label)
        if not o:
            continue
        name = f"{label} (#{o['trial']})"
        lines.append(
            f"{name:<16}{_num(o['train_cost']):>11}{_pct(o['train_success_rate']):>10}"
            f"{_num(o['train_runs'], 'd'):>6}   {_num(o['holdout_cost']):>9}"
            f"{_pct(o['holdout_success_rate']):>10}{_num(o['holdout_runs'], 'd'):>6}"
        )
    return lines


def best_toml(values: Mapping[str, Any], header: Sequence[str] = ()) -> str:
    """The values (dotted key -> number) as an ``onboard.toml`` snippet: each key under its table (tables
    in first-seen order), after ``header`` as ``#`` comment lines."""
    tables: dict[str, list[tuple[str, Any]]] = {}
    for key, value in values.items():
        table, _, leaf = key.rpartition(".")
        tables.setdefault(table, []).append((leaf, value))
    out = [f"# {line}".rstrip() for line in header]
    for table, items in tables.items():
        if out:
            out.append("")
        out.append(f"[{table}]")
        out += [f"{leaf} = {json.dumps(value)}" for leaf, value in items]
    return "\n".join(out) + "\n"


def best_header(doc: Mapping[str, Any]) -> list[str]:
    """The comment header of best.toml: where it comes from, train vs held-out, the ``--set`` lines."""
    best, base = doc.get("best") or {}, doc.get("baseline") or {}
    lines = [
        f"auv-hil tune: study {doc['study']!r} over {doc['spec']} "
        f"({_plural(doc['trials']['complete'], 'trial')}, sampler {doc['sampler']}, seed {doc['seed']})",
        "cost = mean run_cost per run (auv_campaign.results.run_cost: 10 per failure + final error m",
        "+ RMS cross-track m + 0.1 x control effort rad; lower is better);",
        *textwrap.wrap(f"held-out = {doc['holdout']['description']}", 100),
        "",
        *results_lines(doc),
        "",
        "merge these keys into onboard.toml (a file of its own as --config would drop every other",
        "packaged setting), or use the --set lines: the same as auv-onboard run arguments:",
        *(f"  --set {set_argument(k, v)}" for k, v in best.get("values", {}).items()),
    ]
    if base:
        lines.append("baseline: " + " ".join(set_argument(k, v) for k, v in base["values"].items()))
    return lines


def write_html(path: Path, doc: Mapping[str, Any], rows: Sequence[Mapping[str, Any]], snippet: str) -> None:
    """``tune.html``: cost per trial with the running best, value vs cost per parameter, the train vs
    held-out table of baseline and best, the snippet and every trial (inline PNGs, no outside file)."""
    from auv_campaign.report import CSS, html_table, html_text, new_figure, png_img

    def num(value: Any) -> str:  # a setting's value, in full (up to 6 significant digits)
        return html_text(None) if value is None else html.escape(f"{value:g}")

    keys = [p["key"] for p in doc["params"]]
    done = [r for r in rows if r["state"] == "COMPLETE" and r["cost"] is not None]
    fig = new_figure(6.0, 3.2)
    ax = fig.add_subplot()
    if done:
        xs, ys = [r["number"] for r in done], [float(r["cost"]) for r in done]
        ax.plot(xs, ys, "o", ms=4, color="tab:blue", label="trial")
        best = list(itertools.accumulate(ys, min))
        ax.step(xs, best, where="post", color="tab:green", label="running best")
        base = doc.get("baseline")
        if base and base.get("train_cost") is not None:
            ax.axhline(base["train_cost"], color="grey", ls="--", lw=1, label="baseline")
        held = [(o["trial"], o["holdout_cost"]) for o in (doc.get("baseline"), doc.get("best"))
                if o and o.get("holdout_cost") is not None]  # fmt: skip
        if held:
            ax.plot(*zip(*held, strict=True), "D", ms=6, mfc="none", color="tab:red", label="held-out")
        if max(ys) > 20.0 * max(min(ys), 1e-9):
            ax.set_yscale("log")
        ax.legend(fontsize=8)
    from matplotlib.ticker import MaxNLocator

    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_xlabel("trial")
    ax.set_ylabel("train cost (mean run_cost)")
    figs = [png_img(fig, "cost per trial")]
    for key in keys:
        fig = new_figure(3.2, 3.2)
        ax = fig.add_subplot()
        pts = [(r[key], float(r["cost"])) for r in done if r.get(key) is not None]
        if pts:
            ax.plot([p[0] for p in pts], [p[1] for p in pts], "o", ms=4, color="tab:blue")
        for label, color in (("baseline", "grey"), ("best", "tab:green")):
            o = doc.get(label)
            if o and key in o["values"]:
                ax.axvline(o["values"][key], color=color, ls="--", lw=1, label=label)
        ax.set_xlabel(key)
        ax.set_ylabel("train cost")
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=8)
        figs.append(png_img(fig, key))

    table_rows = []
    for label in ("baseline", "best"):
        o = doc.get(label)
        if o:
            table_rows.append(
                [
                    html.escape(f"{label} (#{o['trial']})"),
                    *(num(o["values"].get(k)) for k in keys),
                    html_text(o["train_cost"]),
                    html_text(_pct(o["train_success_rate"])),
                    html_text(o["holdout_cost"]),
                    html_text(_pct(o["holdout_success_rate"])),
                ]
            )
    results = html_table(
        ["", *keys, "train cost", "train success", "held-out cost", "held-out success"], table_rows
    )
    ranges = html_table(
        ["key", "low", "high", "baseline"],
        ([html.escape(p["key"]), num(p["low"]), num(p["high"]), num(p["baseline"])] for p in doc["params"]),
    )
    trials = html_table(
        ["trial", "state", "cost", "success", *keys],
        (
            [
                html_text(r["number"]) + (" (baseline)" if r["baseline"] else ""),
                html_text(r["state"]) + (f" (refused: {html.escape(r['refused'])})" if r["refused"] else ""),
                html_text(r["cost"]),
                html_text(_pct(r["success_rate"])),
                *(num(r.get(k)) for k in keys),
            ]
            for r in rows
        ),
    )
    n_train = (doc.get("baseline") or {}).get("train_runs")
    n_hold = doc["holdout"]["runs"]
    n_refused = doc["trials"].get("refused", 0)
    refused = f" ({_plural(n_refused, 'more trial')} refused by the onboard, not flown)" if n_refused else ""
    intro = (
        f"{html.escape(doc['spec'])}: {doc['trials']['complete']} finished trials (sampler "
        f"{html.escape(doc['sampler'])}, seed {doc['seed']}), {_plural(n_train or 0, 'training run')} "
        f"a trial{refused}; held-out: {_plural(n_hold, 'run')}, "
        f"{html.escape(doc['holdout']['description'])}. Cost: mean run_cost (10 per failure + final error "
        "m + RMS cross-track m + 0.1 x control effort rad); lower is better."
        + (" <b>Interrupted.</b>" if doc.get("interrupted") else "")
    )
    title = html.escape(doc["study"])
    page = f"""<!DOCTYPE html>
<html><head><meta charset="utf-8"><title>tune {title}</title>
<style>{CSS}</style></head><body>
<h1>Tuning {title}</h1>
<p>{intro}</p>
<h2>Baseline and best</h2>
{results}
<div class="figs">{"".join(figs)}</div>
<h2>best.toml</h2>
<pre>{html.escape(snippet)}</pre>
<h2>Ranges</h2>
{ranges}
<h2>Trials</h2>
{trials}
</body></html>
"""
    path.write_text(page, encoding="utf-8")


def build_doc(
    spec: CampaignSpec,
    held: CampaignSpec,
    study: optuna.Study,
    params: Sequence[Param],
    args: argparse.Namespace,
    holdout: Mapping[int, Score],
    interrupted: bool,
    out: Path,
) -> dict[str, Any]:
    """The content of tune.json."""
    from optuna.trial import TrialState

    trials = study.get_trials(deepcopy=False)
    base, best = baseline_trial(study), best_trial(study)
    return {
        "spec": spec.path,
        "study": study.study_name,
        "storage": str(out / "study.db"),
        "sampler": args.sampler,
        "seed": args.seed,
        "holdout_seed_offset": args.holdout_seed_offset,
        "holdout": {
            "seed_offset": args.holdout_seed_offset,
            "description": holdout_description(spec, held, args.holdout_seed_offset),
            "runs": len(held.runs),
        },
        "params": [p.to_dict() for p in params],
        "trials": {
            "requested": args.trials,
            "complete": sum(1 for t in trials if t.state == TrialState.COMPLETE),
            "failed": sum(1 for t in trials if t.state == TrialState.FAIL),
            "refused": len(refused_trials(study)),
        },
        "baseline": None if base is None else outcome(base, holdout.get(base.number)),
        "best": None if best is None else outcome(best, holdout.get(best.number)),
        "interrupted": interrupted,
        "files": {name: str(out / name) for name in FILES},
    }


def write_outputs(out: Path, doc: dict[str, Any], study: optuna.Study, keys: Sequence[str]) -> None:
    rows = trial_rows(study.get_trials(deepcopy=False), keys)
    write_trials_csv(rows, keys, out / "trials.csv")
    snippet = ""
    if doc.get("best"):
        snippet = best_toml(doc["best"]["values"], best_header(doc))
        (out / "best.toml").write_text(snippet)
    else:
        doc["files"].pop("best.toml", None)
    (out / "tune.json").write_text(json.dumps(doc, indent=2, allow_nan=False))
    write_html(out / "tune.html", doc, rows, snippet)


# ----------------------------------------------------------------------------------------------------
# The command


class _TrialBar:
    """A rich progress bar over the trials (best cost so far) with the current trial's runs below it."""

    def __init__(self, total: int | None, done: int, runs: int, title: str, enabled: bool) -> None:
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            Progress,
            TextColumn,
            TimeElapsedColumn,
            TimeRemainingColumn,
        )

        self.progress = Progress(
            TextColumn("[bold]{task.description}"),
            BarColumn(),
            MofNCompleteColumn(),
            TextColumn("{task.fields[info]}"),
            TimeElapsedColumn(),
            TimeRemainingColumn(),
            disable=not enabled,
        )
        self.trials = None
        if total is not None:
            self.trials = self.progress.add_task(
                f"{title} trials", total=total, completed=min(done, total), info=""
            )
        self.runs = self.progress.add_task("  runs" if total is not None else title, total=runs, info="")

    def __enter__(self) -> _TrialBar:
        self.progress.__enter__()
        return self

    def __exit__(self, *exc: object) -> None:
        self.progress.__exit__(None, None, None)

    def start_trial(self, runs: int) -> None:
        self.progress.reset(self.runs, total=runs, info="")

    def run_done(self, record: dict[str, Any]) -> None:
        self.progress.update(self.runs, advance=1)

    def trial_done(self, best: float | None, last: float | None) -> None:
        info = f"best [green]{best:.4f}[/] last {last:.4f}" if best is not None and last is not None else ""
        if self.trials is not None:
            self.progress.update(self.trials, advance=1, info=info)


class _StopFlag:
    """SIGINT while the trials run: the first asks to stop after the current trial, the second stops now."""

    def __init__(self) -> None:
        self.presses = 0

    def __call__(self) -> bool:
        return self.presses > 0

    def handler(self, signum: int, frame: FrameType | None) -> None:
        self.presses += 1
        if self.presses > 1:
            raise KeyboardInterrupt
        print(f"{PROG}: stopping after the current trial (Ctrl-C again: now)", file=sys.stderr)  # noqa: T201


@contextlib.contextmanager
def _sigint(handler: Callable[[int, FrameType | None], None]) -> Iterator[None]:
    old = signal.signal(signal.SIGINT, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)


def tune_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog=PROG,
        description=(
            "Tune onboard settings with optuna: each trial flies every run of the spec with the trial's "
            "values as onboard overrides and costs the mean run_cost; trial 0 is the current values. The "
            "baseline and the best are then flown on held-out runs (noise seeds + the offset, random "
            "missions redrawn; listed missions the same). Writes DIR/best.toml, "
            "DIR/trials.csv, DIR/tune.json, DIR/tune.html; the study is DIR/study.db (the same command "
            "resumes it)."
        ),
        epilog=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("spec", help="the campaign spec (YAML): the training runs")
    p.add_argument(
        "--params",
        required=True,
        metavar="KEY[=LO:HI],...",
        help="dotted onboard.toml keys to tune, e.g. control.improved.Kp5 (range: current x [0.5, 1.5]) "
        "or control.improved.Kp5=-1:-0.2",
    )
    p.add_argument("--trials", type=int, required=True, help="finished trials wanted, the baseline included")
    p.add_argument("--out", required=True, help="the output directory (created; its study.db is resumed)")
    add_executor_args(p)
    p.add_argument("--sampler", choices=SAMPLERS, default="tpe", help="optuna sampler (default: tpe)")
    p.add_argument(
        "--seed",
        type=int,
        default=0,
        help="the sampler's seed (default: 0); a resumed study seeds it with this + its trials so far",
    )
    p.add_argument(
        "--holdout-seed-offset",
        type=int,
        default=DEFAULT_HOLDOUT_OFFSET,
        help="held-out runs: the spec's runs with every noise seed + this and the random missions drawn "
        "with random_missions.seed + this (a spec of listed missions only: the same missions, other "
        "noise); no held-out seed may be a training seed "
        f"(default: {DEFAULT_HOLDOUT_OFFSET})",
    )
    p.add_argument("--json", action="store_true", help="print tune.json as one JSON object")
    return p


def tune_main(argv: list[str]) -> int:
    """``auv-hil tune``; returns the exit code."""
    args = tune_parser().parse_args(argv)
    from auv_campaign.spec import load_spec

    if args.workers < 1:
        return fail(PROG, f"--workers must be >= 1, got {args.workers}")
    if args.trials < 1:
        return fail(PROG, f"--trials must be >= 1, got {args.trials}")
    if args.holdout_seed_offset == 0:
        return fail(PROG, "--holdout-seed-offset 0 would make the held-out runs the training runs")
    try:
        entries = parse_params(args.params)
    except ParamError as exc:
        return fail(PROG, f"--params {exc}")
    try:
        train = load_spec(args.spec)
        held = load_spec(args.spec, seed_offset=args.holdout_seed_offset,
                         random_seed_offset=args.holdout_seed_offset)  # fmt: skip
    except (ConfigError, OSError) as exc:
        return fail(PROG, str(exc))
    clash = holdout_clash(train, held)
    if clash is not None:
        return fail(PROG, f"--holdout-seed-offset {args.holdout_seed_offset}: {clash}")
    from onboard.app.runtime import build_config

    try:
        params = resolve_params(entries, build_config(None, []), onboard_accepts)
    except ParamError as exc:
        return fail(PROG, f"--params {exc}")
    if args.sampler == "cmaes":
        try:
            import cmaes  # noqa: F401
        except ImportError:
            return fail(PROG, "--sampler cmaes needs the cmaes package (pip install cmaes)")
        if len(params) < 2:
            print(f"{PROG}: note: CMA-ES needs >= 2 parameters; with one, optuna samples it at random",  # noqa: T201
                  file=sys.stderr)  # fmt: skip
    for p in params:
        if not p.low <= p.baseline <= p.high:
            print(f"{PROG}: note: {p.key}: the current value {p.baseline:g} is outside {p.low:g}:{p.high:g} "  # noqa: T201
                  "(trial 0 flies it all the same)", file=sys.stderr)  # fmt: skip

    import optuna

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    out = Path(args.out)
    problem = usable_out_dir(out)
    if problem:
        return fail(PROG, problem)
    storage = f"sqlite:///{(out / 'study.db').resolve()}"
    attrs = study_attrs(params, train.runs, args.sampler, args.seed)
    try:
        study = open_study(
            storage, train.name, attrs, lambda seed: make_sampler(args.sampler, params, seed, args.trials)
        )
    except ParamError as exc:
        return fail(PROG, str(exc).replace(storage, str(out / "study.db")))
    from auv_campaign.execute import ExecutorError

    try:
        return _tune(study, train, held, params, args, out)
    except ExecutorError as exc:
        return fail(PROG, str(exc), EXIT_RUN_ERROR)


def _tune(
    study: optuna.Study,
    train: CampaignSpec,
    held: CampaignSpec,
    params: Sequence[Param],
    args: argparse.Namespace,
    out: Path,
) -> int:
    from auv_campaign import execute as ex

    executor = ex.Executor("ray" if args.ray is not None else "local", args.workers, args.ray or None)
    execute = ex.execute
    show = not args.no_progress and not args.json
    t0 = time.monotonic()
    stop = _StopFlag()
    done = len(complete_trials(study))
    check = trial_check(train.runs, onboard_accepts)
    gave_up: str | None = None
    # One Ray session for all the trials (else every trial would start and stop its own).
    session = ex.ray_session(executor.workers, executor.address) if executor.kind == "ray" else None
    with session or contextlib.nullcontext():
        with _TrialBar(args.trials, done, len(train.runs), train.name, show) as bar:

            def evaluate(values: dict[str, float]) -> Score:
                bar.start_trial(len(train.runs))
                records = execute([with_values(r, values) for r in train.runs], None, executor, bar.run_done)
                return score([r["row"] for r in records])

            def on_trial(trial: optuna.trial.FrozenTrial) -> None:
                best = best_trial(study)
                bar.trial_done(None if best is None else best.value, trial.value)

            with _sigint(stop.handler):
                try:
                    interrupted = run_trials(
                        study, params, evaluate, args.trials, stop=stop, on_trial=on_trial, check=check
                    )
                except TooManyRefused as exc:
                    interrupted, gave_up = False, str(exc)

        # Held-out: the baseline and the best, in one batch (run ids prefixed so they do not collide).
        holdout: dict[int, Score] = {}
        chosen = [t for t in (baseline_trial(study), best_trial(study)) if t is not None]
        chosen = list({t.number: t for t in chosen}.values())
        if chosen and stop.presses > 1:
            print(f"{PROG}: held-out evaluation skipped", file=sys.stderr)  # noqa: T201
        elif chosen:
            runs = [dataclasses.replace(with_values(r, trial_values(t)), run_id=f"t{t.number}-{r.run_id}")
                    for t in chosen for r in held.runs]  # fmt: skip
            if interrupted:
                print(f"{PROG}: flying the held-out runs (Ctrl-C to skip)", file=sys.stderr)  # noqa: T201
            try:
                with _TrialBar(None, 0, len(runs), f"{train.name} held-out runs", show) as hbar:
                    records = execute(runs, None, executor, hbar.run_done)
                by_id = {r["run_id"]: r["row"] for r in records}
                for t in chosen:
                    holdout[t.number] = score([by_id[f"t{t.number}-{r.run_id}"] for r in held.runs])
            except KeyboardInterrupt:
                interrupted = True
                print(f"{PROG}: held-out evaluation skipped", file=sys.stderr)  # noqa: T201

    doc = build_doc(train, held, study, params, args, holdout, interrupted, out)
    doc["wall_time_s"] = round(time.monotonic() - t0, 2)
    doc["executor"] = executor.describe()
    write_outputs(out, doc, study, [p.key for p in params])
    if args.json:
        print(json.dumps(doc))  # noqa: T201
    else:
        for line in summary_lines(doc):
            print(line)  # noqa: T201
    errors = sum(int(t.user_attrs.get("errors") or 0) for t in complete_trials(study))
    errors += sum(s.errors for s in holdout.values())
    if interrupted:
        print(f"{PROG}: interrupted: {doc['trials']['complete']} of {args.trials} trials finished; "  # noqa: T201
              "the same command resumes", file=sys.stderr)  # fmt: skip
        return EXIT_INTERRUPTED
    if errors:
        print(f"{PROG}: some runs raised (a bug, costed as failures): see the errors column of trials.csv",  # noqa: T201
              file=sys.stderr)  # fmt: skip
        return EXIT_RUN_ERROR
    if gave_up is not None:
        return fail(PROG, gave_up)
    return EXIT_OK


def _plural(n: int, word: str) -> str:
    return f"{n} {word}{'' if n == 1 else 's'}"


def summary_lines(doc: Mapping[str, Any]) -> list[str]:
    """The printed summary: what ran, train vs held-out of baseline and best, the best values, the files."""
    refused = doc["trials"].get("refused", 0)
    lines = [
        f"{doc['study']}: {_plural(doc['trials']['complete'], 'trial')} ({doc['sampler']}, "
        f"seed {doc['seed']}) in {doc.get('wall_time_s', 0):.1f} s on {doc.get('executor', '?')}"
        + (f"; {refused} more refused by the onboard (not flown)" if refused else ""),
        f"held-out: {doc['holdout']['description']}",
        *results_lines(doc),
    ]
    best = doc.get("best")
    if best:
        lines.append("best: " + " ".join(f"--set {set_argument(k, v)}" for k, v in best["values"].items()))
    lines.append("files: " + " ".join(doc["files"].values()))
    return lines


__all__ = [
    "DEFAULT_FACTORS",
    "MAX_REFUSED_IN_A_ROW",
    "SIGNIFICANT_DIGITS",
    "ZERO_SCALE",
    "Param",
    "ParamError",
    "Score",
    "TooManyRefused",
    "best_toml",
    "config_value",
    "default_range",
    "holdout_description",
    "parse_params",
    "resolve_params",
    "resume_seed",
    "round_sig",
    "run_trials",
    "score",
    "trial_check",
    "tune_main",
    "with_values",
]
