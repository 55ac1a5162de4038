"""The planning worker: the plans the core asks for, computed off the control thread.

The core (:class:`onboard.core.autopilot.Autopilot`) never plans inside a tick: it asks
(:meth:`~onboard.core.autopilot.Autopilot.take_plan_request`) and holds (fins neutral, propeller off) until
the answer arrives (:meth:`~onboard.core.autopilot.Autopilot.plan_done`). This worker runs
:func:`onboard.core.autopilot.compute_plan` in one thread of a :class:`concurrent.futures.ThreadPoolExecutor`
(planning is pure Python: a thread shares the GIL with the loop, but the loop's tick is short and the
interpreter switches threads every few milliseconds; a process would pay for pickling the obstacles on
every plan). In real time the answer is handed over at the first tick after it is ready; in lock-step the
loop waits for it before the next step (up to the request's deadline, wall clock), so a run repeats exactly.
A plan that misses its deadline is the core's business: it holds with the reason, and a late answer is
dropped (the request id no longer matches).
"""

from __future__ import annotations

import concurrent.futures
import logging
import time
from typing import Any

from onboard.core.planner.errors import PlannerError
from onboard.core.plans import PlanRequest, compute_plan

log = logging.getLogger(__name__)


def _run(request: PlanRequest) -> Any:
    try:
        return compute_plan(request)
    except PlannerError as exc:
        return exc
    except Exception as exc:  # a planner bug: the vehicle holds with the reason, the loop goes on
        log.exception("planning %s %d failed", request.kind, request.goal_index)
        return PlannerError("internal", f"the planner failed: {type(exc).__name__}: {exc}")


class PlanWorker:
    """Carries plan requests from an autopilot to a worker thread and the results back (loop thread)."""

    def __init__(self, autopilot: Any, lockstep: bool) -> None:
        self.autopilot = autopilot
        self.lockstep = lockstep
        self._pool: concurrent.futures.ThreadPoolExecutor | None = None
        self._jobs: list[tuple[PlanRequest, concurrent.futures.Future[Any], bool, float]] = []
        self.plans = 0
        self.late = 0

    @staticmethod
    def for_autopilot(autopilot: Any, lockstep: bool) -> PlanWorker | None:
        """A worker if the autopilot plans (the benchmark's stub does not)."""
        return PlanWorker(autopilot, lockstep) if hasattr(autopilot, "take_plan_request") else None

    def before_step(self) -> None:
        """Submit what was asked for since the last step (e.g. by a START), then hand finished plans to
        the autopilot; in lock-step wait for each first (once, up to its deadline)."""
        self.after_step()
        keep = []
        for request, future, waited, t_s in self._jobs:
            if self.lockstep and not waited and not future.done():
                try:
                    future.result(timeout=request.deadline_s)
                except concurrent.futures.TimeoutError:
                    self.late += 1
                    log.warning("plan %d (%s) is late: the vehicle holds", request.request_id, request.kind)
                waited = True
            if future.done():
                self.autopilot.plan_done(request.request_id, future.result())
            else:
                keep.append((request, future, waited, t_s))
        self._jobs = keep

    def after_step(self) -> None:
        """Submit the plan the autopilot asked for, if any (on a fresh worker if the one there is still
        busy with a plan past its deadline: a late plan never delays the next one)."""
        request = self.autopilot.take_plan_request()
        if request is None:
            return
        now = time.monotonic()
        if self._pool is not None and any(
            not f.done() and now - t > r.deadline_s for r, f, _w, t in self._jobs
        ):
            self._pool.shutdown(wait=False, cancel_futures=True)  # its thread ends when its plan does
            self._pool = None
        if self._pool is None:
            self._pool = concurrent.futures.ThreadPoolExecutor(max_workers=1, thread_name_prefix="planner")
        self.plans += 1
        self._jobs.append((request, self._pool.submit(_run, request), False, now))

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=False, cancel_futures=True)
            self._pool = None
