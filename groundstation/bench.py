"""``python -m groundstation.bench --json PATH [--quick] [--only SECTION]``: the ground station's sections.

Run by ``auv-bench`` as a subprocess (it merges the JSON of every package). Each section is a module with
``run(quick) -> dict[str, float]`` (flat, unit-suffixed figure names); a section that fails is reported as
``{"error": ...}`` and the others still run. This module imports only ``groundstation`` and the shared
``auv_common`` (the import contract); the vehicle side of the mission upload runs as a real process (see
:mod:`groundstation.bench_upload`), and so do the vehicle, the bench and the flooders of ``links`` (see
:mod:`groundstation.bench_links`).
"""

from __future__ import annotations

import sys

from auv_common.cli import run_bench_sections

# section name -> module with ``run(quick) -> dict[str, float]``
SECTIONS = {
    "mission_upload": "groundstation.bench_upload",
    "links": "groundstation.bench_links",
}


def main(argv: list[str] | None = None) -> int:
    return run_bench_sections("python -m groundstation.bench", SECTIONS, argv)


if __name__ == "__main__":
    sys.exit(main())
