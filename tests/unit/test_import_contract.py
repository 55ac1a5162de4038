"""The import-cycle check of ``make lint`` (:mod:`tests.import_contract`) on small graphs of its own."""

from __future__ import annotations

import grimp

from tests.import_contract import import_cycles


def graph(*imports: tuple[str, str]) -> grimp.ImportGraph:
    g = grimp.ImportGraph()
    for importer, imported in imports:
        g.add_import(importer=importer, imported=imported)
    return g


def test_a_circle_through_a_lazy_import_is_found_with_its_members() -> None:
    # GIVEN cli imports tune (inside a function: grimp counts it) and tune imports cli's helpers,
    # and report, imported by both, imports neither
    g = graph(("p.cli", "p.tune"), ("p.tune", "p.cli"), ("p.cli", "p.report"), ("p.tune", "p.report"))
    # THEN the one circle is cli <-> tune
    assert import_cycles(g) == [["p.cli", "p.tune"]]


def test_a_longer_circle_and_a_package_importing_its_child_and_back_are_found() -> None:
    g = graph(("a.x", "a.y"), ("a.y", "a.z"), ("a.z", "a.x"), ("m", "m.server"), ("m.server", "m"))
    assert import_cycles(g) == [["a.x", "a.y", "a.z"], ["m", "m.server"]]


def test_layers_without_a_circle_and_a_module_naming_itself_pass() -> None:
    g = graph(("app", "core"), ("adapters", "core"), ("app", "adapters"), ("hub", "hub"))
    assert import_cycles(g) == []
