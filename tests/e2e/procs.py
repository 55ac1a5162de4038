"""Processes of an end-to-end test: whatever happens, each is stopped (terminate, then kill)."""

from __future__ import annotations

import contextlib
import subprocess
from collections.abc import Iterator
from typing import Any


def stop(proc: subprocess.Popen[Any]) -> None:
    """Terminate ``proc`` (then kill it if it does not go within 5 s)."""
    if proc.poll() is None:
        proc.terminate()
        try:
            proc.wait(5)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(5)


@contextlib.contextmanager
def processes() -> Iterator[list[subprocess.Popen[Any]]]:
    """Processes appended to the yielded list are stopped on exit, the last started first."""
    procs: list[subprocess.Popen[Any]] = []
    try:
        yield procs
    finally:
        for p in reversed(procs):
            stop(p)
