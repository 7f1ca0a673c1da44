"""The layer contract (docs/architecture.md) in full, on the real import graph.

`lint-imports` (pyproject.toml, `[tool.importlinter]`) checks the component layers; this test
adds what a contract cannot say without naming every module: each top-level `casewatch.*`
module that is not a component is front door (so a new one is covered the day it is added), no
two modules import each other round a circle, and the installed package never reaches for the
repository's tooling (`examples`, `bench`, `tools`, `tests`), which a wheel does not contain.
"""

from __future__ import annotations

import grimp
import networkx as nx
import pytest

#: Bottom to top; a module may import only from its own rank or below.
COMPONENTS = ["errors", "safety_case", "spec", "monitor", "evaluator", "reports"]
FRONT_DOOR = len(COMPONENTS)
TOOLING = {"examples", "bench", "tools", "tests"}


def rank(module: str) -> int:
    """Where a module sits: its component's index, or the front door above them all."""
    parts = module.split(".")
    if len(parts) > 1 and parts[1] in COMPONENTS:
        return COMPONENTS.index(parts[1])
    return FRONT_DOOR


def layer_name(module: str) -> str:
    value = rank(module)
    return "front door" if value == FRONT_DOOR else f"casewatch.{COMPONENTS[value]}"


@pytest.fixture(scope="module")
def graph() -> grimp.ImportGraph:
    return grimp.build_graph("casewatch", include_external_packages=True, cache_dir=None)


def _edges(graph: grimp.ImportGraph) -> list[tuple[str, str]]:
    return [
        (importer, imported)
        for importer in sorted(graph.modules)
        if importer.startswith("casewatch")
        for imported in sorted(graph.find_modules_directly_imported_by(importer))
    ]


def _where(graph: grimp.ImportGraph, importer: str, imported: str) -> str:
    details = graph.get_import_details(importer=importer, imported=imported)
    lines = ", ".join(f"l.{d['line_number']}" for d in details)
    return f"{importer} -> {imported} ({lines})"


def test_rank_of_known_modules():
    assert rank("casewatch.errors") == 0
    assert rank("casewatch.safety_case.loader") == 1
    assert rank("casewatch.reports.html") == 5
    assert rank("casewatch") == FRONT_DOOR  # the package itself (its __version__) is front door
    assert rank("casewatch.cli") == rank("casewatch.commands.run") == FRONT_DOOR


def test_no_import_points_up_a_layer(graph):
    back = [
        f"{_where(graph, a, b)}: {layer_name(a)} may not import {layer_name(b)}"
        for a, b in _edges(graph)
        if b.startswith("casewatch") and rank(a) < rank(b)
    ]
    assert back == [], "imports against the flow of data:\n" + "\n".join(back)


def test_no_import_cycles(graph):
    g = nx.DiGraph(e for e in _edges(graph) if e[1].startswith("casewatch"))
    circles = [sorted(c) for c in nx.strongly_connected_components(g) if len(c) > 1]
    assert circles == [], f"modules that import each other round a circle: {circles}"


def test_the_package_never_imports_repository_tooling(graph):
    reached = [_where(graph, a, b) for a, b in _edges(graph) if b.split(".")[0] in TOOLING]
    assert reached == [], "installed code importing what a wheel lacks:\n" + "\n".join(reached)


def test_a_back_arrow_is_caught():
    """The checks above on a made-up graph: they do fail on what they forbid."""
    fake = grimp.ImportGraph()
    for module in ["casewatch", "casewatch.monitor", "casewatch.monitor.a", "casewatch.spec.b"]:
        fake.add_module(module)
    fake.add_module("examples", is_squashed=True)
    fake.add_import(
        importer="casewatch.spec.b",
        imported="casewatch.monitor.a",
        line_number=3,
        line_contents="from casewatch.monitor import a",
    )
    fake.add_import(
        importer="casewatch.monitor.a",
        imported="casewatch.spec.b",
        line_number=4,
        line_contents="from casewatch.spec import b",
    )
    fake.add_import(
        importer="casewatch.monitor.a",
        imported="examples",
        line_number=5,
        line_contents="import examples",
    )
    with pytest.raises(AssertionError, match=r"casewatch.spec.b -> casewatch.monitor.a \(l.3\)"):
        test_no_import_points_up_a_layer(fake)
    with pytest.raises(AssertionError, match="round a circle"):
        test_no_import_cycles(fake)
    with pytest.raises(AssertionError, match=r"-> examples \(l.5\)"):
        test_the_package_never_imports_repository_tooling(fake)
