"""COMMAND_LONG / COMMAND_INT / MISSION_SET_CURRENT -> core commands; the request queue; one ACK each.

The adapter never judges the vehicle's state (``onboard/core/DESIGN.md``). It checks only that a command is
well formed (a NaN or infinity in a parameter the command uses is DENIED "paramN is not a number"), maps it
to a :mod:`onboard.core.commands` command and queues it as a :class:`~onboard.adapters.mavlink.api.Request`
for the loop; the core's :class:`~onboard.core.commands.Verdict` comes back through
:meth:`RequestQueue.answer` and becomes exactly one COMMAND_ACK (:data:`MAV_RESULT`, the one table) plus a
STATUSTEXT with the reason for every refusal. A request the loop has not taken within ``command_timeout_s``
is answered TEMPORARILY_REJECTED "the control loop is not running"; a taken one only by the loop. A resent
COMMAND_LONG (same sender and command) while the first is still pending is not queued again: the first one's
ACK answers it. If the mapping code raises, the command is ACKed FAILED (logged).

Per link: the COMMAND_ACK and the refusal's STATUSTEXT go to the link the command came over only (another
station, even with the same ids, hears neither); what an accepted command changes reaches every station
through the telemetry (HEARTBEAT, MISSION_CURRENT) and the core's notes. SET_MESSAGE_INTERVAL sets the
asker's link's rate (:meth:`~onboard.adapters.mavlink.telemetry.Telemetry.set_interval`), REQUEST_MESSAGE
and GET_HOME_POSITION answer the asker's link.

Mapping (seq = MAVLink mission seq; a stored home item shifts seq = goal index + 1):

- ARM_DISARM p1 1 -> :class:`Arm`, 0 -> :class:`Disarm` (forced when p2 = 21196), else DENIED.
- MISSION_START p1 first_item: <= 0 or NaN -> ``Start(None)`` (the current goal, i.e. the progress), else
  ``Start(goal of seq)``; a seq beyond the mission is DENIED.
- DO_SET_MODE with a custom mode, ArduSub's or PX4's layout (:mod:`~onboard.adapters.mavlink.modes`, the
  one table) -> ``SetMode`` "mission", "loiter", "surface" or "ready"; else DENIED with the modes there are.
- DO_PAUSE_CONTINUE p1 0 -> :class:`Hold`, 1 -> :class:`Resume`.
- NAV_RETURN_TO_LAUNCH -> ``Abort("return to surface")``; DO_FLIGHTTERMINATION p1 > 0.5 ->
  ``Abort("termination")``.
- DO_SET_MISSION_CURRENT p1 seq -> ``SetCurrent(goal)`` (-1: no change, ACCEPTED by the adapter);
  the MISSION_SET_CURRENT message likewise (it has no ACK: a refusal is a STATUSTEXT).
- Link-only, answered by the adapter: REQUEST_MESSAGE, SET_MESSAGE_INTERVAL, GET_HOME_POSITION,
  REQUEST_AUTOPILOT_CAPABILITIES. Anything else is UNSUPPORTED (no STATUSTEXT: ground stations probe).
"""

from __future__ import annotations

import logging
import math
import threading
from collections.abc import Callable, Hashable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

from pymavlink.dialects.v20 import common as mavlink

from onboard.adapters.mavlink import modes
from onboard.adapters.mavlink.api import Request
from onboard.adapters.mavlink.config import MavlinkConfig
from onboard.adapters.mavlink.mission_protocol import goal_of_seq
from onboard.adapters.mavlink.peers import Sender
from onboard.adapters.mavlink.transport import Transport, addressed_to
from onboard.core import commands as core
from onboard.core.commands import Outcome, Severity, Verdict

if TYPE_CHECKING:
    from onboard.adapters.mavlink.telemetry import Telemetry

log = logging.getLogger(__name__)

FORCE_DISARM_MAGIC = 21196
LOOP_NOT_RUNNING = "the control loop is not running"

#: The one mapping of the core's outcomes to MAV_RESULT.
MAV_RESULT: dict[Outcome, int] = {
    Outcome.ACCEPTED: mavlink.MAV_RESULT_ACCEPTED,
    Outcome.TEMPORARILY_REJECTED: mavlink.MAV_RESULT_TEMPORARILY_REJECTED,
    Outcome.DENIED: mavlink.MAV_RESULT_DENIED,
    Outcome.FAILED: mavlink.MAV_RESULT_FAILED,
    Outcome.UNSUPPORTED: mavlink.MAV_RESULT_UNSUPPORTED,
}
_LINK_ONLY = frozenset(
    {
        mavlink.MAV_CMD_REQUEST_MESSAGE,
        mavlink.MAV_CMD_SET_MESSAGE_INTERVAL,
        mavlink.MAV_CMD_GET_HOME_POSITION,
        mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES,
    }
)

OnAnswer = Callable[[Verdict], None]


# ---- the request queue -------------------------------------------------------------------------
@dataclass
class _Pending:
    id: int
    command: core.Command
    on_answer: OnAnswer
    deadline_s: float | None
    key: Hashable | None
    taken: bool = False


class RequestQueue:
    """Requests for the loop: submitted and answered on the I/O thread, taken and answered by the loop.

    Thread-safe. ``on_answer`` callbacks run on the I/O thread (in :meth:`poll`), exactly once per request.
    """

    def __init__(
        self, clock: Callable[[], float], timeout_s: float, wake: Callable[[], None] = lambda: None
    ) -> None:
        self._clock = clock
        self.timeout_s = timeout_s
        self.wake = wake
        self._lock = threading.Lock()
        self._pending: dict[int, _Pending] = {}
        self._answers: list[tuple[_Pending, Verdict]] = []
        self._next_id = 1
        self.timeouts = 0

    def submit(
        self, command: core.Command, on_answer: OnAnswer, *, timed: bool = True, key: Hashable | None = None
    ) -> int:
        """Queue ``command``; ``timed`` False: it waits for the loop however long it takes."""
        with self._lock:
            rid = self._next_id
            self._next_id += 1
            deadline = self._clock() + self.timeout_s if timed else None
            self._pending[rid] = _Pending(rid, command, on_answer, deadline, key)
            return rid

    def pending(self, key: Hashable) -> bool:
        """True if a request submitted with ``key`` is still unanswered."""
        with self._lock:
            return any(p.key == key for p in self._pending.values())

    def take(self) -> list[Request]:
        """The requests not taken yet, oldest first; each is taken once (loop thread)."""
        with self._lock:
            out = []
            for p in self._pending.values():
                if not p.taken:
                    p.taken = True
                    out.append(Request(p.id, p.command))
            return out

    def answer(self, rid: int, verdict: Verdict) -> None:
        """The loop's verdict on a taken request (any other id is logged and ignored)."""
        with self._lock:
            p = self._pending.get(rid)
            if p is None or not p.taken:
                log.warning("answer to unknown or untaken request %d ignored: %s", rid, verdict)
                return
            del self._pending[rid]
            self._answers.append((p, verdict))
        self.wake()

    def poll(self, now_s: float) -> None:
        """Answer the expired untaken requests and deliver the loop's answers (I/O thread)."""
        with self._lock:
            done, self._answers = self._answers, []
            for rid, p in list(self._pending.items()):
                if not p.taken and p.deadline_s is not None and now_s >= p.deadline_s:
                    del self._pending[rid]
                    self.timeouts += 1
                    done.append((p, Verdict(Outcome.TEMPORARILY_REJECTED, LOOP_NOT_RUNNING)))
        for p, verdict in done:
            try:
                p.on_answer(verdict)
            except Exception:
                log.exception("answering request %d (%s) failed", p.id, type(p.command).__name__)

    def next_deadline(self) -> float | None:
        with self._lock:
            if self._answers:
                return self._clock()
            ds = [p.deadline_s for p in self._pending.values() if not p.taken and p.deadline_s is not None]
            return min(ds) if ds else None


# ---- the command service -----------------------------------------------------------------------
class Seqs(Protocol):
    """MAVLink seq <-> goal index of the accepted mission (the mission service)."""

    def shape(self) -> tuple[int, int]: ...  # (home offset, number of goals)


class _Refused(Exception):
    """A malformed command: answered by the adapter with ``verdict``."""

    def __init__(self, verdict: Verdict) -> None:
        super().__init__(verdict.reason)
        self.verdict = verdict


def _num(p: list[float], i: int) -> float:
    """Parameter ``i`` (0-based) of a command that uses it; DENIED when it is not a number."""
    v = p[i]
    if not math.isfinite(v):
        raise _Refused(core.denied(f"param{i + 1} is not a number"))
    return v


def _no_item(seq: int, offset: int, n: int) -> Verdict:
    return core.denied(f"no mission item {seq} (the mission has {n + offset} items)")


def map_command(cmd: int, p: list[float], seqs: Seqs, source: str = "") -> core.Command | Verdict:
    """The core command for MAV_CMD ``cmd`` with params ``p`` (7 floats), or the adapter's own verdict
    (a malformed command, a no-op, UNSUPPORTED). Never looks at the vehicle's state."""
    try:
        return _map(cmd, p, seqs, source)
    except _Refused as r:
        return r.verdict


def _map(cmd: int, p: list[float], seqs: Seqs, source: str) -> core.Command | Verdict:
    if cmd == mavlink.MAV_CMD_COMPONENT_ARM_DISARM:
        arm = _num(p, 0)
        if arm == 1.0:
            return core.Arm(source=source)
        if arm == 0.0:
            return core.Disarm(forced=p[1] == FORCE_DISARM_MAGIC, source=source)
        return core.denied("param1 must be 0 or 1")
    if cmd == mavlink.MAV_CMD_MISSION_START:
        first = p[0]
        if math.isnan(first) or first <= 0.0:
            return core.Start(None, source=source)
        first = _num(p, 0)
        offset, n = seqs.shape()
        index = goal_of_seq(int(first), offset, n)
        if index is None:
            return _no_item(int(first), offset, n)
        return core.Start(index, source=source)
    if cmd == mavlink.MAV_CMD_DO_SET_MODE:
        mode = modes.requested_mode(int(_num(p, 0)), int(_num(p, 1)), int(_num(p, 2)))
        if isinstance(mode, Verdict):
            return mode
        return core.SetMode(mode, source=source)
    if cmd == mavlink.MAV_CMD_DO_PAUSE_CONTINUE:
        what = _num(p, 0)
        if what == 0.0:
            return core.Hold(source=source)
        if what == 1.0:
            return core.Resume(source=source)
        return core.denied("param1 must be 0 (hold) or 1 (continue)")
    if cmd == mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH:
        return core.Abort("return to surface", source=source)
    if cmd == mavlink.MAV_CMD_DO_FLIGHTTERMINATION:
        if _num(p, 0) > 0.5:
            return core.Abort("termination", source=source)
        return core.denied("param1 must be 1 to terminate")
    if cmd == mavlink.MAV_CMD_DO_SET_MISSION_CURRENT:
        seq = int(_num(p, 0))
        if seq == -1:
            return core.accepted("no change")  # -1: no change (spec)
        offset, n = seqs.shape()
        index = goal_of_seq(seq, offset, n)
        if index is None:
            return _no_item(seq, offset, n)
        return core.SetCurrent(index, source=source)
    return Verdict(Outcome.UNSUPPORTED, f"command {cmd} is not supported")


def _params(msg: mavlink.MAVLink_message) -> list[float]:
    if msg.get_type() == "COMMAND_LONG":
        raw = [msg.param1, msg.param2, msg.param3, msg.param4, msg.param5, msg.param6, msg.param7]
    else:
        raw = [msg.param1, msg.param2, msg.param3, msg.param4, float(msg.x), float(msg.y), msg.z]
    return [float(v) for v in raw]


class CommandService:
    """The command micro-service (I/O thread): exactly one COMMAND_ACK per command addressed to us."""

    def __init__(
        self,
        config: MavlinkConfig,
        transport: Transport,
        requests: RequestQueue,
        seqs: Seqs,
        telemetry: Telemetry,
    ) -> None:
        self.config = config
        self.transport = transport
        self.requests = requests
        self.seqs = seqs
        self.telemetry = telemetry
        self.acks = 0

    def handle(self, msg: mavlink.MAVLink_message, sender: Sender, now_s: float) -> None:
        kind = msg.get_type()
        if not addressed_to(msg, self.config.system_id, self.config.component_id):
            return
        if kind == "MISSION_SET_CURRENT":
            self._set_current_message(int(msg.seq), sender)
            return
        if kind not in ("COMMAND_LONG", "COMMAND_INT"):
            return
        cmd = int(msg.command)
        try:
            p = _params(msg)
        except Exception as exc:  # a bug must still be answered
            log.exception("command %d failed", cmd)
            self._ack(cmd, sender, Verdict(Outcome.FAILED, f"command {cmd} failed: {type(exc).__name__}"))
            return
        # A resend (same command, same parameters; COMMAND_LONG's confirmation counts up) while the first is
        # with the loop: the first one's ACK answers both. Other parameters are another command.
        key = ("cmd", sender, cmd, tuple(repr(v) for v in p))
        if self.requests.pending(key):
            return
        try:
            if cmd in _LINK_ONLY:
                self._link_only(cmd, p, sender)
                return
            mapped = map_command(cmd, p, self.seqs, f"MAVLink {sender[0]}/{sender[1]}")
        except Exception as exc:  # a bug must still be answered
            log.exception("command %d failed", cmd)
            self._ack(cmd, sender, Verdict(Outcome.FAILED, f"command {cmd} failed: {type(exc).__name__}"))
            return
        if isinstance(mapped, Verdict):
            self._ack(cmd, sender, mapped)
            return
        self.requests.submit(mapped, lambda v: self._answered(cmd, sender, mapped, v), key=key)

    def _answered(self, cmd: int, sender: Sender, command: core.Command, verdict: Verdict) -> None:
        self._ack(cmd, sender, verdict)
        if verdict.accepted and isinstance(command, core.SetCurrent):
            self.telemetry.send_mission_current(command.index)

    def _ack(self, cmd: int, sender: Sender, verdict: Verdict) -> None:
        result = MAV_RESULT.get(verdict.outcome, mavlink.MAV_RESULT_FAILED)
        # to the command's link only: another station with the same ids must not take it as its own
        ack = mavlink.MAVLink_command_ack_message(cmd, result, 0, 0, sender[0], sender[1])
        self.transport.reply(ack, sender)
        self.acks += 1
        if verdict.outcome is not Outcome.ACCEPTED and verdict.outcome is not Outcome.UNSUPPORTED:
            self.transport.statustext(Severity.WARNING, verdict.reason, to=sender)  # the asker's answer
        log.info(
            "command %d from %d/%d: %s (%s)", cmd, sender[0], sender[1], verdict.outcome.value, verdict.reason
        )

    def _link_only(self, cmd: int, p: list[float], sender: Sender) -> None:
        """The commands that do not touch the vehicle: answered here, then their message is sent."""
        tel = self.telemetry
        link = sender.link if isinstance(sender, Sender) else None  # None: unknown, every link
        send: int | None = None
        verdict: Verdict
        try:
            if cmd == mavlink.MAV_CMD_REQUEST_MESSAGE:
                msg_id = int(_num(p, 0))
                if msg_id in tel.requestable():
                    verdict, send = core.accepted("sent"), msg_id
                else:
                    verdict = core.denied(f"message {msg_id} cannot be requested")
            elif cmd == mavlink.MAV_CMD_SET_MESSAGE_INTERVAL:
                verdict = tel.set_interval(int(_num(p, 0)), _num(p, 1), link)
            elif cmd == mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES:
                verdict, send = core.accepted("sent"), mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION
            else:  # MAV_CMD_GET_HOME_POSITION: deprecated, still sent by MAVProxy
                verdict, send = core.accepted("sent"), mavlink.MAVLINK_MSG_ID_HOME_POSITION
        except _Refused as r:
            verdict = r.verdict
        self._ack(cmd, sender, verdict)
        if send is not None:
            tel.send_message(send, link)

    def _set_current_message(self, seq: int, sender: Sender) -> None:
        """MISSION_SET_CURRENT: no ACK exists; the answer is MISSION_CURRENT, a refusal a STATUSTEXT."""
        offset, n = self.seqs.shape()
        index = goal_of_seq(seq, offset, n)
        if index is None:
            self.transport.statustext(Severity.WARNING, _no_item(seq, offset, n).reason, to=sender)
            return
        command = core.SetCurrent(index, source=f"MAVLink {sender[0]}/{sender[1]}")

        def answered(v: Verdict) -> None:
            if v.accepted:
                self.telemetry.send_mission_current(index)
            else:
                self.transport.statustext(Severity.WARNING, v.reason, to=sender)

        self.requests.submit(command, answered)
