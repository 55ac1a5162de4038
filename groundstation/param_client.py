"""The parameter protocol's client side over a :class:`~groundstation.link.Link`: list, get and set the
vehicle's parameters (PARAM_REQUEST_LIST / _READ, PARAM_SET, answered by PARAM_VALUE)."""

from __future__ import annotations

import math
import struct
import time

from pymavlink.dialects.v20 import common as mavlink

from groundstation.link import Link, LinkError
from groundstation.messages import wire_string


class UnknownParameter(LinkError):
    """The vehicle has no parameter of that name (a refusal, not a link problem)."""


class ParamClient:
    """The parameters of the vehicle the link talks to (its ``target``)."""

    def __init__(self, link: Link) -> None:
        self.link = link

    def get_all(self, *, quiet_s: float = 1.0, timeout_s: float = 10.0) -> dict[str, float]:
        """All parameters (PARAM_REQUEST_LIST, then PARAM_REQUEST_READ for any missing index)."""
        link = self.link
        ts, tc = link.target
        link.send(mavlink.MAVLink_param_request_list_message(ts, tc))
        values: dict[int, tuple[str, float]] = {}
        total: int | None = None
        t_end = time.monotonic() + timeout_s
        last_rx = time.monotonic()
        while time.monotonic() < t_end:
            m = link.recv(0.1)
            if m is not None and m.get_type() == "PARAM_VALUE" and link.from_vehicle(m):
                total = int(m.param_count)
                values[m.param_index] = (wire_string(m.param_id), float(m.param_value))
                last_rx = time.monotonic()
                if len(values) >= total:
                    break
            elif time.monotonic() - last_rx > quiet_s:
                if total is None:
                    link.send(mavlink.MAVLink_param_request_list_message(ts, tc))
                else:
                    for i in range(total):
                        if i not in values:
                            link.send(mavlink.MAVLink_param_request_read_message(ts, tc, b"", i))
                last_rx = time.monotonic()
        if total is None or len(values) < total:
            raise LinkError("parameter list incomplete")
        return dict(values[i] for i in sorted(values))

    def get(self, name: str, *, resend_s: float = 0.5, retries: int = 5) -> float:
        """PARAM_REQUEST_READ by name. No answer (MAVLink's way of saying "unknown"): the list is asked for
        and :class:`UnknownParameter` raised if the name is not in it, else :class:`LinkError`."""
        link = self.link
        ts, tc = link.target
        for _ in range(retries):
            link.send(mavlink.MAVLink_param_request_read_message(ts, tc, name.encode("ascii"), -1))
            deadline = time.monotonic() + resend_s
            while (left := deadline - time.monotonic()) > 0:
                m = link.recv(left)
                if m is not None and m.get_type() == "PARAM_VALUE" and wire_string(m.param_id) == name:
                    return float(m.param_value)
        try:
            names = self.get_all(quiet_s=0.5, timeout_s=3.0)
        except LinkError:
            names = {}
        if names and name not in names:
            raise UnknownParameter(f"no such parameter {name} (the vehicle has {len(names)})")
        raise LinkError(f"no value for parameter {name}{link.signing_note()}")

    def set(self, name: str, value: float, *, resend_s: float = 0.5, retries: int = 5) -> tuple[bool, float]:
        """PARAM_SET; returns (accepted, value now in force). A refused set is answered with the old value."""
        link = self.link
        ts, tc = link.target
        want = struct.unpack("<f", struct.pack("<f", value))[0] if math.isfinite(value) else value
        t_sent = time.monotonic()
        unknown = f"unknown parameter {name}"
        for _ in range(retries):
            link.send(
                mavlink.MAVLink_param_set_message(
                    ts, tc, name.encode("ascii"), value, mavlink.MAV_PARAM_TYPE_REAL32
                )
            )
            deadline = time.monotonic() + resend_s
            while (left := deadline - time.monotonic()) > 0:
                m = link.recv(left)
                if m is not None and m.get_type() == "PARAM_VALUE" and wire_string(m.param_id) == name:
                    got = float(m.param_value)
                    return got == want, got
                if any(t.text == unknown for t in link.texts_since(t_sent)):  # the vehicle's answer
                    raise UnknownParameter(f"no such parameter {name} (the vehicle says: {unknown})")
        raise LinkError(f"no answer to setting {name}{link.signing_note()}")
