"""``auv-gcs map``: the vehicle, its track, goals, obstacles and planned path on a map in the browser.

:mod:`~groundstation.map.state` turns MAVLink messages into the map's picture (pure, unit-tested);
:mod:`~groundstation.map.server` serves the page and pushes the pictures over a websocket; ``static/`` holds
the page (its own JS and SVG: nothing from the network). This module is what ``auv-gcs`` imports: the
sub-command's arguments, and :func:`run`, which loads the server (aiohttp) only when the map is asked for.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from rich.text import Text

    from groundstation.mavclient import MavClient

DEFAULT_PORT = 8600
HOST = "127.0.0.1"


def add_parser(subparsers: Any) -> None:
    """The ``map`` sub-command: ``map [--port P] [--tlog FILE]``."""
    p = subparsers.add_parser(
        "map",
        help=f"live map in the browser on http://{HOST}:PORT/ (vehicle, track, goals, obstacles, planned "
        "path, state, errors); --tlog FILE replays a recording with a time slider instead of connecting",
    )
    p.add_argument("--port", type=int, default=DEFAULT_PORT, help=f"HTTP port (default {DEFAULT_PORT})")
    p.add_argument("--tlog", type=Path, default=None, help="replay this tlog instead of connecting")


def run(
    args: argparse.Namespace,
    client_factory: Callable[[], MavClient],
    done: Callable[[dict[str, Any], str | Text], None],
) -> int:
    """Serve the map until SIGINT / SIGTERM (:func:`groundstation.map.server.run`)."""
    from groundstation.map import server

    return server.run(args, client_factory, done, host=HOST)
