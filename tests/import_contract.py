"""The import contract that import-linter's forbidden contracts cannot state on their own.

``hil_sim`` may import from ``onboard`` only ``onboard.protocol`` (and its modules). Run as
``python -m tests.import_contract`` (part of ``make lint``); exits 1 and lists each offending import.
"""

from __future__ import annotations

import sys

import grimp


def violations() -> list[str]:
    graph = grimp.build_graph("hil_sim", "onboard")
    bad = []
    for module in sorted(graph.find_children("hil_sim") | graph.find_descendants("hil_sim")):
        for imported in sorted(graph.find_modules_directly_imported_by(module)):
            if imported == "onboard" or (
                imported.startswith("onboard.")
                and not (imported == "onboard.protocol" or imported.startswith("onboard.protocol."))
            ):
                bad.append(f"{module} imports {imported}")
    return bad


def main() -> int:
    bad = violations()
    for line in bad:
        print(f"import contract broken: {line} (hil_sim may import only onboard.protocol)")
    if not bad:
        print("import contract: hil_sim imports only onboard.protocol from onboard")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
