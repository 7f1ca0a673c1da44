"""Geometry of the safety-case diagram: nothing overlaps, no edge runs through a node."""

from __future__ import annotations

import itertools

from hypothesis import given, settings
from hypothesis import strategies as st
from shapely.geometry import LineString, box

from casewatch.evaluator.result import CaseInfo, CaseNode
from casewatch.reports.layout import _isotonic_place, layout_case
from tools.sample import reference_case


def _boxes(diagram):
    return {n.id: box(n.x, n.y, n.x + n.w, n.y + n.h) for n in diagram.nodes}


def assert_clean(diagram) -> None:
    boxes = _boxes(diagram)
    for (a, ba), (b, bb) in itertools.combinations(boxes.items(), 2):
        assert not ba.intersects(bb), f"{a} overlaps {b}"
    for edge in diagram.edges:
        for p, q in itertools.pairwise(edge.points):
            segment = LineString([p, q])
            for node_id, node_box in boxes.items():
                if node_id in (edge.source, edge.target):
                    continue
                assert not segment.intersects(node_box), (
                    f"edge {edge.source}->{edge.target} crosses {node_id}"
                )


def test_reference_case_has_no_overlap_and_no_edge_through_a_node() -> None:
    diagram = layout_case(reference_case())
    assert len(diagram.nodes) == 30  # G1, S1, G2-G5, C1-C3, A1, J1, Sn1-Sn16, CSn1-CSn3
    assert_clean(diagram)


def test_every_node_inside_the_canvas() -> None:
    diagram = layout_case(reference_case())
    for n in diagram.nodes:
        assert n.x >= 0 and n.x + n.w <= diagram.width
        assert n.y >= 0 and n.y + n.h <= diagram.height


def test_layers_follow_supported_by() -> None:
    diagram = layout_case(reference_case())
    y = {n.id: n.y for n in diagram.nodes}
    assert y["G1"] < y["S1"] < y["G2"] == y["G5"] < y["Sn1"] == y["Sn14"]
    # counters sit beside the goal they challenge, contexts beside G1
    assert y["CSn1"] == y["G2"] and y["CSn2"] == y["G5"]
    assert y["C1"] == y["G1"] and y["A1"] == y["S1"]


def test_edges_of_every_relation_are_drawn() -> None:
    diagram = layout_case(reference_case())
    kinds = {(e.source, e.target): e.kind for e in diagram.edges}
    assert kinds[("G1", "S1")] == "supported_by"
    assert kinds[("S1", "J1")] == "in_context_of"
    assert kinds[("CSn2", "G5")] == "challenges"
    # 1 + 4 + 3 + 4 + 2 + 7 supportedBy, 5 in context, 3 challenges
    assert len(diagram.edges) == 21 + 5 + 3


def test_layer_skipping_edge_goes_around_nodes() -> None:
    # G1 supports Sn1 directly, and so does G2 two layers down: Sn1 lands in layer 3 and the
    # edge G1 -> Sn1 passes layers 1 and 2.
    nodes = [
        CaseNode(id="G1", type="G", text="top", supported_by=["S1", "Sn1"]),
        CaseNode(id="S1", type="S", text="split", supported_by=["G2", "G3"]),
        CaseNode(id="G2", type="G", text="left goal", supported_by=["Sn1"]),
        CaseNode(id="G3", type="G", text="right goal", supported_by=["Sn2"]),
        CaseNode(id="Sn1", type="Sn", text="e1"),
        CaseNode(id="Sn2", type="Sn", text="e2"),
    ]
    case = CaseInfo(
        path="x", digest="d", module="m", root_id="G1", channels=["a"], period=0.1, nodes=nodes
    )
    diagram = layout_case(case)
    assert_clean(diagram)
    long_edge = next(e for e in diagram.edges if (e.source, e.target) == ("G1", "Sn1"))
    assert len(long_edge.points) > 4  # routed through a dummy slot


def test_isotonic_place_keeps_order_and_gaps() -> None:
    # desired 0, 0, 0 with gaps 10 -> least squares centred on 0: -10, 0, 10
    assert _isotonic_place([0.0, 0.0, 0.0], [10.0, 10.0]) == [-10.0, 0.0, 10.0]
    # already feasible positions are kept
    assert _isotonic_place([0.0, 50.0], [10.0]) == [0.0, 50.0]


@settings(max_examples=25, deadline=None)
@given(
    fanout=st.lists(st.integers(min_value=0, max_value=5), min_size=1, max_size=5),
    texts=st.text(min_size=1, max_size=120),
    contexts=st.integers(min_value=0, max_value=3),
)
def test_random_trees_stay_clean(fanout: list[int], texts: str, contexts: int) -> None:
    nodes = [
        CaseNode(
            id="G1",
            type="G",
            text=texts,
            supported_by=[f"G{i + 2}" for i in range(len(fanout))],
            in_context_of=[f"C{i + 1}" for i in range(contexts)],
        )
    ]
    nodes += [CaseNode(id=f"C{i + 1}", type="C", text=texts) for i in range(contexts)]
    sn = 0
    for i, count in enumerate(fanout):
        children = [f"Sn{sn + k + 1}" for k in range(count)]
        sn += count
        nodes.append(
            CaseNode(
                id=f"G{i + 2}",
                type="G",
                text=texts,
                supported_by=children,
                undeveloped=not children,
            )
        )
        nodes += [CaseNode(id=c, type="Sn", text=texts) for c in children]
    nodes.append(CaseNode(id="CSn1", type="CSn", text=texts, challenges=["G2"]))
    case = CaseInfo(
        path="x", digest="d", module="m", root_id="G1", channels=["a"], period=0.1, nodes=nodes
    )
    assert_clean(layout_case(case))


def test_reference_yaml_lays_out_cleanly_and_matches_the_fixture() -> None:
    from pathlib import Path

    from casewatch.safety_case.loader import load_case
    from tools.sample import case_info_from_case

    path = Path(__file__).resolve().parents[2] / "examples" / "reference-case.yaml"
    case, findings = load_case(path)
    assert case is not None, findings
    info = case_info_from_case(case)
    assert_clean(layout_case(info))
    fixture = reference_case()
    shape = [
        (n.id, n.type, n.text, n.supported_by, n.in_context_of, n.challenges) for n in info.nodes
    ]
    assert shape == [
        (n.id, n.type, n.text, n.supported_by, n.in_context_of, n.challenges) for n in fixture.nodes
    ]
