"""Small hand-built safety cases for evaluator tests (no YAML involved)."""

from __future__ import annotations

from casewatch.safety_case.model import (
    Case,
    HazardBinding,
    Module,
    MonitorConfig,
    Node,
    NodeType,
    SpiBinding,
    Threshold,
)


def node(node_id: str, kind: NodeType, text: str = "", **kw) -> Node:
    return Node(id=node_id, type=kind, text=text or f"text of {node_id}", **kw)


def small_case() -> Case:
    """G1 <- S1 <- {G2 <- Sn1 (els >= 0.6), G3 <- {Sn2 (ppcs >= 0.8), Sn3 (external)}};
    CSn1 (els_var > 0.05) challenges G2; C1 context of G1."""
    nodes = [
        node(
            "G1",
            NodeType.GOAL,
            "EGO vehicle goes from Point A to Point B safely",
            supported_by=["S1"],
            in_context_of=["C1"],
        ),
        node("S1", NodeType.STRATEGY, supported_by=["G2", "G3"]),
        node("G2", NodeType.GOAL, "Ego location is known", supported_by=["Sn1"]),
        node("G3", NodeType.GOAL, supported_by=["Sn2", "Sn3"]),
        node(
            "Sn1",
            NodeType.SOLUTION,
            "ELS",
            spi=SpiBinding(signal="els", threshold=Threshold(op=">=", value=0.6)),
        ),
        node(
            "Sn2",
            NodeType.SOLUTION,
            "PPCS",
            spi=SpiBinding(signal="ppcs", threshold=Threshold(op=">=", value=0.8)),
        ),
        node("Sn3", NodeType.SOLUTION, "Test report"),
        node(
            "CSn1",
            NodeType.COUNTER_SOLUTION,
            "Inconsistent ego localization",
            challenges=["G2"],
            hazard=HazardBinding(when="els_var > 0.05"),
        ),
        node("C1", NodeType.CONTEXT, "Channels lav and tfuse"),
    ]
    return Case(
        path="small.yaml",
        digest="0" * 64,
        module=Module(name="small"),
        monitor=MonitorConfig(channels=["lav", "tfuse"]),
        nodes={n.id: n for n in nodes},
    )
