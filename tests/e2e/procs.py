"""Processes of an end-to-end test: whatever happens, each is stopped (terminate, then kill)."""

from __future__ import annotations

import contextlib
import subprocess
from collections.abc import Iterator
from typing import Any

from auv_common.process import stop_process

#: The e2e tests' name for it.
stop = stop_process


@contextlib.contextmanager
def processes() -> Iterator[list[subprocess.Popen[Any]]]:
    """Processes appended to the yielded list are stopped on exit, the last started first."""
    procs: list[subprocess.Popen[Any]] = []
    try:
        yield procs
    finally:
        for p in reversed(procs):
            stop(p)
