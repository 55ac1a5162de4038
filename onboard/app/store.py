"""The vehicle's state store: atomic JSON files in one directory that can never brick the vehicle.

It belongs to the vehicle program, not to a link: ``auv-onboard run`` opens it with or without MAVLink
(``--no-mavlink``: the persisted parameter edits apply, the mission progress is saved and restored, the
flight logs go to ``<dir>/logs``, a directory that cannot be written is said in the log). Configured by the
``[store]`` table (:class:`StoreConfig`; ``--state-dir`` on the command line). The MAVLink link gets it
handed in, typed by the protocol it owns (:class:`onboard.adapters.mavlink.storage.Store`): adapters do not
import the program.

Files: ``mission.json`` and ``fence.json`` (the stored plans: items in the shared MISSION_ITEM_INT encoding,
:class:`auv_common.mission_items.MissionItem`), ``params.json`` (ground-station parameter edits),
``progress.json`` (the goal the mission has reached, tied to that mission by its key, an opaque string:
:func:`onboard.adapters.mavlink.storage.mission_key`),
``origin.json`` (SET_GPS_GLOBAL_ORIGIN), ``signing_key.json`` and ``signing.json`` (MAVLink signing: the key
a SETUP_SIGNING set, the newest timestamp accepted). The formats are those the MAVLink adapter wrote before
the store moved here (``onboard/adapters/mavlink/persistence.py``): a vehicle upgraded keeps its files.

Writing (:func:`write_json_atomic`): to a temporary file, fsync, rename, fsync the directory. After it
returns, a kill -9 or power loss leaves either the old or the new file, never a partial one. The MAVLink
endpoint saves a mission, a fence or a parameter before it is in force and refuses it when the save fails
(an acknowledgement means durable). A kill -9 mid-write leaves its temporary file (``.NAME.<pid>.tmp``, or
the probe's ``.write-probe.<pid>``): :meth:`StateStore.open` removes them at boot.

Storage health (:meth:`StateStore.problem`): "" while the directory can be written, else one line saying
why not (e.g. "state directory /x is not writable: No space left on device"), logged (ERROR) when it
appears. Set by the boot probe and by every write that fails; cleared by a write or a probe that succeeds
(:meth:`StateStore.reprobe` tries every ``[store] probe_period_s`` while there is a problem: a disk that
frees up is writable again without a reboot). A vehicle whose directory cannot be written still boots with
what it can read.

Reading: a file that is not valid JSON, has the wrong shape, or whose values fail the format checks (for a
plan: :class:`MissionItem` fields of the right JSON types, and the check its owner gives
:meth:`StateStore.load_plan`: the MAVLink adapter's, :func:`onboard.adapters.mavlink.storage.load_plan`,
checks each item as an upload is checked) is moved aside to ``NAME.invalid-<UTC time>`` (kept for
inspection), logged with one ERROR line and recorded: :meth:`StateStore.quarantined` returns one human line
per file, which the MAVLink link announces (STATUSTEXT) when a ground station connects. The load then
returns "nothing stored" (None, {}), so the vehicle boots with no mission rather than not at all.
"""

from __future__ import annotations

import contextlib
import datetime
import json
import logging
import math
import os
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from auv_common.config import check_declared, param
from auv_common.mission_items import MissionItem

log = logging.getLogger(__name__)

#: The two stored plans, by kind.
PlanKind = Literal["mission", "fence"]
PLAN_FILES: dict[str, str] = {"mission": "mission.json", "fence": "fence.json"}
PARAMS_FILE = "params.json"
PROGRESS_FILE = "progress.json"
SIGNING_FILE = "signing.json"
SIGNING_KEY_FILE = "signing_key.json"
ORIGIN_FILE = "origin.json"
FORMAT_VERSION = 1
#: MAVLink PARAM_* ids are at most 16 characters (the parameter names of the core's table).
MAX_PARAM_NAME = 16
#: While the directory cannot be written, a probe this often (s; one small file, synced, removed).
PROBE_PERIOD_S = 2.0
#: A progress save that failed is tried again after this (s), doubling up to the maximum.
PROGRESS_RETRY_S = 1.0
PROGRESS_RETRY_MAX_S = 30.0
_STATE_FILES = (*PLAN_FILES.values(), PARAMS_FILE, PROGRESS_FILE, SIGNING_FILE, SIGNING_KEY_FILE, ORIGIN_FILE)
#: What a kill -9 leaves: the temporary file of write_json_atomic, or the write probe (``<pid>``).
_LEFTOVER = re.compile(
    r"\.(?:(?:" + "|".join(re.escape(n) for n in _STATE_FILES) + r")\.(\d+)\.tmp|write-probe\.(\d+))"
)

_INT_FIELDS = ("frame", "command", "x", "y", "autocontinue")
_FLOAT_FIELDS = ("param1", "param2", "param3", "param4", "z")  # null = NaN

#: The check a plan's owner gives :meth:`StateStore.load_plan`: ``(seq, item) -> why it is invalid``
#: ("" valid).
ItemCheck = Callable[[int, MissionItem], str]


def default_state_dir() -> Path:
    """Per-user state path: ``$XDG_STATE_HOME/isimi100`` or ``~/.local/state/isimi100``."""
    base = os.environ.get("XDG_STATE_HOME") or str(Path.home() / ".local" / "state")
    return Path(base) / "isimi100"


@dataclass(frozen=True)
class StoreConfig:
    """The ``[store]`` table: where the vehicle keeps what must survive a restart.

    ``dir``: the directory ("" = :func:`default_state_dir`; ``--state-dir`` on the command line). It was
    ``[mavlink] state_dir`` (refused now, with the reason): the store is the vehicle's, not the link's.
    """

    dir: str = ""
    probe_period_s: float = param(
        PROBE_PERIOD_S, unit="s", min=0.1, max=60.0,
        desc="while the store's directory cannot be written, it is probed again this often",
    )  # fmt: skip

    def __post_init__(self) -> None:
        check_declared(self)

    def resolved_dir(self) -> Path:
        """The directory to use (the configured one or the per-user default)."""
        return Path(self.dir) if self.dir else default_state_dir()


class StateDirError(OSError):
    """The state directory cannot be created or written; the message is one line for the operator."""


class InvalidStateFile(ValueError):
    """A state file whose content is unusable; the message says why (e.g. "item 3: frame 99 unsupported")."""


def write_json_atomic(path: Path, data: Any, durable: bool = True, mode: int = 0o644) -> None:
    """Write ``data`` as JSON to ``path`` atomically and (``durable``) synced to the disk; without it the
    file survives a process crash or kill, not a power loss (for a value written many times a second).
    ``mode``: the file's permissions from its creation on (before the umask; 0o600 for a secret)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, mode)
        if not mode & 0o077:
            os.fchmod(fd, mode)  # private: also when a stale tmp of a wider mode was left there
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            json.dump(data, f, indent=1, allow_nan=False)
            f.flush()
            if durable:
                os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    if not durable:
        return
    fd = os.open(path.parent, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


# ---- format checks ---------------------------------------------------------------------------------
def _is_int(v: Any) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def _is_number(v: Any) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool)


def _shape(data: Any, key: str, kind: type) -> Any:
    if not isinstance(data, dict):
        raise InvalidStateFile(f"expected a JSON object, got {type(data).__name__}")
    if data.get("version") != FORMAT_VERSION:
        raise InvalidStateFile(f"version {data.get('version')!r}, expected {FORMAT_VERSION}")
    if not isinstance(data.get(key), kind):
        raise InvalidStateFile(f"'{key}' must be a JSON {'array' if kind is list else 'object'}")
    return data[key]


def _item_from_json(d: Any) -> MissionItem:
    if not isinstance(d, dict):
        raise InvalidStateFile(f"expected an object, got {d!r}")
    missing = [k for k in (*_INT_FIELDS, *_FLOAT_FIELDS) if k not in d]
    if missing:
        raise InvalidStateFile(f"missing {', '.join(missing)}")
    for k in _INT_FIELDS:
        if not _is_int(d[k]):
            raise InvalidStateFile(f"{k} {d[k]!r} is not an integer")
    for k in _FLOAT_FIELDS:
        if d[k] is not None and not _is_number(d[k]):
            raise InvalidStateFile(f"{k} {d[k]!r} is not a number or null")
    return MissionItem.from_json(d)


def parse_plan(data: Any, check: ItemCheck | None = None) -> tuple[MissionItem, ...]:
    """The items of a plan file's JSON content, each passing ``check`` (when given); raises
    :class:`InvalidStateFile` naming the first bad item ("item 3: frame 99 unsupported")."""
    out = []
    for seq, d in enumerate(_shape(data, "items", list)):
        try:
            item = _item_from_json(d)
        except InvalidStateFile as exc:
            raise InvalidStateFile(f"item {seq}: {exc}") from None
        why = check(seq, item) if check is not None else ""
        if why:
            raise InvalidStateFile(f"item {seq}: {why}")
        out.append(item)
    return tuple(out)


def parse_params(data: Any) -> dict[str, float]:
    """The parameter values of a params file's JSON content; raises :class:`InvalidStateFile`."""
    out = {}
    for name, value in _shape(data, "params", dict).items():
        if not 1 <= len(name) <= MAX_PARAM_NAME:
            raise InvalidStateFile(f"parameter name {name!r} is not 1..{MAX_PARAM_NAME} characters")
        if not _is_number(value) or not math.isfinite(value):
            raise InvalidStateFile(f"parameter {name} = {value!r} is not a finite number")
        out[name] = float(value)
    return out


def parse_progress(data: Any) -> tuple[str, int]:
    """(mission key, goal index) of a progress file's JSON content; raises :class:`InvalidStateFile`."""
    key = _shape(data, "mission_key", str)
    index = data.get("goal_index")
    if not _is_int(index) or index < 0:
        raise InvalidStateFile(f"goal_index {index!r} is not an integer >= 0")
    return key, index


# ---- the store ---------------------------------------------------------------------------------
class StateStore:
    """The vehicle's state directory (the module docstring): the plans, the parameter edits, the mission
    progress, the origin and the signing state. Thread-safe enough for its use: one writer per file (the
    MAVLink I/O thread, or the loop's progress without MAVLink)."""

    def __init__(self, state_dir: Path | str, probe_period_s: float = PROBE_PERIOD_S) -> None:
        self.dir = Path(state_dir)
        self.probe_period_s = probe_period_s
        self._quarantined: list[str] = []
        self._problem = ""
        self._opened = False
        self._next_probe_s = 0.0
        self._progress_saved: tuple[str, int] | None = None  # (mission key, goal) on the disk
        self._progress_failed = False  # said once until a save works again
        self._progress_retry_s = 0.0  # the next try after a failure (monotonic), and the back-off
        self._progress_backoff_s = PROGRESS_RETRY_S

    @classmethod
    def of(cls, config: StoreConfig) -> StateStore:
        """The store of the ``[store]`` table."""
        return cls(config.resolved_dir(), config.probe_period_s)

    # ---- start-up checks and storage health ------------------------------------------------------
    def open(self) -> str:
        """At boot (once; again is a no-op): remove what killed writers left, probe the directory.

        Never raises: a directory that cannot be written is logged (ERROR) and returned as the problem
        (:meth:`problem`); the vehicle boots with what it can read.
        """
        if self._opened:
            return self._problem
        self._opened = True
        self.remove_leftovers()
        problem = self.probe()
        if problem:
            log.error("%s: nothing can be saved (missions, parameters, progress are refused)", problem)
        return problem

    def remove_leftovers(self) -> list[str]:
        """Remove the temporary files a killed writer left (``.NAME.<pid>.tmp``, ``.write-probe.<pid>``;
        never this process's own); returns their names."""
        removed = []
        try:
            names = os.listdir(self.dir)
        except OSError:
            return []
        own = str(os.getpid())
        for name in names:
            m = _LEFTOVER.fullmatch(name)
            if m is None or own in m.groups():
                continue
            try:
                (self.dir / name).unlink()
            except OSError as exc:
                log.warning("state directory %s: cannot remove the leftover %s: %s", self.dir, name, exc)
                continue
            removed.append(name)
        if removed:
            log.info("state directory %s: removed what killed writers left: %s", self.dir, ", ".join(removed))
        return removed

    def problem(self) -> str:
        """Why the directory cannot be written ("" if the last write or probe worked)."""
        return self._problem

    def probe(self) -> str:
        """Probe the directory now (:meth:`check_writable`); returns and records the problem ("" none)."""
        try:
            self.check_writable()
            self._set_problem("")
        except StateDirError as exc:
            self._set_problem(str(exc))
        return self._problem

    def reprobe(self, now_s: float) -> str:
        """While there is a problem, probe at most every ``probe_period_s`` (``now_s``: monotonic)."""
        if self._problem and now_s >= self._next_probe_s:
            self._next_probe_s = now_s + self.probe_period_s
            self.probe()
        return self._problem

    def _set_problem(self, problem: str) -> None:
        if problem == self._problem:
            return
        if problem:
            log.error("%s", problem)
        else:
            log.warning("state directory %s is writable again", self.dir)
        self._problem = problem

    def _write(self, name: str, data: Any, durable: bool = True, mode: int = 0o644) -> None:
        """Every save: :func:`write_json_atomic`, the outcome recorded as the storage health; a failure
        raises :class:`StateDirError` with one line ("state directory /x is not writable: <why>")."""
        try:
            write_json_atomic(self.dir / name, data, durable=durable, mode=mode)
        except OSError as exc:
            problem = f"state directory {self.dir} is not writable: {exc.strerror or exc}"
            self._set_problem(problem)
            raise StateDirError(problem) from exc
        self._set_problem("")

    def check_writable(self) -> None:
        """Create the directory if needed and prove it writable (a probe file, fsynced, removed).

        Raises :class:`StateDirError` with one line, e.g. "state directory /x is not writable: Permission
        denied".
        """
        try:
            self.dir.mkdir(parents=True, exist_ok=True)
        except FileExistsError:
            raise StateDirError(f"state directory {self.dir} is not a directory") from None
        except OSError as exc:
            raise StateDirError(f"state directory {self.dir} cannot be created: {exc.strerror}") from None
        if not self.dir.is_dir():
            raise StateDirError(f"state directory {self.dir} is not a directory")
        probe = self.dir / f".write-probe.{os.getpid()}"
        try:
            with probe.open("w", encoding="utf-8") as f:
                f.write("probe")
                f.flush()
                os.fsync(f.fileno())
            probe.unlink()
        except OSError as exc:
            with contextlib.suppress(OSError):
                probe.unlink(missing_ok=True)
            raise StateDirError(f"state directory {self.dir} is not writable: {exc.strerror}") from None

    def quarantined(self) -> list[str]:
        """One human line per state file found invalid and moved aside since this store was made."""
        return list(self._quarantined)

    def quarantine(self, name: str, why: str) -> str:
        """Move the state file ``name`` aside to ``name.invalid-<UTC time>``, log and record it.

        Public so that the runtime can set aside a plan that is well formed but fails the whole-mission
        check. Returns the recorded line.
        """
        path = self.dir / name
        stamp = datetime.datetime.now(datetime.UTC).strftime("%Y%m%dT%H%M%SZ")
        target = path.with_name(f"{name}.invalid-{stamp}")
        n = 1
        while target.exists():
            target = path.with_name(f"{name}.invalid-{stamp}-{n}")
            n += 1
        try:
            os.replace(path, target)
            line = f"{name} was invalid ({why}) and was moved to {target.name}"
        except OSError as exc:
            line = f"{name} was invalid ({why}) and is ignored (could not be moved aside: {exc.strerror})"
        log.error("state directory %s: %s", self.dir, line)
        self._quarantined.append(line)
        return line

    def _load(self, name: str) -> Any | None:
        """The JSON content of a state file; None if it does not exist or was invalid JSON (quarantined)."""
        path = self.dir / name
        try:
            with path.open("r", encoding="utf-8") as f:
                return json.load(f, parse_constant=_refuse_constant)
        except FileNotFoundError:
            return None
        except (OSError, ValueError, RecursionError) as exc:  # RecursionError: nested absurdly deep
            if isinstance(exc, OSError):
                why = exc.strerror or str(exc)
            else:
                why = f"not valid JSON: {_why(exc)}"
            self.quarantine(name, why)
            return None

    # ---- plans -----------------------------------------------------------------------------------
    def save_plan(self, kind: PlanKind, items: Sequence[MissionItem]) -> None:
        """Save the ``kind`` plan ("mission" or "fence"); raises :class:`StateDirError` when it cannot."""
        self._write(PLAN_FILES[kind], {"version": FORMAT_VERSION, "items": [i.to_json() for i in items]})

    def load_plan(self, kind: PlanKind, check: ItemCheck | None = None) -> tuple[MissionItem, ...] | None:
        """The stored ``kind`` plan, each item passing ``check`` (the plan owner's: what an item means is
        not the store's); None: nothing stored, or the file was invalid and was set aside."""
        name = PLAN_FILES[kind]
        data = self._load(name)
        if data is None:
            return None
        try:
            return parse_plan(data, check)
        except Exception as exc:  # anything in untrusted content (e.g. a 400-digit number) means invalid
            self.quarantine(name, _why(exc))
            return None

    def quarantine_plan(self, kind: PlanKind, why: str) -> str:
        """:meth:`quarantine` the ``kind`` plan file (well formed, but refused by the whole-mission check)."""
        return self.quarantine(PLAN_FILES[kind], why)

    # ---- parameters ------------------------------------------------------------------------------
    def save_params(self, values: dict[str, float]) -> None:
        self._write(PARAMS_FILE, {"version": FORMAT_VERSION, "params": values})

    def load_params(self) -> dict[str, float]:
        """The persisted parameter values, or {} (nothing stored, or the file was invalid and set aside)."""
        data = self._load(PARAMS_FILE)
        if data is None:
            return {}
        try:
            return parse_params(data)
        except Exception as exc:  # anything in untrusted content (e.g. a 400-digit number) means invalid
            self.quarantine(PARAMS_FILE, _why(exc))
            return {}

    # ---- geodetic origin (SET_GPS_GLOBAL_ORIGIN) ---------------------------------------------------
    def save_origin(self, lat_deg: float, lon_deg: float, alt_m: float) -> None:
        self._write(
            ORIGIN_FILE,
            {"version": FORMAT_VERSION, "lat_deg": lat_deg, "lon_deg": lon_deg, "alt_m": alt_m},
        )

    def load_origin(self) -> tuple[float, float, float] | None:
        """The origin a ground station set (lat, lon, alt AMSL), or None (never set, or set aside)."""
        data = self._load(ORIGIN_FILE)
        if data is None:
            return None
        try:
            lat, lon, alt = (float(data[k]) for k in ("lat_deg", "lon_deg", "alt_m"))
            if not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0 and math.isfinite(alt)):
                raise ValueError(f"origin out of range: {lat}, {lon}, {alt}")
            return lat, lon, alt
        except Exception as exc:  # anything in untrusted content means invalid
            self.quarantine(ORIGIN_FILE, _why(exc))
            return None

    # ---- mission progress ------------------------------------------------------------------------
    def save_progress(self, goal_index: int, mission_key: str) -> None:
        """Persist the active goal of the mission whose key is ``mission_key``."""
        if not _is_int(goal_index) or goal_index < 0:
            raise ValueError(f"goal_index must be an integer >= 0, got {goal_index!r}")
        self._write(
            PROGRESS_FILE,
            {"version": FORMAT_VERSION, "mission_key": mission_key, "goal_index": goal_index},
        )

    def load_progress(self, mission_key: str) -> int | None:
        """The persisted goal index if it belongs to the mission ``mission_key``; else None.

        Progress of another mission is never applied (logged, the file is left alone: it is not invalid).
        """
        data = self._load(PROGRESS_FILE)
        if data is None:
            return None
        try:
            key, index = parse_progress(data)
        except Exception as exc:  # anything in untrusted content (e.g. a 400-digit number) means invalid
            self.quarantine(PROGRESS_FILE, _why(exc))
            return None
        if key != mission_key:
            log.info("progress.json belongs to another mission; starting at goal 0")
            return None
        self._progress_saved = (key, index)
        return index

    def keep_progress(self, goal_index: int, mission_key: str, now_s: float) -> tuple[bool, str] | None:
        """The one rule of when the mission progress is written, for the MAVLink link and the vehicle
        without it alike: save ``goal_index`` of the mission ``mission_key`` unless it is what the file holds
        (saved or loaded); after a failure, try again with back-off (:data:`PROGRESS_RETRY_S` doubling to
        :data:`PROGRESS_RETRY_MAX_S`, ``now_s`` monotonic), at once when the directory is writable again.

        Returns news for the operator, logged here already: ``(False, why)`` once when saving starts to
        fail, ``(True, line)`` when it works again; None otherwise.
        """
        now = (mission_key, goal_index)
        if now == self._progress_saved or goal_index < 0:
            return None
        if self._progress_failed and now_s < self._progress_retry_s and self._problem:
            return None  # back off, unless the directory was found writable again
        try:
            self.save_progress(goal_index, mission_key)
        except (OSError, ValueError) as exc:
            self._progress_retry_s = now_s + self._progress_backoff_s
            self._progress_backoff_s = min(2.0 * self._progress_backoff_s, PROGRESS_RETRY_MAX_S)
            if self._progress_failed:
                return None
            self._progress_failed = True
            text = f"mission progress (goal {goal_index}) not saved, retrying: {exc}"
            log.error("%s", text)
            return False, text
        self._progress_saved = now
        if not self._progress_failed:
            return None
        self._progress_failed = False
        self._progress_backoff_s = PROGRESS_RETRY_S
        log.warning("mission progress (goal %d) saved again", goal_index)
        return True, f"mission progress (goal {goal_index}) saved"

    # ---- signing ---------------------------------------------------------------------------------
    def save_signing_key(self, key: bytes | None) -> None:
        """Persist the key a SETUP_SIGNING set (None: signing turned off); it wins over the configured key
        file at the next boot. Owner-only (0600) from its creation, atomic and synced."""
        data = {"version": FORMAT_VERSION, "key": key.hex() if key is not None else None}
        self._write(SIGNING_KEY_FILE, data, mode=0o600)

    def load_signing_key(self) -> tuple[bool, bytes | None]:
        """(set, key): whether a SETUP_SIGNING set the key, and the key (None: off). A file that exists but
        cannot be read or is invalid is set aside and fails closed: a random key nobody holds, persisted in
        its place (only what signing lets through unsigned gets in; a SETUP_SIGNING over a secure endpoint
        sets a new key)."""
        path = self.dir / SIGNING_KEY_FILE
        if not os.path.lexists(path):
            return False, None
        data = self._load(SIGNING_KEY_FILE)
        if data is None:
            return True, self._lock_signing()
        try:
            text = _shape(data, "key", object)
            if text is None:
                return True, None
            if not isinstance(text, str):
                raise ValueError("'key' must be 64 hex characters or null")
            key = bytes.fromhex(text)
            if len(key) != 32:
                raise ValueError(f"a signing key has 32 bytes, got {len(key)}")
            return True, key
        except Exception as exc:  # anything in untrusted content means invalid
            self.quarantine(SIGNING_KEY_FILE, _why(exc))
            return True, self._lock_signing()

    def _lock_signing(self) -> bytes:
        """A key nobody holds, in force and persisted in place of the file set aside (so the next boots fail
        closed too, until a SETUP_SIGNING over a secure endpoint sets a key)."""
        key = os.urandom(32)
        try:
            self.save_signing_key(key)
        except OSError as exc:
            log.error("signing key file not replaced (%s): this boot refuses all but unsigned HEARTBEAT", exc)
        return key

    def save_signing_timestamp(self, timestamp: int) -> None:
        """Persist the newest signing timestamp accepted (10 us units since 2015): after a restart no packet
        at or below it is accepted (a replay). Written at every advance, atomically, not synced."""
        self._write(SIGNING_FILE, {"version": FORMAT_VERSION, "timestamp": int(timestamp)}, durable=False)

    def load_signing_timestamp(self) -> int:
        """The persisted signing timestamp, or 0 (none; an invalid file is set aside)."""
        data = self._load(SIGNING_FILE)
        if data is None:
            return 0
        try:
            ts = _shape(data, "timestamp", int)
            if not (_is_int(ts) and 0 <= ts < 1 << 48):
                raise ValueError(f"timestamp must be a 48-bit integer, got {ts!r}")
            return int(ts)
        except Exception as exc:  # anything in untrusted content means invalid
            self.quarantine(SIGNING_FILE, _why(exc))
            return 0


def _why(exc: BaseException) -> str:
    """One line saying what is wrong with a state file."""
    text = str(exc).splitlines()[0] if str(exc) else ""
    if isinstance(exc, InvalidStateFile):
        return text
    return f"{type(exc).__name__}: {text}"[:200]


def _refuse_constant(name: str) -> float:
    """JSON has no NaN or Infinity; Python's json module accepts them unless told otherwise."""
    raise ValueError(f"{name} is not JSON")


__all__ = [
    "PLAN_FILES",
    "InvalidStateFile",
    "ItemCheck",
    "PlanKind",
    "StateDirError",
    "StateStore",
    "StoreConfig",
    "default_state_dir",
    "write_json_atomic",
]
