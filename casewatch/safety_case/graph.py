"""The GSN graph of a case as a networkx DiGraph.

Nodes carry `type` (NodeType), `text` and `mark`; edges run from the node that names the
relation to the node it names, with `relation` in {"supportedBy", "inContextOf", "challenges"}.
References to ids that do not exist are left out (the checks report them as dangling).
"""

from __future__ import annotations

import networkx as nx

from casewatch.safety_case.model import Case, Node

SUPPORTED_BY = "supportedBy"
IN_CONTEXT_OF = "inContextOf"
CHALLENGES = "challenges"


def relations(node: Node) -> list[tuple[str, str]]:
    """(relation, target id) pairs of a node, in YAML order."""
    return (
        [(SUPPORTED_BY, t) for t in node.supported_by]
        + [(IN_CONTEXT_OF, t) for t in node.in_context_of]
        + [(CHALLENGES, t) for t in node.challenges]
    )


def build_graph(case: Case) -> nx.DiGraph:
    """The whole argument. When two nodes are linked twice, the first relation is kept."""
    graph = nx.DiGraph()
    for node in case.nodes.values():
        graph.add_node(node.id, type=node.type, text=node.text, mark=node.mark)
    for node in case.nodes.values():
        for relation, target in relations(node):
            if target in case.nodes and not graph.has_edge(node.id, target):
                graph.add_edge(node.id, target, relation=relation)
    return graph


def supported_by_graph(case: Case) -> nx.DiGraph:
    """Only the `supportedBy` edges (parent -> child), every node present."""
    graph = nx.DiGraph()
    graph.add_nodes_from(case.nodes)
    for node in case.nodes.values():
        for target in node.supported_by:
            if target in case.nodes:
                graph.add_edge(node.id, target)
    return graph
