"""Hand-built `Case` values for spec tests (no YAML loader involved)."""

from __future__ import annotations

from casewatch.safety_case.model import (
    Case,
    HazardBinding,
    Mark,
    Module,
    MonitorConfig,
    Node,
    NodeType,
    SpiBinding,
    Threshold,
)


def make_case(*nodes: Node, period: float = 0.1, signals: dict[str, str] | None = None) -> Case:
    root = Node(
        id="G1",
        type=NodeType.GOAL,
        text="Ego drives safely",
        supported_by=[n.id for n in nodes if n.type is NodeType.SOLUTION],
    )
    return Case(
        path="case.yaml",
        digest="0" * 64,
        module=Module(name="test"),
        monitor=MonitorConfig(channels=["lav", "tfuse"], period=period, signals=signals or {}),
        nodes={n.id: n for n in (root, *nodes)},
    )


def spi_node(
    node_id: str, signal: str, op: str, value: float, for_seconds: float | None = None
) -> Node:
    return Node(
        id=node_id,
        type=NodeType.SOLUTION,
        text=f"{signal} {op} {value}",
        spi=SpiBinding(
            signal=signal,
            threshold=Threshold(op=op, value=value),  # type: ignore[arg-type]
            for_seconds=for_seconds,
            mark=Mark(line=10, col=3),
            formula_mark=Mark(line=10, col=18),
        ),
    )


def stl_node(node_id: str, stl: str, line: int = 20, col: int = 10) -> Node:
    return Node(
        id=node_id,
        type=NodeType.SOLUTION,
        text=f"raw {node_id}",
        spi=SpiBinding(stl=stl, mark=Mark(line=line, col=3), formula_mark=Mark(line=line, col=col)),
    )


def hazard_node(node_id: str, when: str, line: int = 30, col: int = 12) -> Node:
    return Node(
        id=node_id,
        type=NodeType.COUNTER_SOLUTION,
        text=f"hazard {node_id}",
        challenges=["G1"],
        hazard=HazardBinding(
            when=when, mark=Mark(line=line, col=3), formula_mark=Mark(line=line, col=col)
        ),
    )
