"""The import contracts that import-linter's contracts cannot state on their own.

- ``hil_sim`` may import from ``onboard`` only ``onboard.protocol`` (and its modules).
- No import cycle anywhere: no module of the project's packages reaches itself through its imports (those
  inside functions count too: a lazy import is still a dependency; so do those under ``if TYPE_CHECKING:``:
  a type named in an annotation is a dependency of the design, and a protocol breaks such a circle, as
  ``onboard.core.vehicle.Core`` and ``executive.maneuver.Plans`` do). import-linter's ``acyclic_siblings``
  judges packages, not modules, and misses a package that imports its own child and back.

Run as ``python -m tests.import_contract`` (part of ``make lint``); exits 1 and lists each offending import
and each cycle.
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


#: The project's packages: the cycle check covers every module of each.
PACKAGES = ("onboard", "hil_sim", "groundstation", "auv_bench", "auv_common", "auv_campaign")


def import_cycles(graph: grimp.ImportGraph | None = None) -> list[list[str]]:
    """Each group of modules that import one another in a circle (a strongly connected component of the
    module import graph with more than one module), sorted; [] when none. A module importing itself (the
    hub's ``__main__`` block loads its own module by name) is no circle.

    Tarjan's algorithm, iterative (no recursion limit)."""
    graph = graph or grimp.build_graph(*PACKAGES, exclude_type_checking_imports=False)
    edges = {m: sorted(graph.find_modules_directly_imported_by(m)) for m in sorted(graph.modules)}
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    cycles: list[list[str]] = []
    for root in edges:
        if root in index:
            continue
        work = [(root, iter(edges[root]))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, todo = work[-1]
            for nxt in todo:
                if nxt not in index:
                    index[nxt] = low[nxt] = len(index)
                    stack.append(nxt)
                    on_stack.add(nxt)
                    work.append((nxt, iter(edges.get(nxt, []))))
                    break
                if nxt in on_stack:
                    low[node] = min(low[node], index[nxt])
            else:
                work.pop()
                if work:
                    parent = work[-1][0]
                    low[parent] = min(low[parent], low[node])
                if low[node] == index[node]:
                    group = []
                    while True:
                        member = stack.pop()
                        on_stack.discard(member)
                        group.append(member)
                        if member == node:
                            break
                    if len(group) > 1:
                        cycles.append(sorted(group))
    return sorted(cycles)


def _cycle_text(graph: grimp.ImportGraph, group: list[str]) -> str:
    """One cycle of the group, as ``a -> b -> a``."""
    first = group[0]
    back = min(
        (graph.find_shortest_chain(importer=nxt, imported=first) or () for nxt in group[1:]
         if graph.direct_import_exists(importer=first, imported=nxt)),
        key=len,
        default=(),
    )  # fmt: skip
    return " -> ".join([first, *back]) if back else ", ".join(group)


def main() -> int:
    bad = violations()
    for line in bad:
        print(f"import contract broken: {line} (hil_sim may import only onboard.protocol)")
    if not bad:
        print("import contract: hil_sim imports only onboard.protocol from onboard")
    graph = grimp.build_graph(*PACKAGES, exclude_type_checking_imports=False)
    cycles = import_cycles(graph)
    for group in cycles:
        print(f"import contract broken: an import cycle: {_cycle_text(graph, group)}")
    if not cycles:
        print(f"import contract: no import cycle among the {len(graph.modules)} modules")
    return 1 if bad or cycles else 0


if __name__ == "__main__":
    sys.exit(main())
