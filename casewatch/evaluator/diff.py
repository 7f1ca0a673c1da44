"""Two runs of the same logs compared: which episodes are new, gone or changed, per node, and
with ground-truth labels which of them are fixed false alarms, lost or new detections.

A validation team's daily question: what did the new software version change on the same
drives? Episodes of one formula are paired across the two runs by overlap, each at most once
and as many pairs as possible (the matcher of `--labels`, `evaluator.ground_truth`). A pair
whose span moved by more than one period or whose worst robustness differs is **changed**
(reported with the differences, never a regression). What is left unpaired depends on what
is known about it:

- without labels (every SPI, and hazards when the runs carry none), an episode of run B only
  is **new** (a regression) and an episode of run A only is **gone**: neutral, since nothing
  says whether it was a false alarm or a hazard no longer found;
- a hazard with labels (both runs judged against the same labels, or `--labels`) splits them
  by the same label matching as precision and recall:
  - **fixed**: in A only, and it matched no label (a false alarm that went away);
  - **lost detection**: in A only, matched a label, and B finds that label with no episode
    (a regression);
  - **new detection**: in B only, matched a label A did not find;
  - **new**: in B only and it matches no label (a new false alarm, a regression);
  - **moved**: in one run only, but its label is found in the other run by an episode that
    does not overlap it (neutral).

plus episodes per hour and the verdict of each run. Results are plain values
(`casewatch diff` renders them).
"""

from __future__ import annotations

import re
from collections.abc import Sequence

from casewatch.evaluator.ground_truth import match_pairs
from casewatch.evaluator.policy import gated
from casewatch.evaluator.result import Episode, LabelInterval, RunResult

#: Worst-robustness differences below this are rounding, not a change.
ROBUSTNESS_TOLERANCE = 1e-9

#: The lists of unpaired episodes each node row carries, in display order.
CHANGE_KINDS = ("new", "lost", "new_detection", "fixed", "gone", "moved")
#: How each is spoken of, and whether it counts as a regression (red) or an improvement.
CHANGE_LABELS = {
    "new": "new",
    "lost": "lost detection",
    "new_detection": "new detection",
    "fixed": "fixed",
    "gone": "gone",
    "moved": "moved",
    "changed": "changed",
}
REGRESSION_KINDS = ("new", "lost")
IMPROVEMENT_KINDS = ("new_detection", "fixed")


def _span(e: Episode) -> dict[str, float]:
    return {"start": e.start, "end": e.end, "worst_robustness": e.worst_robustness}


def _with_label(e: Episode, label: LabelInterval, side: str | None = None) -> dict:
    span = {**_span(e), "label": {"start": label.start, "end": label.end}}
    return span if side is None else {**span, "run": side}


def _natural(name: str) -> list:
    """Sn2 before Sn12."""
    return [int(p) if p.isdigit() else p for p in re.split(r"(\d+)", name)]


def _hours(result: RunResult) -> float:
    return (result.stream.duration or 0.0) / 3600.0


def _unpaired(
    ea: list[Episode],
    eb: list[Episode],
    vanished: list[int],
    appeared: list[int],
    truth: list[LabelInterval] | None,
) -> dict[str, list[dict]]:
    """The unpaired episodes sorted into the module docstring's kinds."""
    out: dict[str, list[dict]] = {kind: [] for kind in CHANGE_KINDS}
    if truth is None:
        out["new"] = [_span(eb[j]) for j in appeared]
        out["gone"] = [_span(ea[i]) for i in vanished]
        return out
    spans = [(label.start, label.end) for label in truth]
    label_of_a = dict(match_pairs([(e.start, e.end) for e in ea], spans))
    label_of_b = dict(match_pairs([(e.start, e.end) for e in eb], spans))
    found_a, found_b = set(label_of_a.values()), set(label_of_b.values())
    for i in vanished:
        label = label_of_a.get(i)
        if label is None:
            out["fixed"].append(_span(ea[i]))
        elif label not in found_b:
            out["lost"].append(_with_label(ea[i], truth[label]))
        else:
            out["moved"].append(_with_label(ea[i], truth[label], "a"))
    for j in appeared:
        label = label_of_b.get(j)
        if label is None:
            out["new"].append(_span(eb[j]))
        elif label not in found_a:
            out["new_detection"].append(_with_label(eb[j], truth[label]))
        else:
            out["moved"].append(_with_label(eb[j], truth[label], "b"))
    return out


def diff_runs(
    a: RunResult, b: RunResult, name: str = "", labels: Sequence[LabelInterval] | None = None
) -> dict:
    """The differences from run `a` to run `b` (see the module docstring); `labels` are the
    ground truth of the log (hazard node id per interval), None when there is none."""
    period = b.case.period or a.case.period
    kinds = {f.id: f.kind for f in (*a.formulas, *b.formulas)}
    node_of = {f.id: f.node_id for f in (*a.formulas, *b.formulas)}
    nodes = sorted(kinds, key=lambda f: (kinds[f] != "spi", _natural(f)))
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
        labelled = labels is not None and kinds[formula] == "hazard"
        truth = (
            [lab for lab in labels if lab.node_id == node_of[formula]]
            if labels is not None and labelled
            else None
        )
        row = {
            "formula": formula,
            "node": node_of[formula],
            "kind": kinds[formula],
            "labelled": labelled,
            "a": len(ea),
            "b": len(eb),
            **_unpaired(
                ea,
                eb,
                [i for i in range(len(ea)) if i not in paired_a],
                [j for j in range(len(eb)) if j not in paired_b],
                truth,
            ),
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
        "labelled": labels is not None,
        "verdict_a": a.verdict,
        "verdict_b": b.verdict,
        "hours_a": round(ha, 6),
        "hours_b": round(hb, 6),
        "per_hour_a": round(len(a.episodes) / ha, 4) if ha else None,
        "per_hour_b": round(len(b.episodes) / hb, 4) if hb else None,
        "nodes": rows,
    }


def totals(d: dict) -> dict[str, int]:
    """Per kind (`CHANGE_KINDS` and `changed`), how many episodes of the log `d` have it."""
    return {kind: sum(len(row[kind]) for row in d["nodes"]) for kind in (*CHANGE_KINDS, "changed")}


def regressions(diffs: list[dict], fail_on: str) -> int:
    """New episodes (new false alarms, with labels) and lost detections that the policy counts
    (`evaluator.policy`), over every log."""
    return sum(
        len(row[kind])
        for d in diffs
        for row in d["nodes"]
        if gated(row["kind"], fail_on)
        for kind in REGRESSION_KINDS
    )


def is_empty(d: dict) -> bool:
    """No unpaired or changed episode and the same verdict."""
    return d["verdict_a"] == d["verdict_b"] and not any(totals(d).values())
