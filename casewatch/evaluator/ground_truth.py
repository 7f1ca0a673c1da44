"""Scoring hazard events against labelled ground truth, the way the study counted.

A detected event that overlaps a label of the same hazard is a true positive; each label (and
each event) is matched at most once, using a maximum bipartite matching so the count does not
depend on the order events happen to be listed in. Remaining events are false positives,
remaining labels false negatives.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import networkx as nx

from casewatch.errors import CasewatchError
from casewatch.evaluator.result import Episode, EventMark, GroundTruth, HazardScore, LabelInterval


@dataclass(frozen=True)
class Label:
    hazard: str  # as written in the file
    start: float
    end: float
    line: int


class LabelsError(CasewatchError, ValueError):
    """A labels file that cannot be used; the message names the file, line and field."""


def label_lines(
    path: Path,
    data: bytes,
    error: type[ValueError],
    example: str,
) -> Iterator[tuple[int, str, dict]]:
    """(line number, "file:line", object) of every non-blank line of a JSON Lines label file;
    a line that is not a JSON object raises `error` naming the file and line (`example`: what
    a line should look like). The hazard labels and the fault labels (`evaluator.faults`) are
    read through it."""
    for number, raw in enumerate(data.decode("utf-8", errors="replace").splitlines(), start=1):
        if not raw.strip():
            continue
        where = f"{path}:{number}"
        try:
            item = json.loads(raw)
        except json.JSONDecodeError as exc:
            raise error(f"{where}: not valid JSON ({exc.msg} at column {exc.colno})") from None
        except RecursionError:
            raise error(f"{where}: JSON nested too deeply to be a label") from None
        if not isinstance(item, dict):
            raise error(f"{where}: expected an object like {example}")
        yield number, where, item


def label_interval(item: dict, where: str, error: type[ValueError]) -> tuple[float, float]:
    """A label's closed interval [start, end] in seconds: two finite numbers, end not before
    start (a NaN bound would match nothing and hide the label), else `error` naming the key."""
    bounds = []
    for key in ("start", "end"):
        value = item.get(key)
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise error(f"{where}: '{key}' must be a number of seconds, got {value!r}")
        try:
            number = float(value)
        except OverflowError:
            number = math.inf
        if not math.isfinite(number):
            raise error(f"{where}: '{key}' must be a finite number of seconds, got {value!r}")
        bounds.append(number)
    if bounds[1] < bounds[0]:
        raise error(f"{where}: 'end' ({bounds[1]}) is before 'start' ({bounds[0]})")
    return bounds[0], bounds[1]


def read_labels(path: str | Path) -> tuple[list[Label], str]:
    """Read a labels file (JSON Lines of `{"hazard", "start", "end"}`); returns labels, sha256."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise LabelsError(f"{path}: cannot read labels file: {exc.strerror}") from None
    labels: list[Label] = []
    example = '{"hazard": "CSn1", "start": 12.0, "end": 14.5}'
    for number, where, item in label_lines(path, data, LabelsError, example):
        hazard = item.get("hazard")
        if not isinstance(hazard, str) or not hazard:
            raise LabelsError(f"{where}: 'hazard' must be a node id or hazard name (a string)")
        start, end = label_interval(item, where, LabelsError)
        labels.append(Label(hazard, start, end, number))
    return labels, hashlib.sha256(data).hexdigest()


def resolve_hazard(name: str, hazard_texts: dict[str, str]) -> str | None:
    """Map a label's hazard (node id, or node text, case-insensitive) to a hazard node id."""
    if name in hazard_texts:
        return name
    wanted = name.strip().casefold()
    for node_id, text in hazard_texts.items():
        if node_id.casefold() == wanted or text.strip().casefold() == wanted:
            return node_id
    return None


def _score(tp: int, fp: int, fn: int, hazard: str) -> HazardScore:
    return HazardScore(
        hazard=hazard,
        true_positives=tp,
        false_positives=fp,
        false_negatives=fn,
        precision=tp / (tp + fp) if tp + fp else None,
        recall=tp / (tp + fn) if tp + fn else None,
    )


def match_counts(
    detected: list[tuple[float, float]], truth: list[tuple[float, float]]
) -> tuple[int, int, int]:
    """(TP, FP, FN) of detected intervals against labelled ones: an event and a label match
    when they overlap (closed intervals), each at most once, as many pairs as possible (a
    maximum bipartite matching). `casewatch tune` scores its candidates with this too."""
    tp = len(match_pairs(detected, truth))
    return tp, len(detected) - tp, len(truth) - tp


def match_pairs(
    first: list[tuple[float, float]], second: list[tuple[float, float]]
) -> list[tuple[int, int]]:
    """The matched (index in first, index in second) pairs of `match_counts`'s matching,
    sorted (`casewatch diff` pairs two runs' episodes with it)."""
    if not first or not second:
        return []
    graph = nx.Graph()
    events_side = [("event", i) for i in range(len(first))]
    graph.add_nodes_from(events_side)
    graph.add_nodes_from(("label", j) for j in range(len(second)))
    for i, (start, end) in enumerate(first):
        for j, (label_start, label_end) in enumerate(second):
            if start <= label_end and label_start <= end:
                graph.add_edge(("event", i), ("label", j))
    if graph.number_of_edges() == 0:
        return []
    matching = nx.bipartite.hopcroft_karp_matching(graph, top_nodes=events_side)
    return sorted((node[1], other[1]) for node, other in matching.items() if node[0] == "event")


def score_events(
    events: list[Episode],
    labels: list[Label],
    hazard_texts: dict[str, str],
    labels_path: str,
    labels_digest: str,
) -> GroundTruth:
    """Per-hazard and overall true/false positives and negatives, precision and recall."""
    by_hazard: dict[str, list[Label]] = {h: [] for h in hazard_texts}
    unmatched_names: set[str] = set()
    for label in labels:
        node_id = resolve_hazard(label.hazard, hazard_texts)
        if node_id is None:
            unmatched_names.add(label.hazard)
        else:
            by_hazard[node_id].append(label)
    per_hazard: list[HazardScore] = []
    totals = [0, 0, 0]
    marks: list[EventMark] = []
    for hazard in hazard_texts:
        found = [e for e in events if e.node_id == hazard and e.kind == "hazard"]
        detected = [(e.start, e.end) for e in found]
        truth = [(label.start, label.end) for label in by_hazard[hazard]]
        hits = {i for i, _ in match_pairs(detected, truth)}
        tp, fp, fn = len(hits), len(detected) - len(hits), len(truth) - len(hits)
        per_hazard.append(_score(tp, fp, fn, hazard))
        marks += [
            EventMark(
                formula_id=e.formula_id,
                node_id=e.node_id,
                start=e.start,
                end=e.end,
                match="TP" if i in hits else "FP",
            )
            for i, e in enumerate(found)
        ]
        totals = [totals[0] + tp, totals[1] + fp, totals[2] + fn]
    return GroundTruth(
        labels_path=labels_path,
        labels_digest=labels_digest,
        per_hazard=per_hazard,
        overall=_score(totals[0], totals[1], totals[2], hazard="all"),
        unmatched_label_names=sorted(unmatched_names),
        labels=[
            LabelInterval(node_id=h, start=lab.start, end=lab.end)
            for h, labs in by_hazard.items()
            for lab in labs
        ],
        marks=marks,
    )
