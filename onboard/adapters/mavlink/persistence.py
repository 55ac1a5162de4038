"""Atomic JSON state files: write to a temporary file, fsync, rename, fsync the directory.

After :func:`write_json_atomic` returns, a kill -9 or power loss leaves either the old or the new file,
never a partial one. The MAVLink endpoint calls it before it acknowledges a mission, a fence or a parameter.
"""

from __future__ import annotations

import json
import logging
import os
from pathlib import Path
from typing import Any

from onboard.adapters.mavlink.mission_protocol import TYPE_FENCE, TYPE_MISSION, MissionItem

log = logging.getLogger(__name__)

FILE_NAMES = {TYPE_MISSION: "mission.json", TYPE_FENCE: "fence.json"}
PARAMS_FILE = "params.json"
FORMAT_VERSION = 1


def write_json_atomic(path: Path, data: Any) -> None:
    """Write ``data`` as JSON to ``path`` atomically and durably."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    with tmp.open("w", encoding="utf-8") as f:
        json.dump(data, f, indent=1, allow_nan=False)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)
    fd = os.open(path.parent, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def read_json(path: Path) -> Any | None:
    """The JSON content of ``path``, or None if it is missing or unreadable (logged)."""
    try:
        with path.open("r", encoding="utf-8") as f:
            return json.load(f)
    except FileNotFoundError:
        return None
    except (OSError, ValueError) as exc:
        log.error("ignoring unreadable state file %s: %s", path, exc)
        return None


class StateStore:
    """The endpoint's state directory: mission.json, fence.json, params.json."""

    def __init__(self, state_dir: Path) -> None:
        self.dir = state_dir

    def save_plan(self, mission_type: int, items: tuple[MissionItem, ...]) -> None:
        write_json_atomic(
            self.dir / FILE_NAMES[mission_type],
            {"version": FORMAT_VERSION, "items": [i.to_json() for i in items]},
        )

    def load_plan(self, mission_type: int) -> tuple[MissionItem, ...] | None:
        data = read_json(self.dir / FILE_NAMES[mission_type])
        if data is None:
            return None
        try:
            return tuple(MissionItem.from_json(d) for d in data["items"])
        except (KeyError, TypeError, ValueError) as exc:
            log.error("ignoring malformed %s: %s", FILE_NAMES[mission_type], exc)
            return None

    def save_params(self, values: dict[str, float]) -> None:
        write_json_atomic(self.dir / PARAMS_FILE, {"version": FORMAT_VERSION, "params": values})

    def load_params(self) -> dict[str, float]:
        data = read_json(self.dir / PARAMS_FILE)
        if not isinstance(data, dict) or not isinstance(data.get("params"), dict):
            return {}
        return {str(k): float(v) for k, v in data["params"].items() if isinstance(v, int | float)}
