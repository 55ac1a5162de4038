"""The flight logs on disk: the one rule of their names, their order and which are kept. The writer
(:mod:`onboard.app.flight_log`) and the MAVLink FTP server (:mod:`onboard.adapters.mavlink.ftp`) both ask
it.

A name is ``flight-<seq>-YYYYmmdd-HHMMSS.mcap``: ``seq`` (six digits or more) is one more than the largest
in the directory when the run starts, the time is the UTC start for the reader. Logs are ordered by
``seq``, never by the time in the name: a clock that once ran ahead (a log named 2030) does not make an old
log look new. Names of the older firmware (``flight-YYYYmmdd-HHMMSS[-N].mcap``, no sequence) come before
every sequenced log, in the order of their mtime.

A log that saw the vehicle RUNNING (a flight, not just a boot) has an empty marker beside it,
``<name>.flew``, made by the writer at the first RUNNING tick (so a log cut by a crash keeps it: a crashed
MCAP has no footer to read; the name stays the same, so a download under way is not broken). Logs of the
older firmware have no marker and are counted as flights (nothing cheap tells; keeping them is the safe
side).

What is removed (:func:`to_remove`, pure): never the file being written; the oldest boot-only logs first,
then the oldest flights, until the directory is within its byte budget and file count.
"""

from __future__ import annotations

import datetime as dt
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

#: ``flight-<seq>-YYYYmmdd-HHMMSS.mcap``: the sequence number (creation order), the UTC start.
FILE_NAME = re.compile(r"^flight-(\d{6,})-\d{8}-\d{6}\.mcap$")
#: The older firmware's ``flight-YYYYmmdd-HHMMSS.mcap`` (``-N``: the N-th of a second): no sequence.
OLD_FILE_NAME = re.compile(r"^flight-\d{8}-\d{6}(?:-\d+)?\.mcap$")
#: The suffix of the marker beside a log that saw the vehicle RUNNING.
FLEW = ".flew"


@dataclass(frozen=True)
class LogFile:
    """One flight log as the rotation sees it. ``order``: creation order (sorts oldest first);
    ``has_flight``: it saw the vehicle RUNNING; ``is_current``: the file being written."""

    name: str
    size_bytes: int
    order: tuple[int, int, str]
    has_flight: bool
    is_current: bool = False


def log_name(seq: int, start: dt.datetime) -> str:
    """The name of the ``seq``-th log, started at ``start`` (shown in UTC)."""
    return f"flight-{seq:06d}-{start.astimezone(dt.UTC):%Y%m%d-%H%M%S}.mcap"


def sequence(name: str) -> int | None:
    """The sequence number in a log's name; 0 for the older firmware's names; None: not a log."""
    m = FILE_NAME.match(name)
    if m:
        return int(m.group(1))
    return 0 if OLD_FILE_NAME.match(name) else None


def marker(log: Path) -> Path:
    """The marker beside ``log`` that says it saw the vehicle RUNNING."""
    return log.with_name(log.name + FLEW)


def scan(directory: Path, current: Path | None = None) -> list[LogFile]:
    """The flight logs in ``directory``, oldest first (other files ignored; none if it cannot be read)."""
    try:
        entries = list(Path(directory).iterdir())
    except OSError:
        return []
    names = {p.name for p in entries}
    found = []
    for p in entries:
        seq = sequence(p.name)
        if seq is None:
            continue
        try:
            st = p.stat()
        except OSError:  # removed meanwhile
            continue
        if not p.is_file():
            continue
        flew = seq == 0 or p.name + FLEW in names
        order = (seq, st.st_mtime_ns if seq == 0 else 0, p.name)
        found.append(LogFile(p.name, st.st_size, order, flew, current is not None and p.name == current.name))
    return sorted(found, key=lambda f: f.order)


def log_files(directory: Path) -> list[Path]:
    """The flight logs in ``directory``, oldest first (creation order; other files ignored)."""
    return [Path(directory) / f.name for f in scan(directory)]


def next_sequence(directory: Path) -> int:
    """The sequence number of the next log: one more than the largest in ``directory``."""
    return max((f.order[0] for f in scan(directory)), default=0) + 1


def to_remove(logs: Sequence[LogFile], max_total_bytes: int, max_files: int) -> list[str]:
    """The names to remove so that ``logs`` fit in ``max_total_bytes`` and ``max_files``: boot-only logs
    (no RUNNING) oldest first, then flights oldest first; never the current one (if it alone is over the
    budget, it stays and everything else goes)."""
    total = sum(f.size_bytes for f in logs)
    count = len(logs)
    candidates = sorted((f for f in logs if not f.is_current), key=lambda f: (f.has_flight, f.order))
    out = []
    for f in candidates:
        if total <= max_total_bytes and count <= max_files:
            break
        out.append(f.name)
        total -= f.size_bytes
        count -= 1
    return out


def orphan_markers(directory: Path) -> list[Path]:
    """Markers whose log is gone (removed by hand, or a crash between the two removals)."""
    try:
        names = {p.name for p in Path(directory).iterdir()}
    except OSError:
        return []
    return [
        Path(directory) / n
        for n in sorted(names)
        if n.endswith(FLEW) and FILE_NAME.match(n[: -len(FLEW)]) and n[: -len(FLEW)] not in names
    ]
