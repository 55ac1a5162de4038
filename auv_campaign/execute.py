"""Running many runs: in local processes or as Ray tasks, with progress, resumption and Ctrl-C.

- Local (``--workers N``, default the machine's cores): a :class:`concurrent.futures.ProcessPoolExecutor`
  (``spawn``: every worker a fresh interpreter; workers ignore SIGINT, the parent handles Ctrl-C);
  ``--workers 1`` runs in this process.
- Ray (``--ray`` starts a local Ray with N CPUs; ``--ray ADDRESS`` joins a running cluster, shipping this
  repository's packages with the tasks so the nodes need only the dependencies): one Ray task per batch of
  runs. Scheduling, transport and retries are Ray's.

Locally each run is a task of its own; on Ray runs go out in batches (a few per worker: a task costs a
few ms). Each run is written as soon as its result is back, to ``OUT/runs/RUN_ID.json`` (a temporary
name, then renamed). Resumption skips a run whose file holds a complete record of the same run: the same
spec and the same fingerprint (:func:`fingerprint`: the effective onboard configuration, the vehicle model
and the code), so a changed gain in ``onboard.toml`` or a changed model re-flies it. Ctrl-C saves every
result already back (locally: the runs in flight finish first; on Ray: whole batches) and then stops. A
run is independent of every other and of the executor (its own bus channel, seeded noise, lock-step time),
so the same spec gives the same results whatever the executor and the number of workers.
"""

from __future__ import annotations

import concurrent.futures
import contextlib
import functools
import hashlib
import json
import logging
import math
import multiprocessing
import os
import signal
import socket
import traceback
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from auv_campaign.results import COLUMNS
from auv_campaign.spec import RunSpec


class ExecutorError(RuntimeError):
    """The executor could not start (e.g. no Ray cluster at the address given)."""


BATCHES_PER_WORKER = 4
MAX_BATCH = 16


def default_workers() -> int:
    """The machine's cores (the CPUs this process may run on)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def run_one(spec_dict: dict[str, Any]) -> dict[str, Any]:
    """Fly one run given as :meth:`RunSpec.to_dict`; its JSON record. An exception (a bug, not a miss) is
    caught and reported in the row's ``error`` column, so one bad run does not end the campaign."""
    from auv_campaign.metrics import base_row
    from auv_campaign.runner import fly

    quiet_vehicle_logs()
    spec = RunSpec.from_dict(spec_dict)
    try:
        record = fly(spec).to_json(spec)
        record["fingerprint"] = fingerprint(spec)
        return record
    except Exception as exc:
        row = base_row(spec)
        row["error"] = f"{type(exc).__name__}: {exc}"
        tb = traceback.format_exc(limit=6)
        return {"run_id": spec.run_id, "spec": spec_dict, "row": row, "track": {}, "path": [],
                "traceback": tb}  # fmt: skip


def fingerprint(spec: RunSpec) -> str:
    """What a run's result depends on beyond its spec: the effective onboard configuration (the packaged
    ``onboard.toml`` with the run's overrides), the vehicle model of its variant, and the code (every source
    and data file of onboard, hil_sim, auv_campaign and auv_common). A short hash."""
    return _fingerprint(tuple(spec.onboard_sets()), spec.vehicle_scale, spec.vehicle_set)


@functools.lru_cache(maxsize=256)
def _fingerprint(
    onboard_sets: tuple[str, ...], scale: tuple[tuple[str, float], ...], sets: tuple[tuple[str, Any], ...]
) -> str:
    from auv_campaign.runner import effective_onboard_config, vehicle_variant

    onboard, vehicle = effective_onboard_config(onboard_sets), vehicle_variant(scale, sets)
    text = "\n".join((_code_hash(), repr(onboard), repr(vehicle.config)))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


@functools.cache
def _code_hash() -> str:
    import auv_campaign
    import auv_common
    import hil_sim
    import onboard

    digest = hashlib.sha256()
    for package in (auv_campaign, auv_common, hil_sim, onboard):
        root = Path(str(package.__file__)).parent
        for path in sorted(root.rglob("*")):
            if path.suffix in (".py", ".toml", ".dbc", ".yaml") and "__pycache__" not in path.parts:
                digest.update(str(path.relative_to(root.parent)).encode())
                digest.update(path.read_bytes())
    return digest.hexdigest()


def run_batch(spec_dicts: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Fly a batch of runs in order (the unit of work of both executors)."""
    return [run_one(d) for d in spec_dicts]


def quiet_vehicle_logs() -> None:
    """No log of the onboard or the simulator reaches stderr during a campaign: what the vehicle said (a
    miss, a hold, a plan it could not make) is in each run's ``final_reason``, an exception in its ``error``
    column, and log lines would tear the progress bar. (``--only`` re-flies one run with its logs.)"""
    for name in ("onboard", "hil_sim", "can"):
        logging.getLogger(name).setLevel(logging.CRITICAL)


def _ignore_sigint() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def batches(items: Sequence[dict[str, Any]], workers: int) -> list[list[dict[str, Any]]]:
    """Split into batches of at most ``MAX_BATCH``, about ``BATCHES_PER_WORKER`` per worker."""
    size = max(1, min(MAX_BATCH, math.ceil(len(items) / max(1, workers * BATCHES_PER_WORKER))))
    return [list(items[i : i + size]) for i in range(0, len(items), size)]


# --- the store of finished runs ------------------------------------------------------------------------
def run_path(out_dir: Path, run_id: str) -> Path:
    return out_dir / "runs" / f"{run_id}.json"


def save_run(out_dir: Path, record: dict[str, Any]) -> None:
    path = run_path(out_dir, record["run_id"])
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(record, allow_nan=False, default=str))
    os.replace(tmp, path)


def finished(out_dir: Path, spec: RunSpec) -> dict[str, Any] | None:
    """The saved record of ``spec`` if it is complete and was flown with this very spec, configuration, model
    and code (:func:`fingerprint`), and did not raise; else None (fly it again)."""
    try:
        record = json.loads(run_path(out_dir, spec.run_id).read_text())
    except (OSError, ValueError):
        return None
    if not isinstance(record, dict):
        return None
    row = record.get("row")
    if (
        not isinstance(row, dict)
        or any(c not in row for c in COLUMNS)
        or row.get("run_id") != spec.run_id
        or row.get("error")
        or record.get("spec") != json.loads(json.dumps(spec.to_dict()))
        or record.get("fingerprint") != fingerprint(spec)
    ):
        return None
    return record


# --- executors -----------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Executor:
    """Where the runs go: ``kind`` local (``workers`` processes) or ray (``address`` None = a local Ray)."""

    kind: str = "local"
    workers: int = 1
    address: str | None = None

    def describe(self) -> str:
        if self.kind == "ray":
            return f"ray ({self.address or f'local, {self.workers} CPUs'})"
        return f"{self.workers} local process{'es' if self.workers != 1 else ''}"


Deliver = Callable[[dict[str, Any]], None]


def _local(work: list[dict[str, Any]], workers: int, deliver: Deliver) -> None:
    """One task per run. On KeyboardInterrupt the runs in flight finish, every result back is delivered,
    then the interrupt goes on."""
    if workers <= 1:
        for item in work:
            deliver(run_one(item))
        return
    ctx = multiprocessing.get_context("spawn")
    pool = concurrent.futures.ProcessPoolExecutor(workers, mp_context=ctx, initializer=_ignore_sigint)
    futures = [pool.submit(run_one, item) for item in work]
    delivered: set[concurrent.futures.Future[dict[str, Any]]] = set()
    try:
        for fut in concurrent.futures.as_completed(futures):
            delivered.add(fut)
            deliver(fut.result())
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
        for fut in futures:
            if fut not in delivered and fut.done() and not fut.cancelled() and fut.exception() is None:
                deliver(fut.result())


def _check_reachable(address: str, timeout_s: float = 5.0) -> None:
    """Fail fast, with one line, when nothing listens at ``[ray://]HOST:PORT`` (Ray retries for minutes)."""
    bare = address.removeprefix("ray://")
    host, _, port = bare.rpartition(":")
    host = host.strip("[]")
    if bare in ("auto", "local") or not port.isdigit():
        return
    try:
        with socket.create_connection((host or "127.0.0.1", int(port)), timeout=timeout_s):
            pass
    except OSError as exc:
        raise ExecutorError(f"cannot join the Ray cluster at {address}: {exc.strerror or exc}") from exc


def ray_runtime_env() -> dict[str, Any]:
    """The packages a remote Ray node needs from this repository (its dependencies must be installed)."""
    import auv_campaign
    import auv_common
    import hil_sim
    import onboard

    packages = (auv_campaign, auv_common, hil_sim, onboard)
    return {"py_modules": [str(Path(str(p.__file__)).parent) for p in packages]}


@contextlib.contextmanager
def ray_session(workers: int, address: str | None) -> Iterator[None]:
    """Ray for the block: a local Ray of our own with ``workers`` CPUs (even beside a cluster on this
    machine), or the cluster at ``address`` (this repository's packages shipped with the tasks). Raises
    :class:`ExecutorError` with one line when it cannot start. Already initialised: used as it is."""
    import ray

    if ray.is_initialized():
        yield
        return
    if address:
        _check_reachable(address)
    try:
        if address:
            ray.init(address=address, runtime_env=ray_runtime_env(), log_to_driver=False)
        else:
            ray.init(address="local", num_cpus=workers, include_dashboard=False, log_to_driver=False)
    except Exception as exc:  # Ray's own errors span many lines: the operator gets one with the cause
        where = f"the Ray cluster at {address}" if address else "a local Ray"
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        hint = ""
        if "auth" in str(exc).lower() or "auth" in repr(exc.__cause__).lower():
            hint = " (the cluster uses token authentication: set RAY_AUTH_MODE=token and its token)"
        raise ExecutorError(f"cannot start {where}: {first}{hint}") from exc
    try:
        yield
    finally:
        ray.shutdown()


def _ray(work: list[list[dict[str, Any]]], workers: int, address: str | None, deliver: Deliver) -> None:
    """One Ray task per batch. On KeyboardInterrupt the batches already back are delivered, the others
    cancelled."""
    import ray

    with ray_session(workers, address):
        task = ray.remote(num_cpus=1)(run_batch)
        pending = [task.remote(b) for b in work]
        try:
            while pending:
                done, pending = ray.wait(pending, num_returns=1)
                for ref in done:
                    for record in ray.get(ref):
                        deliver(record)
        except KeyboardInterrupt:
            done, pending = ray.wait(pending, num_returns=len(pending), timeout=0)
            for ref in done:
                with contextlib.suppress(Exception):
                    for record in ray.get(ref):
                        deliver(record)
            raise
        finally:
            for ref in pending:
                ray.cancel(ref, force=True)


def execute(
    runs: Sequence[RunSpec],
    out_dir: Path | None,
    executor: Executor,
    on_record: Callable[[dict[str, Any]], None] | None = None,
) -> list[dict[str, Any]]:
    """Fly ``runs`` (those not already finished in ``out_dir``), saving each record as it comes back; return
    all records in the order of ``runs``. ``on_record`` is called for every record, resumed ones included
    (on Ctrl-C it has seen every record saved). KeyboardInterrupt propagates after the results back are
    saved."""
    records: dict[str, dict[str, Any]] = {}

    def deliver(record: dict[str, Any]) -> None:
        if out_dir is not None:
            save_run(out_dir, record)
        records[record["run_id"]] = record
        if on_record is not None:
            on_record(record)

    todo: list[dict[str, Any]] = []
    for spec in runs:
        old = finished(out_dir, spec) if out_dir is not None else None
        if old is not None:
            records[spec.run_id] = old
            if on_record is not None:
                on_record(old)
        else:
            todo.append(spec.to_dict())
    if executor.kind == "ray":
        _ray(batches(todo, executor.workers), executor.workers, executor.address, deliver)
    else:
        _local(todo, executor.workers, deliver)
    return [records[s.run_id] for s in runs if s.run_id in records]
