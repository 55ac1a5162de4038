"""The vehicle's MAVLink 2 link: a thin composition of the services, run in its own I/O thread.

The loop talks to it only through :class:`VehicleLink` (thread-safe, cheap; see ``onboard/core/DESIGN.md``
"The per-tick exchange"): ``take_requests()`` / ``answer(id, verdict)`` for the commands the ground station
sent, ``notify(notes)`` for what the core has to say, ``publish(snapshot)`` for telemetry, ``mission()``
for the accepted mission. Everything else happens in the I/O thread on the monotonic wall clock:

- :mod:`~onboard.adapters.mavlink.transport`: sockets, peers, signing, the receive shares, the fan-out;
- :mod:`~onboard.adapters.mavlink.mission_service`: uploads/downloads, the validator, the store;
- :mod:`~onboard.adapters.mavlink.commands`: COMMAND_LONG/INT -> core commands, the request queue, ACKs;
- :mod:`~onboard.adapters.mavlink.telemetry`: HEARTBEAT, the streams, the state table;
- :mod:`~onboard.adapters.mavlink.params`: PARAM_*.

The link never judges a command against the vehicle's state: the core does (``Autopilot.handle``).

GCS heartbeat watch: no ground-station HEARTBEAT for ``gcs_timeout_s`` -> a ``LinkLost(gcs_loss_action)``
request (its verdict is only logged) and a STATUSTEXT; a heartbeat again -> a STATUSTEXT "GCS link
regained". When a ground station is first heard, the state files the store set aside at boot are announced
(one STATUSTEXT each).

Storage: the vehicle's state store (``[store]``, handed in by the program, typed by
:class:`~onboard.adapters.mavlink.storage.Store`) is probed at boot (``Store.open``, which also removes what
killed writers left); a vehicle whose directory cannot be written boots all the same, with what it could read.
While nothing can be saved, SYS_STATUS says so (MAV_SYS_STATUS_LOGGING present, enabled, not healthy) and
every ground station that connects (its first HEARTBEAT over a link, or the first after ``gcs_timeout_s``
of silence) hears "storage: nothing can be saved (why)"; a change of the storage health goes to every
station. Uploads and PARAM_SETs are saved before they are in force and refused with the reason when that
fails; the store probes again every few seconds, so a disk that frees up is writable without a reboot.

MAVSDK / QGroundControl / MAVProxy interoperability: see :mod:`~onboard.adapters.mavlink.modes` (ArduSub's
mode numbers in HEARTBEAT, ArduSub's or PX4's in DO_SET_MODE) and :mod:`~onboard.adapters.mavlink.telemetry` (
GLOBAL_POSITION_INT, EXTENDED_SYS_STATE). MAV_CMD_REQUEST_PROTOCOL_VERSION stays UNSUPPORTED (PROTOCOL_VERSION
is not in pymavlink's ``common`` dialect; QGC then goes by the frames it sees, which are MAVLink 2).
"""

from __future__ import annotations

import collections
import logging
import threading
import time
from collections.abc import Callable, Mapping
from pathlib import Path

from pymavlink.dialects.v20 import common as mavlink

from onboard.adapters.mavlink.api import Request, VehicleSnapshot
from onboard.adapters.mavlink.commands import CommandService, RequestQueue
from onboard.adapters.mavlink.config import MavlinkConfig, load_signing_key
from onboard.adapters.mavlink.ftp import FileTree, FtpService
from onboard.adapters.mavlink.mission_service import MissionService, Validator
from onboard.adapters.mavlink.params import ParamService, SpecLike
from onboard.adapters.mavlink.peers import Link, Sender
from onboard.adapters.mavlink.storage import Store
from onboard.adapters.mavlink.telemetry import CAPABILITIES, Telemetry
from onboard.adapters.mavlink.transport import Transport, addressed_to
from onboard.core import commands as core
from onboard.core.commands import Note, Severity, Verdict
from onboard.core.mission.model import Mission

log = logging.getLogger(__name__)

__all__ = ["CAPABILITIES", "VehicleLink"]

MAX_WAIT_S = 0.05
#: Ground-station links remembered for the storage news at connect (halved, oldest first, beyond it).
MAX_STATIONS = 64


def storage_text(problem: str) -> str:
    """The one line a station hears while nothing can be saved."""
    return f"storage: nothing can be saved ({problem})"


class VehicleLink:
    """The MAVLink link of the vehicle (see the module docstring).

    Args:
        config: the ``[mavlink]`` configuration.
        validator: the mission check every upload passes (``check_mission`` bound to the configuration).
        params: the parameter table (:func:`onboard.core.params.param_table`); empty = no parameters.
        param_values: the values in force at start when the caller applied the persisted edits itself;
            None: the link hands each persisted edit to the core as a ``SetParam`` request and answers
            no PARAM_* or mission request until the core has judged them all.
        initial_mission: a mission given at start (``--mission``, already checked); it wins over the
            persisted one and is persisted.
        clock: monotonic wall clock (s); tests may inject one.
        store: the vehicle's state store (:class:`onboard.app.store.StateStore`, ``[store]``), opened here
            if the program has not (opening twice is a no-op).
        log_dir: the flight logs served over MAVLink FTP (default: ``logs`` in the state directory).
    """

    def __init__(
        self,
        config: MavlinkConfig,
        *,
        validator: Validator,
        params: tuple[SpecLike, ...] = (),
        param_values: Mapping[str, float] | None = None,
        initial_mission: Mission | None = None,
        store: Store,
        clock: Callable[[], float] = time.monotonic,
        log_dir: Path | None = None,
    ) -> None:
        self.config = config
        self._clock = clock
        self.store = store
        self.store.open()  # leftovers removed, the directory probed (a problem is reported, never fatal)
        self._storage_said = self.store.problem()  # what every station heard (a station: at its connect)
        self._stations: dict[Link, float] = {}  # GCS links heard (last HEARTBEAT), for the connect news
        self._signing_save_failed = False
        self.transport = Transport(
            config,
            clock,
            self.dispatch,
            signing_key=self._boot_signing_key(),
            signing_floor=self.store.load_signing_timestamp(),
            on_signing_advance=self._save_signing_timestamp,
        )
        self.requests = RequestQueue(clock, config.command_timeout_s, self.transport.wake)
        self.missions = MissionService(
            config, self.transport, self.requests, self.store, validator, initial_mission
        )
        rx = self.transport.rx
        self.telemetry = Telemetry(
            config,
            self.transport,
            clock,
            self.missions.shape,
            lambda: rx.malformed + rx.bad_signature + rx.unsigned_rejected,
            progress=self.missions.progress(),
            fence_circles=lambda: self.missions.mission().obstacles,
            origin=lambda: self.missions.limits,
            storage_problem=self.store.problem,
        )
        self.commands = CommandService(config, self.transport, self.requests, self.missions, self.telemetry)
        self.ftp = FtpService(
            self.transport,
            FileTree(self.telemetry.snapshot, log_dir if log_dir is not None else self.store.dir / "logs"),
            config.system_id,
            config.component_id,
            clock,
        )
        self.params = ParamService(config, self.transport, self.requests, self.store, params, param_values)
        self._lock = threading.Lock()
        self._notes: collections.deque[Note] = collections.deque(maxlen=256)
        self._notes_dropped = 0
        self._gcs_last_s: float | None = None
        self._gcs_lost = False
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()

    def _boot_signing_key(self) -> bytes | None:
        """The key a SETUP_SIGNING set (persisted; it may have turned signing off), else the configured."""
        set_by_setup, key = self.store.load_signing_key()
        configured = self.config.signing_key_file
        if set_by_setup:
            log.warning(
                "signing %s, as the last SETUP_SIGNING left it (the state directory%s)",
                "on" if key is not None else "off",
                f"; it wins over signing_key_file {configured}" if configured else "",
            )
            return key
        if configured:
            log.info("signing on: the key of %s", configured)
            return load_signing_key(configured)
        return None

    def _save_signing_timestamp(self, timestamp: int) -> None:
        """Persist a newer signing timestamp; a failure is logged (once) and the packet still used: a
        replay across a restart is then possible until the state directory is writable again."""
        try:
            self.store.save_signing_timestamp(timestamp)
            self._signing_save_failed = False
        except OSError as exc:
            if not self._signing_save_failed:
                log.error("signing timestamp not saved (%s): a replay across a restart is possible", exc)
            self._signing_save_failed = True

    # ---- the loop's API (thread-safe, cheap) ----------------------------------------------------
    def take_requests(self) -> list[Request]:
        """The requests not taken yet, oldest first; answer each exactly once with :meth:`answer`."""
        return self.requests.take()

    def answer(self, request_id: int, verdict: Verdict) -> None:
        """The core's verdict on a taken request (sent from the I/O thread)."""
        self.requests.answer(request_id, verdict)

    def notify(self, notes: list[Note]) -> None:
        """Each note becomes one STATUSTEXT (chunked when long; severity mapped in one place)."""
        if not notes:
            return
        with self._lock:
            room = self._notes.maxlen or 0
            self._notes_dropped += max(0, len(self._notes) + len(notes) - room)
            self._notes.extend(notes)
        self.transport.wake()

    def publish(self, snapshot: VehicleSnapshot) -> None:
        """Store the loop's latest state (call once per tick; O(1), never blocks on I/O)."""
        self.telemetry.publish(snapshot)

    def mission(self) -> Mission:
        """The accepted mission (goals and fence obstacles)."""
        return self.missions.mission()

    def progress(self) -> int | None:
        """The persisted progress (goal index) of the stored mission at boot, or None."""
        return self.missions.progress()

    @property
    def ports(self) -> list[int]:
        """Local ports of the link's sockets (after :meth:`start`), in config order."""
        return self.transport.ports

    def stats(self) -> dict[str, int]:
        """Receive/transmit/mission/command counters."""
        d = dict(self.transport.rx.__dict__)
        d.update({f"mission_{k}": v for k, v in self.missions.server.stats.__dict__.items()})
        d["tx_packets"] = self.transport.tx_packets
        d["tx_errors"] = self.transport.tx_errors
        d["tx_shed"] = self.transport.tx_shed  # beyond a peer's output budget, dropped for it alone
        d["tcp_closed_idle"] = self.transport.tcp_closed_idle
        d["command_acks"] = self.commands.acks
        d["request_timeouts"] = self.requests.timeouts
        d["notes_dropped"] = self._notes_dropped
        return d

    # ---- lifecycle -----------------------------------------------------------------------------
    def start(self) -> None:
        """Open the sockets and start the I/O thread."""
        self.transport.open()
        self._thread = threading.Thread(target=self._run, name="mavlink-link", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        """Stop the I/O thread, close the sockets and the mission-check worker."""
        self._stop.set()
        self.transport.wake()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
        self.transport.close()
        self.missions.close()

    def __enter__(self) -> VehicleLink:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    # ---- I/O thread ----------------------------------------------------------------------------
    def _run(self) -> None:
        while not self._stop.is_set():
            now = self._clock()
            timeout = max(0.0, min(self._next_deadline(now) - now, MAX_WAIT_S))
            if not self.transport.wait(timeout):
                break
            try:
                self.poll(self._clock())
            except Exception:  # never let a bug kill the link silently
                log.exception("MAVLink timer failed")

    def _next_deadline(self, now: float) -> float:
        t = self.telemetry.next_deadline()
        for d in (self.missions.next_deadline(), self.requests.next_deadline()):
            if d is not None:
                t = min(t, d)
        with self._lock:
            if self._notes:
                t = now
        return t

    def poll(self, now: float) -> None:
        """The timers (I/O thread; tests call it directly): answers, uploads, notes, streams, GCS watch."""
        self.requests.poll(now)
        snap = self.telemetry.snapshot() if self.telemetry.published else None
        self.missions.poll(now, snap)
        while True:
            with self._lock:
                if not self._notes:
                    break
                note = self._notes.popleft()
            self.transport.statustext(note.severity, note.text)
        self._watch_gcs(now)
        self._watch_storage(now)
        self.telemetry.poll(now)

    def dispatch(self, msg: mavlink.MAVLink_message, sender: Sender, now: float) -> None:
        """One received message (I/O thread; tests call it directly)."""
        kind = msg.get_type()
        if kind == "HEARTBEAT":
            # with signing on, only a signed heartbeat is the operator's
            if msg.type == mavlink.MAV_TYPE_GCS and (msg.get_signed() or not self.transport.signing):
                self._gcs_heard(now)
                self._station_heard(sender, now)
            return
        if kind == "SETUP_SIGNING":
            self._setup_signing(msg, sender)
            return
        if kind == "SET_GPS_GLOBAL_ORIGIN":
            self._set_origin(msg, sender)
            return
        if kind == "MISSION_SET_CURRENT" or kind.startswith("COMMAND_"):
            self.commands.handle(msg, sender, now)
        elif kind.startswith(("MISSION_", "PARAM_")) and self.params.booting:
            return  # persisted edits not in force yet: nothing served or judged before them (asked again)
        elif kind.startswith("MISSION_"):
            self.missions.handle(msg, sender, now)
        elif kind.startswith("PARAM_"):
            self.params.handle(msg, sender, now)
        elif kind == "FILE_TRANSFER_PROTOCOL":
            self.ftp.handle(msg, sender)

    # ---- SET_GPS_GLOBAL_ORIGIN -------------------------------------------------------------------
    def _set_origin(self, msg: mavlink.MAVLink_message, sender: Sender) -> None:
        """Move the local frame's geodetic origin (the mission service owns it); no ACK in MAVLink: the
        answer is GPS_GLOBAL_ORIGIN (and HOME_POSITION) to every station, or the refusal's STATUSTEXT."""
        if int(msg.target_system) not in (0, self.config.system_id):
            return
        lat, lon, alt = msg.latitude / 1e7, msg.longitude / 1e7, msg.altitude / 1000.0
        why = self.missions.set_origin(lat, lon, alt)
        if why:
            log.warning("SET_GPS_GLOBAL_ORIGIN from %s refused: %s", sender, why)
            self.transport.statustext(Severity.WARNING, why, to=sender)
            return
        log.info("origin set to %.7f, %.7f, %.1f m by %s/%s", lat, lon, alt, sender[0], sender[1])
        self.transport.statustext(Severity.NOTICE, f"origin set to {lat:.7f}, {lon:.7f}, {alt:.1f} m")
        self.telemetry.send_message(mavlink.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN)
        self.telemetry.send_message(mavlink.MAVLINK_MSG_ID_HOME_POSITION)

    # ---- SETUP_SIGNING ---------------------------------------------------------------------------
    def _setup_signing(self, msg: mavlink.MAVLink_message, sender: Sender) -> None:
        """Set (or, an all-zero key, clear) the signing key, as the MAVLink signing guide says:
        taken only signed with the current key or over a secure endpoint (``[mavlink] secure_endpoints``),
        persisted (it wins over the key file at the next boot), then used for everything that follows."""
        if not addressed_to(msg, self.config.system_id, self.config.component_id):
            return
        who = f"{sender.system_id}/{sender.component_id}"
        if not (msg.get_signed() or self.transport.is_secure(sender.link)):
            reason = (
                f"SETUP_SIGNING from {who} refused: not signed with the current key and not over a secure "
                "endpoint ([mavlink] secure_endpoints)"
            )
            log.warning("%s", reason)
            self.transport.statustext(Severity.WARNING, reason, to=sender)
            return
        key = bytes(msg.secret_key)
        timestamp = int(msg.initial_timestamp)
        off = not any(key)  # the spec's "all zero" (a zero key with a timestamp: no key anyone should use)
        try:
            self.store.save_signing_key(None if off else key)
        except OSError as exc:
            reason = f"SETUP_SIGNING from {who} refused: the key could not be saved ({exc})"
            log.error("%s", reason)
            self.transport.statustext(Severity.ERROR, reason, to=sender)
            return
        # never below the newest timestamp accepted before, across a restart too (the persisted floor)
        self.transport.set_signing(None if off else key, max(timestamp, self.store.load_signing_timestamp()))
        text = (
            f"signing off (SETUP_SIGNING from {who})"
            if off
            else (
                f"signing key set by {who}: from now on only signed messages are taken "
                "(HEARTBEAT and RADIO_STATUS also unsigned)"
            )
        )
        log.warning("%s", text)
        self.transport.statustext(Severity.NOTICE, text, to=sender)

    # ---- GCS heartbeat watch -------------------------------------------------------------------
    def _gcs_heard(self, now: float) -> None:
        first = self._gcs_last_s is None
        self._gcs_last_s = now
        if first:
            for line in self.store.quarantined():
                self.transport.statustext(Severity.WARNING, line)
        if self._gcs_lost:
            self._gcs_lost = False
            self.transport.statustext(Severity.NOTICE, "GCS link regained")
            log.info("ground-station link regained")

    # ---- storage -------------------------------------------------------------------------------
    def _station_heard(self, sender: Sender, now: float) -> None:
        """A GCS HEARTBEAT: a station that connects (new link, or silent for ``gcs_timeout_s``) hears
        what it must know of the storage."""
        link = sender.link if isinstance(sender, Sender) else None
        if link is None:
            return
        last = self._stations.get(link)
        self._stations[link] = now
        if last is not None and now - last <= self.config.gcs_timeout_s:
            return
        if len(self._stations) > MAX_STATIONS:  # the oldest first: a flood of addresses forgets itself
            for old in sorted(self._stations, key=self._stations.__getitem__)[: len(self._stations) // 2]:
                del self._stations[old]
        problem = self.store.problem()
        if problem:
            self.transport.statustext(Severity.ERROR, storage_text(problem), to=sender)

    def _watch_storage(self, now: float) -> None:
        """Probe again while nothing can be saved; a change of the storage health to every station."""
        problem = self.store.reprobe(now)
        if problem == self._storage_said:
            return
        self._storage_said = problem
        if problem:
            self.transport.statustext(Severity.ERROR, storage_text(problem))
        else:
            self.transport.statustext(Severity.NOTICE, "storage: writable again")

    def _watch_gcs(self, now: float) -> None:
        last = self._gcs_last_s
        if last is None or self._gcs_lost or now - last <= self.config.gcs_timeout_s:
            return
        self._gcs_lost = True
        action = self.config.gcs_loss_action
        self.transport.statustext(Severity.WARNING, f"GCS heartbeat lost: action {action}")
        log.warning("ground-station link lost: action %s", action)
        self.requests.submit(
            core.LinkLost(action, source="MAVLink GCS watch"),
            lambda v: log.info("link loss (%s): %s (%s)", action, v.outcome.value, v.reason),
        )
