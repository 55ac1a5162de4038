"""The MAVLink parameter micro-service: PARAM_REQUEST_LIST / PARAM_REQUEST_READ / PARAM_SET -> PARAM_VALUE.

The table is :func:`onboard.core.params.param_table` (one table, ``onboard/core/DESIGN.md``); the service
holds only the values in force as the core last reported them. A PARAM_SET is a
:class:`~onboard.core.commands.SetParam` request judged by the core; its verdict carries the value in force:

- the ground-station edit is saved through the store BEFORE the core judges it (only the edits whose value
  differs from the spec's default in float32, :func:`onboard.core.params.is_default`): an edit that cannot
  be saved is refused with the reason and never in force (an acknowledgement means durable);
- accepted: PARAM_VALUE with the value in force;
- refused (or not taken by the loop in time): PARAM_VALUE with the value in force and a STATUSTEXT with the
  reason; the file gets the value in force back (once no other PARAM_SET of that name is in flight);
- an unknown name has no PARAM_VALUE to answer with: a STATUSTEXT "unknown parameter NAME".

Per link: PARAM_REQUEST_LIST / PARAM_REQUEST_READ and a refused PARAM_SET (its STATUSTEXT and the
PARAM_VALUE in force) and "unknown parameter NAME" are answered to the asker's link only; an accepted
PARAM_SET's PARAM_VALUE (a change) goes to every link, so every station's cached list stays true.

At start the service loads the persisted edits. The vehicle programs apply them to the core first and give
the values in force (``values``; :func:`onboard.app.runtime.resolve_boot`), so the first PARAM_VALUE is
true. Without ``values`` (a link alone, tests) each persisted edit is handed to the core as a ``SetParam``
request (not timed: it waits for the loop) and, until the core has judged them all (:attr:`booting`), the
link answers no PARAM_* or mission request: a table default is never served for a value not in force.
"""

from __future__ import annotations

import functools
import logging
import math
from collections.abc import Mapping
from typing import Protocol

from pymavlink.dialects.v20 import common as mavlink

from onboard.adapters.mavlink.commands import RequestQueue
from onboard.adapters.mavlink.config import MavlinkConfig
from onboard.adapters.mavlink.peers import Sender
from onboard.adapters.mavlink.storage import Store
from onboard.adapters.mavlink.transport import Transport, addressed_to
from onboard.core import commands as core
from onboard.core.commands import Severity, Verdict
from onboard.core.params import ParamSpec, float32

log = logging.getLogger(__name__)

__all__ = ["ParamService", "ParamSpec", "SpecLike"]


class SpecLike(Protocol):
    """What the service reads of a parameter spec (:class:`onboard.core.params.ParamSpec`)."""

    @property
    def name(self) -> str: ...
    @property
    def default(self) -> float: ...


def param_name(raw: object) -> str:
    if isinstance(raw, bytes):
        raw = raw.decode("ascii", "replace")
    return str(raw).split("\x00", 1)[0]


class ParamService:
    """PARAM_* for the table ``specs`` (I/O thread, except :meth:`value` / :meth:`values`)."""

    def __init__(
        self,
        config: MavlinkConfig,
        transport: Transport,
        requests: RequestQueue,
        store: Store,
        specs: tuple[SpecLike, ...],
        values: Mapping[str, float] | None = None,
    ) -> None:
        names = [s.name for s in specs]
        if len(set(names)) != len(names):
            raise ValueError("duplicate parameter names")
        self.config = config
        self.transport = transport
        self.requests = requests
        self.store = store
        self.specs = specs
        self._index = {s.name: i for i, s in enumerate(specs)}
        self._values: dict[str, float] = {s.name: float(s.default) for s in specs}
        persisted = store.load_params()
        self._edits: dict[str, float] = {n: v for n, v in persisted.items() if n in self._index}
        self._in_flight: dict[str, int] = {}  # PARAM_SETs saved and with the core, per name
        for name in sorted(set(persisted) - set(self._index)):
            log.warning("persisted parameter %s is not in the table: ignored", name)
        self._booting: set[str] = set()  # persisted edits handed to the core, not judged yet
        if values is not None:
            self._values.update({n: float(v) for n, v in values.items() if n in self._index})
        else:
            for name, value in self._edits.items():
                self._booting.add(name)
                self.requests.submit(
                    core.SetParam(name, value, source="persisted edit"),
                    functools.partial(self._boot_answer, name),
                    timed=False,
                )

    # ---- queries (any thread: values change only on the I/O thread, dict reads are atomic) --------
    @property
    def booting(self) -> bool:
        """True while a persisted edit handed to the core at start has not been judged: the values held
        are not the values in force yet, so the link answers no PARAM_* (nor mission request) meanwhile."""
        return bool(self._booting)

    def value(self, name: str) -> float:
        return self._values[name]

    def values(self) -> dict[str, float]:
        return dict(self._values)

    def spec(self, name: str) -> SpecLike | None:
        i = self._index.get(name)
        return None if i is None else self.specs[i]

    # ---- protocol --------------------------------------------------------------------------------
    def _param_value(self, name: str) -> mavlink.MAVLink_message:
        return mavlink.MAVLink_param_value_message(
            name.encode("ascii"),
            self._values[name],
            mavlink.MAV_PARAM_TYPE_REAL32,
            len(self.specs),
            self._index[name],
        )

    def handle(self, msg: mavlink.MAVLink_message, sender: Sender, now_s: float) -> None:
        if not addressed_to(msg, self.config.system_id, self.config.component_id):
            return
        kind = msg.get_type()
        # PARAM_REQUEST_LIST / READ are answered to the asker's link only (within its output budget): a
        # station asking for the list again and again costs no other station anything
        if kind == "PARAM_REQUEST_LIST":
            for spec in self.specs:
                self.transport.reply(self._param_value(spec.name), sender)
        elif kind == "PARAM_REQUEST_READ":
            if msg.param_index >= 0:
                if msg.param_index < len(self.specs):
                    self.transport.reply(self._param_value(self.specs[msg.param_index].name), sender)
                return
            name = param_name(msg.param_id)
            if name in self._index:
                self.transport.reply(self._param_value(name), sender)
        elif kind == "PARAM_SET":
            self._set(param_name(msg.param_id), float(msg.param_value), sender)

    def _set(self, name: str, value: float, sender: Sender) -> None:
        if name not in self._index:
            self.transport.statustext(Severity.WARNING, f"unknown parameter {name}", to=sender)
            return
        if not math.isfinite(value):
            self._refused(name, core.denied(f"{name}: the value is not a number"), sender)
            return
        key = ("param", name, float32(value))
        if self.requests.pending(key):
            return  # a resend: the first one's PARAM_VALUE answers it
        why = self._persist(name, value)  # saved before it can be in force: an acknowledgement is durable
        if why:
            self._refused(name, core.denied(f"{name} not set: it cannot be saved ({why})"), sender)
            return
        self._in_flight[name] = self._in_flight.get(name, 0) + 1
        self.requests.submit(
            core.SetParam(name, value, source=f"MAVLink {sender[0]}/{sender[1]}"),
            lambda v: self._answered(name, v, sender),
            key=key,
        )

    def _answered(self, name: str, verdict: Verdict, sender: Sender | None = None) -> None:
        left = self._in_flight.pop(name, 1) - 1
        if left > 0:
            self._in_flight[name] = left
        if not verdict.accepted:
            self._refused(name, verdict, sender)
            if left == 0:  # the saved edit was refused: the file says the value in force again
                self._unsave(name)
            return
        if math.isfinite(verdict.value):
            self._values[name] = verdict.value
        if left == 0:  # the file holds the value asked for; the value in force if the core made it another
            self._persist(name, self._values[name])
        self.transport.send(self._param_value(name))

    def _refused(self, name: str, verdict: Verdict, to: Sender | None = None) -> None:
        """A refused PARAM_SET: the reason and the value in force, to the asker's link only (``to``; None:
        every link), since nothing changed that another station must hear."""
        if math.isfinite(verdict.value):
            self._values[name] = verdict.value
        self.transport.statustext(Severity.WARNING, verdict.reason, to=to)
        if to is None:
            self.transport.send(self._param_value(name))  # the value in force
        else:
            self.transport.reply(self._param_value(name), to)

    def _persist(self, name: str, value: float) -> str:
        """Save ``name = value`` as a ground-station edit (none when it is the configured value, in
        float32); "" when saved or nothing to save, else why not (the file is unchanged)."""
        spec = self.specs[self._index[name]]
        edits = dict(self._edits)
        if float32(value) == float32(spec.default):
            edits.pop(name, None)
        else:
            edits[name] = value
        if edits == self._edits:
            return ""
        try:
            self.store.save_params(edits)
        except OSError as exc:
            log.error("cannot save parameters: %s", exc)
            return str(exc)
        self._edits = edits
        return ""

    def _unsave(self, name: str) -> None:
        """After a refusal (none other in flight for ``name``): the file gets the value in force back."""
        why = self._persist(name, self._values[name])
        if why:
            text = f"{name}: the refused value stays saved and applies at the next boot ({why})"
            log.critical("%s", text)
            self.transport.statustext(Severity.CRITICAL, text)

    def _boot_answer(self, name: str, verdict: Verdict) -> None:
        self._booting.discard(name)
        if math.isfinite(verdict.value):
            self._values[name] = verdict.value
        if verdict.accepted:
            log.info("persisted parameter %s = %g applied", name, self._values[name])
        else:
            log.warning("persisted parameter %s not applied: %s", name, verdict.reason)
