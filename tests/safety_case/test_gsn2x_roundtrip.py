"""Property: any argument valid by gsn2x's rules loads without errors, exports to gsn2x input
that the schema of gsn2x's format accepts, and reads back as the same argument (nodes, edges,
challenged nodes and relations, presentation attributes and layers)."""

from __future__ import annotations

from pathlib import Path

import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from casewatch.reports.gsn_export import write_gsn
from casewatch.safety_case.checks import check_file
from casewatch.safety_case.gsn2x_schema import gsn2x_problems

ARGUMENT = ("G", "S", "Sn")
CONTEXT = ("C", "A", "J")
COUNTER = ("CG", "CSn")
LAYER_VALUES = st.one_of(
    st.text(alphabet="abc xyz", min_size=1, max_size=8).map(str.strip).filter(bool),
    st.integers(-5, 5),
    st.lists(st.sampled_from(["p", "q"]), max_size=2),
)


@st.composite
def arguments(draw: st.DrawFn) -> dict:
    """A gsn2x document grown from one root goal: every node hangs off one already there, so
    the argument has one root and every node is reached."""
    doc: dict[str, dict] = {"G0": {"text": "the top claim"}}
    edges: list[tuple[str, str]] = []
    for i in range(1, draw(st.integers(1, 12))):
        prefix = draw(st.sampled_from(ARGUMENT + CONTEXT + COUNTER))
        node_id = f"{prefix}{i}"
        node: dict = {}
        heads = [n for n in doc if n[0] in "GS" and not n.startswith("Sn")]
        if prefix in ARGUMENT + CONTEXT:
            parent = draw(st.sampled_from(heads))
            relation = "supportedBy" if prefix in ARGUMENT else "inContextOf"
            doc[parent].setdefault(relation, []).append(node_id)
            edges.append((parent, node_id))
        elif prefix == "CSn" and any(n.startswith("CG") for n in doc) and draw(st.booleans()):
            doc[draw(st.sampled_from([n for n in doc if n.startswith("CG")]))].setdefault(
                "supportedBy", []
            ).append(node_id)
        elif edges and draw(st.booleans()):
            parent, child = draw(st.sampled_from(edges))
            node["challenges"] = f"{parent} -> {child}"
        else:
            node["challenges"] = draw(st.sampled_from(sorted(doc)))
        if draw(st.booleans()):
            node["text"] = f"node {i}"
        if draw(st.booleans()):
            node["classes"] = draw(st.lists(st.sampled_from(["c1", "c2"]), min_size=1))
        if draw(st.booleans()):
            node["horizontalIndex"] = draw(
                st.one_of(
                    st.integers(-3, 3).map(lambda n: {"relative": n}),
                    st.sampled_from([{"absolute": 0}, {"absolute": "last"}]),
                )
            )
        if draw(st.booleans()):
            node["rankIncrement"] = draw(st.integers(0, 3))
        if draw(st.booleans()):
            node[f"layer{i % 3}"] = draw(LAYER_VALUES)
        doc[node_id] = node
    for node_id, node in doc.items():
        if node_id[0] in "GS" and not node_id.startswith("Sn") and "supportedBy" not in node:
            node["undeveloped"] = True  # gsn2x's V02 warns otherwise
        if node_id.startswith("CG") and "supportedBy" not in node:
            node["undeveloped"] = True
    return doc


def graph(case) -> dict:
    return {
        i: (
            n.type,
            n.text,
            n.supported_by,
            n.in_context_of,
            n.challenges,
            n.challenged_relations,
            n.undeveloped,
            n.gsn,
        )
        for i, n in case.nodes.items()
    }


@settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(document=arguments())
def test_a_valid_gsn2x_argument_survives_the_round_trip(tmp_path: Path, document: dict) -> None:
    assert gsn2x_problems(document) == []  # the generator writes gsn2x input
    source = tmp_path / "arg.gsn.yaml"
    source.write_text(yaml.safe_dump(document, sort_keys=False), encoding="utf-8")
    case, findings = check_file(source)
    assert [f.code for f in findings] == ["CW011"], [f.format() for f in findings]
    (written,) = write_gsn(case, tmp_path / "out")
    exported = yaml.safe_load(written.read_text(encoding="utf-8"))
    assert gsn2x_problems(exported) == []
    again, findings = check_file(written)
    assert [f.code for f in findings] == ["CW011"]
    assert graph(again) == graph(case)
