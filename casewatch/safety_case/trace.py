"""Traces: every path from a node up to the root goal, with ids and texts.

Upward steps follow the argument's support in reverse: a node's parents are the nodes naming it
in `supportedBy`; a context, assumption or justification goes up to the nodes naming it in
`inContextOf`; a counter node (CG, CSn) goes up through the claims it `challenges`. Paths are
returned in a deterministic order (parents in YAML order, depth first). A path that would visit
a node twice (only possible in a case that fails CW034) is cut.
"""

from __future__ import annotations

from casewatch.safety_case.model import Case, NodeType

_CONTEXT_TYPES = frozenset({NodeType.CONTEXT, NodeType.ASSUMPTION, NodeType.JUSTIFICATION})


def supporters(case: Case) -> dict[str, list[str]]:
    """node id -> ids of the nodes it names in `supportedBy` that exist (children), YAML order."""
    return {
        node.id: [t for t in node.supported_by if t in case.nodes] for node in case.nodes.values()
    }


def parents(case: Case) -> dict[str, list[str]]:
    """node id -> ids one step up towards the root (see module doc), in YAML order."""
    up: dict[str, list[str]] = {node_id: [] for node_id in case.nodes}
    for node in case.nodes.values():
        for target in node.supported_by:
            if target in up and node.id not in up[target]:
                up[target].append(node.id)
        for target in node.in_context_of:
            is_context = target in up and case.nodes[target].type in _CONTEXT_TYPES
            if is_context and node.id not in up[target]:
                up[target].append(node.id)
    for node in case.nodes.values():
        for target in node.challenges:
            if target in case.nodes and target not in up[node.id]:
                up[node.id].append(target)
    return up


def traces_to_root(case: Case, node_id: str) -> list[list[tuple[str, str]]]:
    """Every path from `node_id` up to the root goal, each a list of (id, text), node first.

    Raises KeyError for an id the case does not have. A node with no path to the root gets [],
    and so does every node of a case without a root goal (checks report that as CW035/CW036;
    `casewatch check` still runs the formula checks on such a case, which ask for traces).
    """
    if node_id not in case.nodes:
        raise KeyError(f"no node {node_id!r} in {case.path}")
    try:
        root = case.root_id()
    except IndexError:
        return []
    up = parents(case)
    paths: list[list[tuple[str, str]]] = []

    def walk(current: str, path: list[str]) -> None:
        if current == root:
            paths.append([(i, case.nodes[i].text) for i in path])
            return
        for parent in up[current]:
            if parent not in path:
                walk(parent, [*path, parent])

    walk(node_id, [node_id])
    return paths
