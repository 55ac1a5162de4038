"""Waiting in tests: poll machine-readable state with a deadline, never sleep a fixed time before an assert.

A fixed ``sleep(0.3)`` before an assert is a guess of how long the machine takes; on a loaded machine
(xdist workers, other processes) the guess is wrong and the test flakes, on an idle one it wastes the time.
:func:`wait_until` returns as soon as the condition holds and fails, saying what it waited for, only after a
deadline generous enough for a loaded machine.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import TypeVar

T = TypeVar("T")


def wait_until(
    predicate: Callable[[], T], timeout_s: float = 10.0, what: str = "", poll_s: float = 0.02
) -> T:
    """Call ``predicate`` every ``poll_s`` until it returns a truthy value, and return that value; raise
    AssertionError naming ``what`` (or the predicate) if it has not within ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    while True:
        value = predicate()
        if value:
            return value
        if time.monotonic() >= deadline:
            raise AssertionError(
                f"not within {timeout_s:g} s: {what or getattr(predicate, '__name__', predicate)}"
            )
        time.sleep(poll_s)
