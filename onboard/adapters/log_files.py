"""The flight logs on disk: the one rule of their names and their order. The writer
(:mod:`onboard.app.flight_log`) and the MAVLink FTP server (:mod:`onboard.adapters.mavlink.ftp`) both ask
it."""

from __future__ import annotations

import re
from pathlib import Path

#: ``flight-YYYYmmdd-HHMMSS.mcap`` (UTC start), ``-N`` for the N-th started in the same second.
FILE_NAME = re.compile(r"^flight-(\d{8}-\d{6})(?:-(\d+))?\.mcap$")


def log_files(directory: Path) -> list[Path]:
    """The flight logs in ``directory``, oldest first (by the start time in the name; other files ignored)."""
    found = []
    try:
        entries = list(Path(directory).iterdir())
    except OSError:
        return []
    for p in entries:
        m = FILE_NAME.match(p.name)
        if m and p.is_file():
            found.append(((m.group(1), int(m.group(2) or 1)), p))
    return [p for _, p in sorted(found)]
