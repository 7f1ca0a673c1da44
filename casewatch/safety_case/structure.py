"""Structural checks of a loaded case (GSN v3 rules), each reporting a stable code.

The loader already reports syntax and schema problems (CW001-CW025). These checks look at the
argument as a graph: references, relation types, cycles, the root goal, reachability and
development status. Each finding points at the offending node key or list item. See
`docs/checks.md` for the table of codes with fixing examples.

Two rule sets: a case with a `monitor` block is held to casewatch's rules (one root goal,
counter nodes challenge goals), because a run judges the case from its root goal; a pure
argument (no `monitor`) is checked by gsn2x's rules, where several roots are only a warning
and a counter node may challenge any node or relation (docs/gsn2x.md).

This module does not load files (`checks.check_file` does), so the loader can run the checks
without an import cycle.
"""

from __future__ import annotations

from collections.abc import Collection, Mapping

import networkx as nx

from casewatch.safety_case.codes import finding
from casewatch.safety_case.findings import Finding
from casewatch.safety_case.graph import (
    CHALLENGES,
    IN_CONTEXT_OF,
    SUPPORTED_BY,
    relations,
    supported_by_graph,
)
from casewatch.safety_case.gsn2x import COUNTER_TYPES, did_you_mean
from casewatch.safety_case.model import Case, Mark, Node, NodeType

G, S, SN = NodeType.GOAL, NodeType.STRATEGY, NodeType.SOLUTION
C, A, J = NodeType.CONTEXT, NodeType.ASSUMPTION, NodeType.JUSTIFICATION
CG, CSN = NodeType.COUNTER_GOAL, NodeType.COUNTER_SOLUTION

#: GSN: which node types may name which in `supportedBy` / `inContextOf`.
SUPPORTED_BY_RULES: dict[NodeType, frozenset[NodeType]] = {
    G: frozenset({G, S, SN}),
    S: frozenset({G, S, SN}),
    CG: frozenset({CG, CSN}),
}
#: gsn2x also lets goals and strategies name counter nodes in `supportedBy`.
GSN2X_SUPPORTED_BY_RULES: dict[NodeType, frozenset[NodeType]] = {
    G: frozenset({G, S, SN, CG, CSN}),
    S: frozenset({G, S, SN, CG, CSN}),
    CG: frozenset({CG, CSN}),
}
IN_CONTEXT_OF_RULES: dict[NodeType, frozenset[NodeType]] = {
    G: frozenset({C, A, J}),
    S: frozenset({C, A, J}),
}
#: Node types that must be supported or marked undeveloped.
DEVELOPABLE = frozenset({G, S, CG})
#: Node types that may head the argument (a root is one of these with nothing above it).
ARGUMENT_TYPES = frozenset({G, S, SN})

_TYPE_NAMES = {
    G: "goal",
    S: "strategy",
    SN: "solution",
    C: "context",
    A: "assumption",
    J: "justification",
    CG: "counter-goal",
    CSN: "counter-solution",
}


def sort_findings(findings: list[Finding]) -> list[Finding]:
    """By line and column (file-level findings at 0:0 first), stable otherwise."""
    return sorted(findings, key=lambda f: (f.line, f.col))


def check_case(
    case: Case,
    skipped: Mapping[str, Mark] | None = None,
    invalid: Collection[str] = (),
    gsn2x_rules: bool | None = None,
) -> list[Finding]:
    """Every structural check on `case`. `skipped` names ids the loader could not type (their
    references are not reported again as dangling); `invalid` names nodes that failed
    validation (their missing support is not reported again as CW039). `gsn2x_rules`: check
    by gsn2x's rules (a pure argument); None: when the case has no monitor channels."""
    if gsn2x_rules is None:
        gsn2x_rules = not case.monitor.channels
    checker = _Checker(case, dict(skipped or {}), frozenset(invalid), gsn2x_rules)
    checker.run()
    return checker.findings


def is_bound(node: Node) -> bool:
    """The node carries something a run judges: an SPI, a contract or a hazard."""
    return node.spi is not None or node.contract is not None or node.hazard is not None


def unmonitored_reason(case: Case) -> str | None:
    """Why a run of `case` would judge nothing, or None when it judges something: a pure
    argument (no `monitor`), or a monitor with no evidence bound to any node. Said by
    `casewatch check` and `run` so that "no violation" is never read as "satisfied"."""
    if not case.monitor.channels:
        return (
            "nothing is monitored: it has no `monitor` block (a pure argument, checked by "
            "gsn2x's rules); add `monitor:` and bind evidence with `spi:` to monitor it"
        )
    if not any(is_bound(n) for n in case.nodes.values()):
        return (
            "nothing is monitored: no solution has an `spi` or `contract` and no counter "
            "solution a `hazard`, so a run judges none of its claims (docs/gsn2x.md)"
        )
    return None


class _Checker:
    def __init__(
        self, case: Case, skipped: dict[str, Mark], invalid: frozenset[str], gsn2x_rules: bool
    ) -> None:
        self.case = case
        self.nodes = case.nodes
        self.skipped = skipped
        self.invalid = invalid
        self.gsn2x_rules = gsn2x_rules
        self.supported_by_rules = GSN2X_SUPPORTED_BY_RULES if gsn2x_rules else SUPPORTED_BY_RULES
        self.root: str | None = None
        self.findings: list[Finding] = []

    def add(self, code: str, message: str, mark: Mark, hint: str = "") -> None:
        self.findings.append(finding(code, message, self.case.path, mark, hint))

    def ref_mark(self, node: Node, relation: str, target: str) -> Mark:
        return node.ref_marks.get(relation, {}).get(target) or node.key_marks.get(
            relation, node.mark
        )

    def run(self) -> None:
        for node in self.nodes.values():
            self.counter(node)
            self.references(node)
            self.challenged_relations(node)
            self.defeats(node)
            self.claim_points(node)
        self.cycles()
        roots = self.gsn2x_roots() if self.gsn2x_rules else self.roots()
        goals = [r for r in roots if self.nodes[r].type is G]
        self.root = roots[0] if len(roots) == 1 and goals else None
        if roots:
            self.reachability(roots)
        for node in self.nodes.values():
            self.development(node)
        if not self.gsn2x_rules:
            self.unjudged()

    def counter(self, node: Node) -> None:
        # a counter node supporting a counter goal argues for that challenge (GSN's dialectic
        # extension, as gsn2x draws it); only a counter node on its own must say what it
        # challenges
        supports_counter = any(
            node.id in other.supported_by and other.type in COUNTER_TYPES
            for other in self.case.nodes.values()
        )
        challenges = node.challenges or node.challenged_relations
        if self.gsn2x_rules:
            return  # gsn2x does not ask it; an unattached counter node is then a second root
        if node.type in COUNTER_TYPES and not challenges and not supports_counter:
            kind = _TYPE_NAMES[node.type]
            self.add(
                "CW024",
                f"{kind} {node.id} does not say what it challenges",
                node.mark,
                f"add `challenges: G<n>` naming the claim this {kind} puts in doubt",
            )

    def duplicates(self, node: Node) -> None:
        """gsn2x warns when a list names an element twice (its V05): a copy-paste slip that
        draws one edge and reads as two."""
        for relation, targets in (
            (SUPPORTED_BY, node.supported_by),
            (IN_CONTEXT_OF, node.in_context_of),
            (CHALLENGES, node.challenges),
        ):
            for target in sorted({t for t in targets if targets.count(t) > 1}):
                self.add(
                    "CW068",
                    f"{node.id} names {target} twice in `{relation}`",
                    node.key_marks.get(relation, node.mark),
                    "list it once",
                )

    def references(self, node: Node) -> None:
        self.duplicates(node)
        for relation, target in relations(node):
            mark = self.ref_mark(node, relation, target)
            if target == node.id:
                self.add("CW031", f"{node.id} names itself in `{relation}`", mark)
                continue
            if target not in self.nodes:
                if target in self.skipped:
                    continue
                self.add(
                    "CW030",
                    f"{node.id} `{relation}` names {target!r}, which is not a node in this case"
                    f"{did_you_mean(target, list(self.nodes))}",
                    mark,
                )
                continue
            target_type = self.nodes[target].type
            if relation == SUPPORTED_BY:
                allowed = self.supported_by_rules.get(node.type, frozenset())
                self.relation_type("CW032", node, target, target_type, relation, allowed, mark)
            elif relation == IN_CONTEXT_OF:
                allowed = IN_CONTEXT_OF_RULES.get(node.type, frozenset())
                self.relation_type("CW033", node, target, target_type, relation, allowed, mark)
            elif relation == CHALLENGES and self.gsn2x_rules:
                continue  # gsn2x: a counter node may challenge any node
            elif relation == CHALLENGES and target_type in COUNTER_TYPES:
                self.add(
                    "CW026",
                    f"{node.id} challenges {target}, a {_TYPE_NAMES[target_type]}; a counter "
                    "node challenges a goal of the argument",
                    mark,
                )
            elif relation == CHALLENGES and target_type is not G:
                self.challenged_non_goal(node, target, target_type, mark)

    def challenged_relations(self, node: Node) -> None:
        """`challenges: X -> Y` (gsn2x): both ends exist, differ and are linked."""
        for left, right in node.challenged_relations:
            text = f"{left} -> {right}"
            mark = self.ref_mark(node, CHALLENGES, text)
            missing = [end for end in (left, right) if end not in self.nodes]
            if missing:
                if not any(end in self.skipped for end in missing):
                    self.add(
                        "CW030",
                        f"{node.id} `challenges` the relation {text}, but {missing[0]!r} is not "
                        f"a node in this case{did_you_mean(missing[0], list(self.nodes))}",
                        mark,
                    )
                continue
            a, b = self.nodes[left], self.nodes[right]
            linked = right in (t for _, t in relations(a)) or left in (t for _, t in relations(b))
            if left == right or not linked:
                why = "both ends are the same node" if left == right else "they are not linked"
                self.add(
                    "CW062",
                    f"{node.id} `challenges` the relation {text}, which is not a relation of "
                    f"the argument: {why}",
                    mark,
                    "name a `supportedBy`, `inContextOf` or `challenges` link as `FROM -> TO`",
                )

    def defeats(self, node: Node) -> None:
        """gsn2x's dialectic attributes say what the argument shows: a `defeated` node is one
        a counter node challenges (gsn2x's V10), a `defeatedRelation` one of this node's
        relations (V13)."""
        if node.gsn.get("defeated") is True and not any(
            node.id in other.challenges for other in self.nodes.values()
        ):
            self.add(
                "CW066",
                f"{node.id} is marked `defeated`, but no counter node challenges it",
                node.key_marks.get("defeated", node.mark),
                f"add a counter node with `challenges: {node.id}`, or drop `defeated`",
            )
        written = node.gsn.get("defeatedRelation")
        for target in [written] if isinstance(written, str) else list(written or []):
            if target not in (t for _, t in relations(node)):
                self.add(
                    "CW066",
                    f"{node.id} marks its relation to {target} as defeated, but it has no "
                    f"relation to {target}",
                    node.key_marks.get("defeatedRelation", node.mark),
                    "name one of its own `supportedBy`, `inContextOf` or `challenges` targets",
                )

    def claim_points(self, node: Node) -> None:
        """gsn2x's assurance claim points (`acp`) sit on the node or on one of its own
        `supportedBy` / `inContextOf` links (gsn2x's V09)."""
        acp = node.gsn.get("acp")
        if not isinstance(acp, dict):
            return
        allowed = {node.id, *node.supported_by, *node.in_context_of}
        for name, targets in acp.items():
            for target in [targets] if isinstance(targets, str) else targets:
                if target not in allowed:
                    self.add(
                        "CW067",
                        f"{node.id}'s assurance claim point {name} names {target}, which is "
                        f"neither {node.id} nor one of its `supportedBy` / `inContextOf`",
                        node.key_marks.get("acp", node.mark),
                        f"name {node.id} or a node it links to",
                    )

    def unjudged(self) -> None:
        """A monitored case: a challenged relation is drawn, never judged; say so."""
        for node in self.nodes.values():
            for left, right in node.challenged_relations:
                self.add(
                    "CW064",
                    f"{node.id} challenges the relation {left} -> {right}: it is drawn and "
                    "exported, but a run does not judge challenges of relations (only of nodes)",
                    self.ref_mark(node, CHALLENGES, f"{left} -> {right}"),
                    f"to put a claim in doubt at run time, challenge it: `challenges: {left}`",
                )

    def relation_type(
        self,
        code: str,
        node: Node,
        target: str,
        target_type: NodeType,
        relation: str,
        allowed: frozenset[NodeType],
        mark: Mark,
    ) -> None:
        if target_type in allowed:
            return
        kind = _TYPE_NAMES[node.type]
        if not allowed:
            why = f"a {kind} cannot have `{relation}`"
        else:
            names = ", ".join(sorted(t.value for t in allowed))
            why = f"a {kind} may only name {names} in `{relation}`"
        hint = ""
        if relation == SUPPORTED_BY and target_type in (C, A, J):
            hint = f"did you mean `inContextOf: [{target}]`?"
        elif relation == IN_CONTEXT_OF and target_type in (G, S, SN):
            hint = f"did you mean `supportedBy: [{target}]`?"
        self.add(
            code,
            f"{node.id} `{relation}` names {target}, a {_TYPE_NAMES[target_type]}: {why}",
            mark,
            hint,
        )

    def challenged_non_goal(
        self, node: Node, target: str, target_type: NodeType, mark: Mark
    ) -> None:
        # A challenged C, A or J would show `in-doubt` and nothing above it would ever notice:
        # context is not support. Goals are the claims casewatch judges, so doubt goes there.
        goals = self.goals_above(target)
        hint = (
            f"challenge the goal {target} belongs to: `challenges: {goals[0]}`"
            if goals
            else "name a goal (G) in `challenges`"
        )
        self.add(
            "CW027",
            f"{node.id} challenges {target}, a {_TYPE_NAMES[target_type]}; counter nodes "
            "challenge goals, the claims that carry doubt up to the root goal",
            mark,
            hint,
        )

    def goals_above(self, node_id: str) -> list[str]:
        """The nearest goals that name `node_id` (or a node between) in supportedBy or
        inContextOf, in YAML order."""
        found: list[str] = []
        frontier, seen = [node_id], {node_id}
        while frontier and not found:
            upper = [
                n.id
                for n in self.nodes.values()
                if n.id not in seen
                and n.type not in COUNTER_TYPES
                and any(t in frontier for t in (*n.supported_by, *n.in_context_of))
            ]
            seen.update(upper)
            found = [i for i in upper if self.nodes[i].type is G]
            frontier = upper
        return found

    def cycles(self) -> None:
        graph = supported_by_graph(self.case)
        graph.remove_edges_from(list(nx.selfloop_edges(graph)))  # CW031 already
        order = {node_id: i for i, node_id in enumerate(self.nodes)}
        for component in nx.strongly_connected_components(graph):
            if len(component) < 2:
                continue
            start = min(component, key=order.__getitem__)
            cycle = nx.find_cycle(graph.subgraph(component), source=start)
            ids = [edge[0] for edge in cycle] + [cycle[-1][1]]
            first, second = cycle[0]
            self.add(
                "CW034",
                f"`supportedBy` cycle: {' -> '.join(ids)}",
                self.ref_mark(self.nodes[first], SUPPORTED_BY, second),
                "an argument is a tree of support; remove one of these links",
            )

    def roots(self) -> list[str]:
        supported = {
            target
            for node in self.nodes.values()
            for target in node.supported_by
            if target != node.id
        }
        candidates = [
            n for n in self.nodes.values() if n.type in ARGUMENT_TYPES and n.id not in supported
        ]
        goals = [n for n in candidates if n.type is G]
        if not goals:
            if candidates:
                top = candidates[0]
                self.add(
                    "CW036",
                    f"the argument starts at {top.id}, a {_TYPE_NAMES[top.type]}; the root of a "
                    "safety case must be a goal",
                    top.mark,
                    f"add a top goal with `supportedBy: [{top.id}]`",
                )
            else:
                self.add(
                    "CW035",
                    "no root goal: every goal is supported by another node (or there is none)",
                    next(iter(self.nodes.values())).mark if self.nodes else Mark(line=1, col=1),
                    "the top goal is the one goal no other node names in `supportedBy`",
                )
            return []
        for extra in goals[1:]:
            self.add(
                "CW035",
                f"{extra.id} is a second root goal (the first is {goals[0].id}); a case has "
                "exactly one top goal",
                extra.mark,
                f"name {extra.id} in the `supportedBy` of the goal or strategy it supports",
            )
        return [g.id for g in goals]

    def gsn2x_roots(self) -> list[str]:
        """gsn2x's roots: the nodes nothing names in `supportedBy` or `inContextOf` and that
        challenge nothing. Several are a warning (gsn2x C01), one that is no goal an error."""
        named = {
            t for n in self.nodes.values() for t in (*n.supported_by, *n.in_context_of) if t != n.id
        }
        roots = [
            n.id
            for n in self.nodes.values()
            if n.id not in named and not (n.challenges or n.challenged_relations)
        ]
        if not roots:
            return self.roots()  # none at all: CW035, as for any case
        if len(roots) == 1 and self.nodes[roots[0]].type is not G:
            top = self.nodes[roots[0]]
            self.add(
                "CW036",
                f"the argument starts at {top.id}, a {_TYPE_NAMES[top.type]}; the root of an "
                "argument must be a goal",
                top.mark,
                f"add a top goal with `supportedBy: [{top.id}]`",
            )
        for extra in roots[1:]:
            self.add(
                "CW061",
                f"{extra} is another root (the first "
                f"is {roots[0]}): gsn2x draws both and warns; a case casewatch monitors has "
                "one root goal",
                self.nodes[extra].mark,
                f"name {extra} in the `supportedBy` or `inContextOf` of the node it belongs to",
            )
        return roots

    def reachability(self, roots: list[str]) -> None:
        reached: set[str] = set()
        frontier = list(roots)
        while True:
            while frontier:
                node_id = frontier.pop()
                if node_id in reached or node_id not in self.nodes:
                    continue
                reached.add(node_id)
                node = self.nodes[node_id]
                frontier.extend(node.supported_by)
                frontier.extend(node.in_context_of)
            # A counter node hangs off the claim (or the relation) it challenges.
            frontier = [
                n.id
                for n in self.nodes.values()
                if n.id not in reached
                and (
                    any(t in reached for t in n.challenges)
                    or any(a in reached or b in reached for a, b in n.challenged_relations)
                )
            ]
            if not frontier:
                break
        for node in self.nodes.values():
            if node.id in reached or node.id in roots:
                continue
            kind = _TYPE_NAMES[node.type]
            if node.type in (C, A, J):
                hint = "name it in the `inContextOf` of a goal or strategy, or remove it"
            elif node.type in COUNTER_TYPES:
                hint = "challenge a node of the argument, or support a counter-goal that does"
            else:
                hint = "name it in the `supportedBy` of a goal or strategy, or remove it"
            self.add(
                "CW037",
                f"{kind} {node.id} is not connected to the root goal {roots[0]}"
                if len(roots) == 1
                else f"{kind} {node.id} is not connected to any root ({', '.join(roots)})",
                node.mark,
                hint,
            )

    def development(self, node: Node) -> None:
        if node.undeveloped and node.supported_by:
            self.add(
                "CW038",
                f"{node.id} is marked undeveloped but has `supportedBy`",
                node.key_marks.get("undeveloped", node.mark),
                "remove `undeveloped: true` once the node is developed, or drop its support",
            )
        # A `supportedBy` that failed validation was already reported; do not add a warning.
        # One that validated but is empty (`supportedBy: []`) is no support at all.
        reported = "supportedBy" in node.key_marks and node.id in self.invalid
        if (
            node.type in DEVELOPABLE
            and not node.supported_by
            and not node.undeveloped
            and not reported
        ):
            kind = _TYPE_NAMES[node.type]
            message = f"{kind} {node.id} has no support and is not marked undeveloped"
            if node.id == self.root:
                message = (
                    f"the root goal {node.id} has no support and is not marked undeveloped: "
                    "nothing is argued below it, so every run judges nothing and passes"
                )
            self.add(
                "CW039",
                message,
                node.key_marks.get("supportedBy", node.mark),
                "add `supportedBy: [...]`, or `undeveloped: true` to say the gap is known",
            )
