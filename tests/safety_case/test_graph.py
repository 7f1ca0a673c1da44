"""The networkx view of a case."""

from __future__ import annotations

from casewatch.safety_case.graph import build_graph, supported_by_graph
from casewatch.safety_case.loader import load_case_text
from casewatch.safety_case.model import NodeType
from tests.safety_case.fixtures import BASE


def test_edges_carry_their_relation() -> None:
    text = BASE + "C1: {text: c}\nCSn1: {text: h, challenges: G1}\n"
    text = text.replace("  supportedBy: [Sn1]\n", "  supportedBy: [Sn1]\n  inContextOf: [C1]\n")
    value, findings = load_case_text(text)
    assert value is not None, findings
    graph = build_graph(value)
    assert sorted(graph.edges(data="relation")) == [
        ("CSn1", "G1", "challenges"),
        ("G1", "C1", "inContextOf"),
        ("G1", "Sn1", "supportedBy"),
    ]
    assert graph.nodes["CSn1"]["type"] is NodeType.COUNTER_SOLUTION
    assert list(supported_by_graph(value).edges) == [("G1", "Sn1")]


def test_dangling_targets_are_left_out() -> None:
    value, _ = load_case_text(BASE.replace("[Sn1]", "[Sn1, Sn7]"))
    assert value is not None
    assert list(build_graph(value).edges) == [("G1", "Sn1")]
