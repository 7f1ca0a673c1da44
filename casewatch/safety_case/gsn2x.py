"""What casewatch knows of gsn2x's YAML format (gsn2x 4.x, its documentation): how an id gets
its type, how a challenged relation is written, and which attributes are gsn2x's own.

gsn2x is the renderer many safety engineers keep their arguments in. A file without a
`monitor` block is read by gsn2x's rules (docs/gsn2x.md): optional `text` and `module`, any
further attribute a layer, several roots only a warning; this module holds the facts those
rules need, so the loader, the structural checks and the exporter agree on them.
"""

from __future__ import annotations

import difflib

from casewatch.safety_case.model import NodeType

#: gsn2x types an id by its first letters, longest prefix first (`CSn1` is a counter
#: solution, `Sn1` a solution, `S1` a strategy); anything after the prefix is free.
_PREFIXES: tuple[tuple[str, NodeType], ...] = (
    ("CG", NodeType.COUNTER_GOAL),
    ("G", NodeType.GOAL),
    ("CSn", NodeType.COUNTER_SOLUTION),
    ("Sn", NodeType.SOLUTION),
    ("S", NodeType.STRATEGY),
    ("C", NodeType.CONTEXT),
    ("A", NodeType.ASSUMPTION),
    ("J", NodeType.JUSTIFICATION),
)

#: gsn2x's `nodeType` names, which win over the id's prefix.
NODE_TYPE_NAMES: dict[str, NodeType] = {
    "Goal": NodeType.GOAL,
    "Strategy": NodeType.STRATEGY,
    "Solution": NodeType.SOLUTION,
    "Context": NodeType.CONTEXT,
    "Assumption": NodeType.ASSUMPTION,
    "Justification": NodeType.JUSTIFICATION,
    "CounterGoal": NodeType.COUNTER_GOAL,
    "CounterSolution": NodeType.COUNTER_SOLUTION,
}

#: The dialectic extension's node types: they challenge a node or a relation.
COUNTER_TYPES = frozenset({NodeType.COUNTER_GOAL, NodeType.COUNTER_SOLUTION})

#: The attributes gsn2x reads on an element; any other key is an extra attribute, which gsn2x
#: shows as a layer (`gsn2x -l layer1`) and otherwise ignores.
NODE_ATTRIBUTES: tuple[str, ...] = (
    "text",
    "supportedBy",
    "inContextOf",
    "challenges",
    "undeveloped",
    "defeated",
    "defeatedRelation",
    "classes",
    "url",
    "rankIncrement",
    "horizontalIndex",
    "nodeType",
    "charWrap",
    "acp",
)

#: The attributes gsn2x reads on the `module` block (any other key is kept as information).
MODULE_ATTRIBUTES: tuple[str, ...] = (
    "name",
    "brief",
    "extends",
    "uses",
    "stylesheets",
    "horizontalIndex",
    "rankIncrement",
    "charWrap",
)

#: `challenges: G2 -> CG1` challenges the relation between the two, not a node.
RELATION_ARROW = "->"


def type_by_prefix(node_id: str) -> NodeType | None:
    """The type gsn2x gives `node_id` by its prefix alone, or None when no prefix matches."""
    for prefix, node_type in _PREFIXES:
        if node_id.startswith(prefix):
            return node_type
    return None


def split_relation(target: str) -> tuple[str, str] | None:
    """`"G2 -> CG1"` -> `("G2", "CG1")`; None for a plain node id."""
    if RELATION_ARROW not in target:
        return None
    left, _, right = target.partition(RELATION_ARROW)
    return left.strip(), right.strip()


def relation_text(relation: tuple[str, str]) -> str:
    """The way gsn2x writes a challenged relation: `G2 -> CG1`."""
    return f"{relation[0]} {RELATION_ARROW} {relation[1]}"


def did_you_mean(word: str, choices: tuple[str, ...] | list[str]) -> str:
    """`"; did you mean 'x'?"` for the closest choice, or an empty string."""
    lowered = {c.lower(): c for c in choices}
    if word.lower() in lowered:
        return f"; did you mean {lowered[word.lower()]!r}?"
    close = difflib.get_close_matches(word, list(choices), n=1, cutoff=0.6)
    return f"; did you mean {close[0]!r}?" if close else ""
