"""A token bucket: at most ``rate_per_s`` events a second on average, ``burst`` at once.

The one rate limiter of the stack: the vehicle's MAVLink receive shares (one per known peer, one for all
strangers) and the CAN receivers' rate check per id (``onboard.protocol.codec.FrameReceiver.check_rates``)
use it. Pure: the caller passes the time (monotonic or simulated seconds).
"""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass
class TokenBucket:
    """``take(now_s)`` is True while tokens are left; they come back at ``rate_per_s`` up to ``burst``."""

    rate_per_s: float
    burst: float
    tokens: float = field(init=False)
    t_s: float | None = field(default=None, init=False)

    def __post_init__(self) -> None:
        if not (self.rate_per_s > 0.0 and self.burst >= 1.0):
            raise ValueError(f"token bucket: rate > 0 and burst >= 1, got {self.rate_per_s}, {self.burst}")
        self.tokens = self.burst

    def take(self, now_s: float) -> bool:
        """Spend one token if there is one. A clock that steps back adds no tokens and the bucket goes on
        from the new time (a wall clock set back an hour must not stop the refill for an hour)."""
        if self.t_s is not None and now_s > self.t_s:
            self.tokens = min(self.burst, self.tokens + (now_s - self.t_s) * self.rate_per_s)
        self.t_s = now_s
        if self.tokens < 1.0:
            return False
        self.tokens -= 1.0
        return True
