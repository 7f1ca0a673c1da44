"""Node status at each tick, propagated up the argument.

Statuses (architecture.md, "Verdicts and status"), worst first:
- `violated`: a monitored evidence node whose formula is violated at this tick; for a hazard
  node (CSn, or a CG above one) it means the hazard condition holds;
- `undermined`: a goal or strategy with violated or undermined support below it;
- `in-doubt`: challenged by an active hazard, or supported by an in-doubt node;
- `no-data`: its formula (or support below it) could not be evaluated at this tick;
- `undeveloped`: marked undeveloped, or supported by an undeveloped node;
- `satisfied`: everything below it holds;
- `external` (casewatch's addition): evidence or context the monitor does not observe (an Sn
  without `spi:`, C/A/J nodes). It is neutral in propagation: it neither supports nor undermines.
- `outside-assumption` (docs/contracts.md): a contract whose assumption fails at this tick;
  neither a pass nor a violation, and it reaches the goals above like any status;
- `outside-odd` (docs/odd.md): a context node with an `odd:` whose ODD the tick is outside of;
  every node in its scope (the goals and strategies naming it in `inContextOf`, and everything
  that supports them) that would be `satisfied` is `outside-odd` instead, and `no-data` when a
  condition is not reported: a pass outside the domain would extrapolate. Violations stay.

`summarize` turns a node's statuses over a run into the one status a report colours it with
(docs/reports.md, "Node colours"): findings (`violated`, `undermined`, `in-doubt`) from a
single tick; any other status only when it holds on at least 1 % of the ticks after warm-up,
so one warm-up tick or a short gap does not turn a 99.9 % satisfied node grey.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Literal

import networkx as nx

from casewatch.evaluator.result import STATUS_SEVERITY, NodeStatus
from casewatch.safety_case.model import Case, NodeType

Verdict = Literal["ok", "violated", "no-data", "outside-assumption"]
OddVerdict = Literal["inside", "outside", "unknown"]
_OWN = {
    "ok": "satisfied",
    "violated": "violated",
    "no-data": "no-data",
    "outside-assumption": "outside-assumption",
}
_ODD_CONTEXT = {"inside": "satisfied", "outside": "outside-odd", "unknown": "no-data"}
_ODD_SCOPE = {"outside": "outside-odd", "unknown": "no-data"}

_COUNTER = (NodeType.COUNTER_GOAL, NodeType.COUNTER_SOLUTION)
_ARGUMENT = (NodeType.GOAL, NodeType.STRATEGY)


class StatusPropagator:
    """Computes every node's status from the formulas' verdicts at one tick.

    The same verdict combination always gives the same statuses, and runs repeat combinations
    for long stretches, so results are memoised by the verdict tuple.
    """

    def __init__(
        self,
        case: Case,
        formula_of_node: Mapping[str, str],
        odd_contexts: list[str] | tuple[str, ...] = (),
    ):
        self.case = case
        self.odd_contexts = tuple(odd_contexts)
        self.scope = self._odd_scope(case, self.odd_contexts)
        self.formula_of_node = dict(formula_of_node)
        self.formula_ids = sorted(set(self.formula_of_node.values()))
        self.order = self._evaluation_order(case)
        self.challengers: dict[str, list[str]] = {}
        for node in case.nodes.values():
            for target in node.challenges:
                self.challengers.setdefault(target, []).append(node.id)
        #: node statuses per combination of formula verdicts and ODD verdicts
        self._memo: dict[tuple[str, ...], dict[str, str]] = {}

    @staticmethod
    def _evaluation_order(case: Case) -> list[str]:
        """Children before parents; a challenged node after the counter nodes challenging it."""
        deps = nx.DiGraph()
        deps.add_nodes_from(case.nodes)
        for node in case.nodes.values():
            for child in node.supported_by:
                if child in case.nodes:
                    deps.add_edge(child, node.id)
            for target in node.challenges:
                if target in case.nodes:
                    deps.add_edge(node.id, target)
        return list(nx.lexicographical_topological_sort(deps))

    @staticmethod
    def _odd_scope(case: Case, contexts: tuple[str, ...]) -> dict[str, list[str]]:
        """node id -> the ODD contexts whose scope it is in: a goal or strategy naming the
        context in `inContextOf`, and every node below it along `supportedBy`."""
        support = nx.DiGraph()
        support.add_nodes_from(case.nodes)
        for node in case.nodes.values():
            support.add_edges_from((node.id, c) for c in node.supported_by if c in case.nodes)
        scope: dict[str, list[str]] = {}
        for context in contexts:
            heads = [n.id for n in case.nodes.values() if context in n.in_context_of]
            covered = set(heads).union(*(nx.descendants(support, h) for h in heads))
            for node_id in covered:
                scope.setdefault(node_id, []).append(context)
        return scope

    def statuses(
        self, verdicts: Mapping[str, Verdict], odd: Mapping[str, OddVerdict] | None = None
    ) -> dict[str, str]:
        """Status of every node given each formula's verdict (`ok`, `violated`, `no-data`,
        `outside-assumption`) and each ODD context's (`inside`, `outside`, `unknown`)."""
        odd = odd or {}
        key = tuple(verdicts.get(f, "no-data") for f in self.formula_ids) + tuple(
            odd.get(c, "unknown") for c in self.odd_contexts
        )
        cached = self._memo.get(key)
        if cached is not None:
            return cached
        out: dict[str, str] = {}
        for node_id in self.order:
            out[node_id] = self._status_of(node_id, verdicts, out, odd)
        if len(self._memo) < 4096:
            self._memo[key] = out
        return out

    def _status_of(
        self,
        node_id: str,
        verdicts: Mapping[str, Verdict],
        known: Mapping[str, str],
        odd: Mapping[str, OddVerdict],
    ) -> str:
        node = self.case.nodes[node_id]
        formula = self.formula_of_node.get(node_id)
        own = "external"
        if node_id in self.odd_contexts:
            return _ODD_CONTEXT[odd.get(node_id, "unknown")]
        if formula is not None:
            own = _OWN[verdicts.get(formula, "no-data")]
        elif node.type in _COUNTER:
            # A counter-goal holds while any counter-evidence below it holds.
            below = [known[c] for c in node.supported_by if c in known]
            own = _worst(below) if below else "external"
            if own not in ("violated", "no-data", "satisfied"):
                own = "external"
        elif node.type in _ARGUMENT:
            below = [known[c] for c in node.supported_by if c in known]
            worst = _worst(below) if below else "undeveloped"
            if worst in ("violated", "undermined"):
                own = "undermined"
            elif worst == "external":
                own = "undeveloped" if node.undeveloped else "external"
            else:
                own = worst
            if node.undeveloped and own in ("satisfied", "external"):
                own = "undeveloped"
        if own == "satisfied" and node.type not in _COUNTER:
            for context in self.scope.get(node_id, ()):
                scoped = _ODD_SCOPE.get(odd.get(context, "unknown"))
                if scoped is not None and STATUS_SEVERITY[scoped] > STATUS_SEVERITY[own]:
                    own = scoped
        challenged = any(known.get(c) == "violated" for c in self.challengers.get(node_id, ()))
        if challenged and STATUS_SEVERITY[own] < STATUS_SEVERITY["in-doubt"]:
            own = "in-doubt"
        return own


def _worst(statuses: list[str]) -> str:
    return max(statuses, key=STATUS_SEVERITY.__getitem__)


def worst_status(statuses: list[str]) -> str:
    """The worst of several statuses (`external` when empty)."""
    return _worst(statuses) if statuses else "external"


#: Statuses that are findings: they colour a node from a single tick.
FINDINGS = ("violated", "undermined", "in-doubt")
#: Any other status colours a node only on at least this share of its ticks after warm-up.
SUMMARY_SHARE = 0.01
#: The `no-data` stretch a run starts with counts as warm-up for at most this long (seconds):
#: metrics that need history and windowed formulas have no value yet. Longer, the rest is a
#: data gap like any other.
WARMUP_MAX_S = 10.0


@dataclass(frozen=True)
class StatusSummary:
    """A node's statuses over a run, and the one it is coloured with."""

    status: str  # the colour (`summarize`'s rule)
    worst: str  # the worst status of any tick (`NodeStatus.worst`)
    ticks: dict[str, int]  # status -> ticks over the run
    warmup_ticks: int  # of the `no-data` ticks, those of the warm-up

    @property
    def total(self) -> int:
        return sum(self.ticks.values())


def warmup_ticks(status: NodeStatus, period: float) -> int:
    """The `no-data` ticks the node's run starts with, up to `WARMUP_MAX_S`, when a verdict
    follows them (a node that never had data has no warm-up: it has no data)."""
    timeline = status.timeline
    if len(timeline) < 2 or timeline[0].status != "no-data":
        return 0
    most = round(WARMUP_MAX_S / period) + 1 if period > 0 else timeline[0].ticks
    return min(timeline[0].ticks, most)


def summarize(status: NodeStatus | None, period: float) -> StatusSummary:
    """The colour of a node (module docstring): the worst finding of any tick; otherwise the
    worst status holding on at least `SUMMARY_SHARE` of the ticks with warm-up left out; the
    most frequent one when none does. A node without ticks has no data."""
    if status is None or not sum(status.ticks.values()):
        return StatusSummary("no-data", "no-data", {}, 0)
    warmup = warmup_ticks(status, period)
    counted = {name: n for name, n in status.ticks.items() if n}
    counted["no-data"] = counted.get("no-data", 0) - warmup
    total = sum(counted.values())
    findings = [name for name in FINDINGS if counted.get(name)]
    if findings:
        colour = _worst(findings)
    else:
        eligible = [name for name, n in counted.items() if n > 0 and n >= SUMMARY_SHARE * total]
        colour = _worst(eligible) if eligible else max(counted, key=counted.__getitem__)
    return StatusSummary(colour, status.worst, dict(status.ticks), warmup)
