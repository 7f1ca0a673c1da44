"""Two runs of the same logs compared: which episodes are new, fixed or changed, per node.

A validation team's daily question: what did the new software version change on the same
drives? Episodes of one formula are paired across the two runs by overlap, each at most once
and as many pairs as possible (the matcher of `--labels`, `evaluator.ground_truth`):

- **new**: an episode of run B that overlaps none of run A's (a regression);
- **fixed**: an episode of run A that overlaps none of run B's;
- **changed**: a pair whose span moved by more than one period or whose worst robustness
  differs (reported with the differences, not counted as a regression);

plus episodes per hour and the verdict of each run. Results are plain values
(`casewatch diff` renders them).
"""

from __future__ import annotations

from evaluator.ground_truth import match_pairs
from evaluator.policy import gated
from evaluator.result import Episode, RunResult

#: Worst-robustness differences below this are rounding, not a change.
ROBUSTNESS_TOLERANCE = 1e-9


def _span(e: Episode) -> dict[str, float]:
    return {"start": e.start, "end": e.end, "worst_robustness": e.worst_robustness}


def _hours(result: RunResult) -> float:
    return (result.stream.duration or 0.0) / 3600.0


def diff_runs(a: RunResult, b: RunResult, name: str = "") -> dict:
    """The differences from run `a` to run `b` (see the module docstring)."""
    period = b.case.period or a.case.period
    kinds = {f.id: f.kind for f in (*a.formulas, *b.formulas)}
    node_of = {f.id: f.node_id for f in (*a.formulas, *b.formulas)}
    nodes = sorted(kinds, key=lambda f: (kinds[f] != "spi", f))
    rows = []
    for formula in nodes:
        ea = [e for e in a.episodes if e.formula_id == formula]
        eb = [e for e in b.episodes if e.formula_id == formula]
        pairs = match_pairs([(e.start, e.end) for e in ea], [(e.start, e.end) for e in eb])
        paired_a = {i for i, _ in pairs}
        paired_b = {j for _, j in pairs}
        changed = []
        for i, j in pairs:
            x, y = ea[i], eb[j]
            moved = max(abs(x.start - y.start), abs(x.end - y.end)) > period + 1e-9
            worse = abs(x.worst_robustness - y.worst_robustness) > ROBUSTNESS_TOLERANCE
            if moved or worse:
                changed.append({"a": _span(x), "b": _span(y)})
        row = {
            "formula": formula,
            "node": node_of[formula],
            "kind": kinds[formula],
            "a": len(ea),
            "b": len(eb),
            "new": [_span(eb[j]) for j in range(len(eb)) if j not in paired_b],
            "fixed": [_span(ea[i]) for i in range(len(ea)) if i not in paired_a],
            "changed": changed,
        }
        if row["a"] or row["b"]:
            rows.append(row)
    ha, hb = _hours(a), _hours(b)
    return {
        "log": name or b.case.module,
        "stream_a": a.stream.path,
        "stream_b": b.stream.path,
        "same_stream": bool(a.stream.digest and a.stream.digest == b.stream.digest),
        "verdict_a": a.verdict,
        "verdict_b": b.verdict,
        "hours_a": round(ha, 6),
        "hours_b": round(hb, 6),
        "per_hour_a": round(len(a.episodes) / ha, 4) if ha else None,
        "per_hour_b": round(len(b.episodes) / hb, 4) if hb else None,
        "nodes": rows,
    }


def regressions(diffs: list[dict], fail_on: str) -> int:
    """New episodes that the policy counts (`evaluator.policy`), over every log."""
    return sum(len(row["new"]) for d in diffs for row in d["nodes"] if gated(row["kind"], fail_on))


def is_empty(d: dict) -> bool:
    """No new, fixed or changed episode and the same verdict."""
    return d["verdict_a"] == d["verdict_b"] and not any(
        row["new"] or row["fixed"] or row["changed"] for row in d["nodes"]
    )
