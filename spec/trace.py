"""Traces: every path from a formula's node up to the root goal, with ids and texts.

Uses `safety_case.trace.traces_to_root` when the safety-case package provides it, so there is one
definition of a trace; the fallback below walks `supportedBy` upwards (and, for a counter node,
first to the claims it `challenges`) so `spec` works on hand-built cases too.
"""

from __future__ import annotations

from collections.abc import Callable

from safety_case.model import Case
from spec.model import TraceStep

TraceFn = Callable[[Case, str], list[list[tuple[str, str]]]]


def _fallback_traces(case: Case, node_id: str) -> list[list[tuple[str, str]]]:
    parents: dict[str, list[str]] = {}
    for node in case.nodes.values():
        for child in node.supported_by:
            parents.setdefault(child, []).append(node.id)

    def up(nid: str, seen: frozenset[str]) -> list[list[str]]:
        node = case.nodes.get(nid)
        if node is None or nid in seen:
            return []
        ups = list(parents.get(nid, [])) + list(node.challenges)
        if not ups:
            return [[nid]]
        out: list[list[str]] = []
        for parent in ups:
            out.extend([nid, *p] for p in up(parent, seen | {nid}))
        return out or [[nid]]

    return [[(n, case.nodes[n].text) for n in path] for path in up(node_id, frozenset())]


def _trace_fn() -> TraceFn:
    try:
        from safety_case.trace import traces_to_root
    except ImportError:
        return _fallback_traces
    return traces_to_root


def traces_for(case: Case, node_id: str) -> list[list[TraceStep]]:
    """Every path from `node_id` to the root, node first, as serialisable steps."""
    paths = _trace_fn()(case, node_id)
    return [[TraceStep(id=i, text=t) for i, t in path] for path in paths]
