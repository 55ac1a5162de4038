"""``python -m onboard.app.params_doc > docs/parameters.md``: the parameter reference page, generated.

The page is :func:`onboard.core.params.parameters_markdown` with the DBC's command ranges (read here, at the
edge: the core has no cantools) and the declared keys of the program's tables (``[bus]``, ``[loop]``,
``[mavlink]``, ``[log]``: :data:`APP_TABLES`);
``tests/unit/params/test_params_doc.py`` fails when the committed page differs, so a declaration changed
without regenerating the page fails CI.
"""

from __future__ import annotations

import sys
from pathlib import Path

from onboard.adapters.mavlink.config import MavlinkConfig
from onboard.app.flight_log import LogConfig
from onboard.app.loop import LoopConfig
from onboard.core.params import BusLimits, parameters_markdown
from onboard.protocol.bus import BusConfig
from onboard.protocol.codec import command_ranges

#: Where the page lives in the repository.
PAGE_PATH = Path(__file__).resolve().parents[2] / "docs" / "parameters.md"

#: The program's tables on the page after the core's, (table name, its defaults), in the file's order.
APP_TABLES: tuple[tuple[str, object], ...] = (
    ("bus", BusConfig()),
    ("loop", LoopConfig()),
    ("mavlink", MavlinkConfig()),
    ("log", LogConfig()),
)


def page() -> str:
    """The text of ``docs/parameters.md``."""
    return parameters_markdown(BusLimits.from_ranges(command_ranges()), APP_TABLES)


def main() -> int:
    sys.stdout.write(page())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
