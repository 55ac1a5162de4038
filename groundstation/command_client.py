"""COMMAND_LONG's client side over a :class:`~groundstation.link.Link`: a command, re-sent until the
vehicle's COMMAND_ACK, and with a refusal the vehicle's reason (its STATUSTEXT)."""

from __future__ import annotations

import time
from dataclasses import dataclass

from pymavlink.dialects.v20 import common as mavlink

from groundstation.link import REASON_WINDOW_S, Link, LinkError
from groundstation.messages import MAV_RESULT_NAMES


@dataclass(frozen=True)
class CommandAck:
    """The vehicle's answer to one command: the MAV_RESULT, its name, and the vehicle's reason (the
    STATUSTEXT it sent with a refusal; "" if none came within the window)."""

    result: int
    result_name: str
    reason: str = ""
    texts: tuple[str, ...] = ()

    @property
    def ok(self) -> bool:
        return self.result == mavlink.MAV_RESULT_ACCEPTED


class CommandClient:
    """Commands to the vehicle the link talks to (its ``target``)."""

    def __init__(self, link: Link) -> None:
        self.link = link

    def command(self, command: int, *params: float, resend_s: float = 1.0, retries: int = 3) -> int:
        """COMMAND_LONG with retries (confirmation counts up); returns the MAV_RESULT."""
        return self.command_ack(command, *params, resend_s=resend_s, retries=retries, reason=False).result

    def command_ack(
        self,
        command: int,
        *params: float,
        resend_s: float = 1.0,
        retries: int = 3,
        reason: bool = True,
        window_s: float = REASON_WINDOW_S,
    ) -> CommandAck:
        """COMMAND_LONG with retries (confirmation counts up); the vehicle's MAV_RESULT and, for anything
        but ACCEPTED (and ``reason``), the vehicle's reason (see :meth:`Link.reason_after`)."""
        link = self.link
        p = [*params, *([0.0] * (7 - len(params)))]
        ts, tc = link.target
        link.drop_stale(("COMMAND_ACK",))  # an ACK already waiting answers an earlier command, not this one
        t_sent = time.monotonic()
        for attempt in range(retries):
            link.send(mavlink.MAVLink_command_long_message(ts, tc, command, attempt, *p))
            deadline = time.monotonic() + resend_s
            while (left := deadline - time.monotonic()) > 0:
                m = link.recv(left)
                if (
                    m is not None
                    and m.get_type() == "COMMAND_ACK"
                    and m.command == command
                    and link.from_vehicle(m)
                    and link.to_us(m)
                ):
                    result = int(m.result)
                    t_ack = time.monotonic()
                    why = ""
                    if reason and result != mavlink.MAV_RESULT_ACCEPTED:
                        why = link.reason_after(t_sent, t_ack, window_s)
                    texts = tuple(t.text for t in link.texts_since(t_sent))
                    return CommandAck(result, MAV_RESULT_NAMES.get(result, str(result)), why, texts)
        raise LinkError(f"no COMMAND_ACK for command {command} after {retries} tries{link.signing_note()}")
