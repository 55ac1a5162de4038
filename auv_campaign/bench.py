"""``python -m auv_campaign.bench --json PATH [--quick] [--only SECTION]``: the campaign's benchmark section.

Run by ``auv-bench`` as a subprocess (it merges the JSON of every package). The ``campaign`` section
(:mod:`auv_campaign.bench_campaign`): missions per minute with one and with all local workers, against one
``auv-hil scenario`` over processes, and where the wall time of a lock-step tick goes.
"""

from __future__ import annotations

import sys

from auv_common.cli import run_bench_sections

# section name -> module with ``run(quick) -> dict[str, float]``
SECTIONS = {"campaign": "auv_campaign.bench_campaign"}


def main(argv: list[str] | None = None) -> int:
    return run_bench_sections("python -m auv_campaign.bench", SECTIONS, argv)


if __name__ == "__main__":
    sys.exit(main())
