"""Running many runs: in local processes or as Ray tasks, with progress, resumption and Ctrl-C.

- Local (``--workers N``, default the machine's cores): a :class:`concurrent.futures.ProcessPoolExecutor`
  (``spawn``: every worker a fresh interpreter; workers ignore SIGINT, the parent handles Ctrl-C);
  ``--workers 1`` runs in this process.
- Ray (``--ray`` starts a local Ray with N CPUs; ``--ray ADDRESS`` joins a running cluster, shipping this
  repository's packages with the tasks so the nodes need only the dependencies): one Ray task per batch of
  runs. Scheduling, transport and retries are Ray's.

Runs go out in batches (a few per worker, so the progress bar moves and a lost worker costs little). Each
finished run is written at once to ``OUT/runs/RUN_ID.json`` (written to a temporary name, then renamed): a
run whose file exists with the same spec is skipped next time (resumption), and Ctrl-C keeps every finished
run. A run is independent of every other and of the executor (its own bus channel, seeded noise, lock-step
time), so the same spec gives the same results whatever the executor and the number of workers.
"""

from __future__ import annotations

import concurrent.futures
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
    from auv_campaign.runner import fly

    spec = RunSpec.from_dict(spec_dict)
    try:
        return fly(spec).to_json(spec)
    except Exception as exc:
        row: dict[str, Any] = {c: None for c in COLUMNS}
        row.update(
            run_id=spec.run_id,
            mission=spec.mission.name,
            seed=spec.seed,
            current_speed_mps=spec.current_speed_mps,
            current_dir_deg=spec.current_dir_deg,
            profile=spec.profile,
            onboard=spec.onboard_label,
            vehicle=spec.vehicle_label,
            planned=False,
            completed=False,
            success=False,
            false_complete=False,
            error=f"{type(exc).__name__}: {exc}",
        )
        tb = traceback.format_exc(limit=6)
        return {"run_id": spec.run_id, "spec": spec_dict, "row": row, "track": {}, "path": [],
                "traceback": tb}  # fmt: skip


def run_batch(spec_dicts: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Fly a batch of runs in order (the unit of work of both executors)."""
    quiet_vehicle_logs()
    return [run_one(d) for d in spec_dicts]


def quiet_vehicle_logs() -> None:
    """Only errors of the onboard and the simulator reach stderr during a campaign: what the vehicle said
    (a miss, a hold) is in each run's ``final_reason``, and warnings would tear the progress bar."""
    for name in ("onboard", "hil_sim", "can"):
        logging.getLogger(name).setLevel(logging.ERROR)


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
    tmp.write_text(json.dumps(record, allow_nan=False, default=_json_default))
    os.replace(tmp, path)


def _json_default(value: Any) -> Any:
    if isinstance(value, float):  # pragma: no cover - floats are native; numpy scalars come here
        return float(value)
    return str(value)


def finished(out_dir: Path, spec: RunSpec) -> dict[str, Any] | None:
    """The saved record of ``spec`` if it exists, reads, and was flown with this very spec (else None)."""
    path = run_path(out_dir, spec.run_id)
    try:
        record: dict[str, Any] = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    if record.get("spec") != json.loads(json.dumps(spec.to_dict())) or record.get("row", {}).get("error"):
        return None  # another spec under this id, or a run that raised: fly it again
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


def _local(work: list[list[dict[str, Any]]], workers: int) -> Iterator[list[dict[str, Any]]]:
    if workers <= 1:
        for batch in work:
            yield run_batch(batch)
        return
    ctx = multiprocessing.get_context("spawn")
    pool = concurrent.futures.ProcessPoolExecutor(workers, mp_context=ctx, initializer=_ignore_sigint)
    try:
        futures = [pool.submit(run_batch, b) for b in work]
        for fut in concurrent.futures.as_completed(futures):
            yield fut.result()
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


def _check_reachable(address: str, timeout_s: float = 5.0) -> None:
    """Fail fast, with one line, when nothing listens at ``HOST:PORT`` (Ray itself retries for minutes)."""
    host, _, port = address.rpartition(":")
    if address in ("auto", "local") or not port.isdigit():
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


Batches = list[list[dict[str, Any]]]


def _ray(work: Batches, workers: int, address: str | None) -> Iterator[list[dict[str, Any]]]:
    import ray

    started_here = not ray.is_initialized()
    if started_here:
        if address:
            _check_reachable(address)
        try:
            if address:
                ray.init(address=address, runtime_env=ray_runtime_env(), log_to_driver=False)
            else:  # a Ray of our own, even if a cluster runs on this machine
                ray.init(address="local", num_cpus=workers, include_dashboard=False, log_to_driver=False)
        except Exception as exc:  # Ray's own errors span many lines: the operator gets one with the cause
            where = f"the Ray cluster at {address}" if address else "a local Ray"
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            hint = ""
            if "auth" in str(exc).lower() or "auth" in repr(exc.__cause__).lower():
                hint = " (the cluster uses token authentication: set RAY_AUTH_MODE=token and its token)"
            raise ExecutorError(f"cannot start {where}: {first}{hint}") from exc
    task = ray.remote(num_cpus=1)(run_batch)
    pending = [task.remote(b) for b in work]
    try:
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            for ref in done:
                yield ray.get(ref)
    finally:
        for ref in pending:
            ray.cancel(ref, force=True)
        if started_here:
            ray.shutdown()


def execute(
    runs: Sequence[RunSpec],
    out_dir: Path | None,
    executor: Executor,
    on_record: Callable[[dict[str, Any]], None] | None = None,
) -> list[dict[str, Any]]:
    """Fly ``runs`` (those not already finished in ``out_dir``), saving each record as it comes; return all
    records in the order of ``runs``. ``on_record`` is called for every record, resumed ones included.
    KeyboardInterrupt propagates after the finished runs are saved."""
    records: dict[str, dict[str, Any]] = {}
    todo: list[dict[str, Any]] = []
    for spec in runs:
        old = finished(out_dir, spec) if out_dir is not None else None
        if old is not None:
            records[spec.run_id] = old
            if on_record is not None:
                on_record(old)
        else:
            todo.append(spec.to_dict())
    work = batches(todo, executor.workers)
    stream = (
        _ray(work, executor.workers, executor.address)
        if executor.kind == "ray"
        else _local(work, executor.workers)
    )
    for batch in stream:
        for record in batch:
            if out_dir is not None:
                save_run(out_dir, record)
            records[record["run_id"]] = record
            if on_record is not None:
                on_record(record)
    return [records[s.run_id] for s in runs if s.run_id in records]
