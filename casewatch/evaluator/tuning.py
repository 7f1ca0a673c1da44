"""Thresholds from data: sweep a formula's threshold (and duration) over saved signals, form
episodes exactly as the evaluator does, and score them against labels (`casewatch tune`);
`evaluator.calibration` counts them on nominal logs (`casewatch calibrate`).

Every formula has one **knob**: the constant of its first comparison between a signal and a
number (`els >= 0.6`, `lead_thw < 1.0 and ...`), plus its duration: an SPI's `for:` window or a
hazard rule's `min_duration`. Candidates are quantiles of the signal's observed values (rounded
to 4 significant digits, so the tuned case says exactly what was measured) and a few durations,
the original values always among them. Scores use `evaluator.ground_truth.match_counts`, the
matcher of `casewatch run --labels`; the episodes are those `evaluator.episodes` would form
(tested against real runs). Everything returned is a plain value (dicts, lists, floats).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any, cast

import numpy as np

from casewatch.errors import CasewatchError
from casewatch.evaluator.ground_truth import Label, match_counts, resolve_hazard
from casewatch.evaluator.signal_store import SavedSignals
from casewatch.evaluator.vector_eval import Segments, Unsupported, evaluated_ticks, robustness
from casewatch.safety_case.model import Case
from casewatch.spec.ast import Compare, Formula, Interval, Node, Num, Signal, Window, children, walk
from casewatch.spec.model import CompiledSpec
from casewatch.spec.parser import FormulaError, parse_formula

#: Quantile levels always tried besides the evenly spaced ones (the tails of the values).
TAIL_LEVELS = (1e-5, 1e-4, 1e-3, 3e-3, 1 - 3e-3, 1 - 1e-3, 1 - 1e-4, 1 - 1e-5)
#: Durations [s] tried besides the original one.
SPI_WINDOWS = (0.0, 0.5, 1.0, 2.0)
HAZARD_DURATIONS = (0.0, 0.5, 1.0, 1.5, 2.0)
OBJECTIVES = ("f1", "min-precision")


class TuningError(CasewatchError, ValueError):
    """Input tuning cannot use (names the rule, log or file)."""


@dataclass(frozen=True)
class Knob:
    """What tuning sweeps in one formula (see the module docstring)."""

    formula_id: str
    node_id: str
    node_text: str
    kind: str  # "spi" or "hazard"
    source: str  # the formula text as the case writes it (hazard `when`, SPI threshold or stl)
    condition: Formula  # SPI: holds while fine; hazard: holds while the hazard is present
    path: tuple[int, ...]  # child indices from `condition` to the swept comparison
    signal: str
    op: str
    signal_left: bool
    value: float
    duration_kind: str | None  # "for" (SPI window), "min_duration" (hazard) or None
    duration: float
    merge_gap: float
    min_duration: float
    raw_stl: bool = False

    @property
    def parameter(self) -> str:
        return f"{self.signal} {self.op}" if self.signal_left else f"{self.op} {self.signal}"


def _swept(formula: Formula) -> tuple[tuple[int, ...], Compare] | None:
    """The first comparison of a signal with a number, and its path."""

    def visit(node: Node, path: tuple[int, ...]):
        if isinstance(node, Compare) and (
            (isinstance(node.left, Signal) and isinstance(node.right, Num))
            or (isinstance(node.left, Num) and isinstance(node.right, Signal))
        ):
            return path, node
        for k, child in enumerate(children(node)):
            found = visit(child, (*path, k))
            if found is not None:
                return found
        return None

    return visit(formula, ())


def knobs(case: Case, spec: CompiledSpec) -> tuple[list[Knob], list[dict[str, str]]]:
    """The knob of every formula of `spec`, and the formulas tuning cannot sweep (with why)."""
    out: list[Knob] = []
    skipped: list[dict[str, str]] = []
    for f in spec.formulas:
        node = case.nodes[f.node_id]
        if node.contract is not None:
            skipped.append(
                {
                    "formula": f.id,
                    "reason": "a contract: its guarantee is judged "
                    "only where its assumption holds, which a threshold sweep of the "
                    "guarantee alone ignores; set its parameters instead",
                }
            )
            continue
        duration_kind: str | None = None
        duration = 0.0
        raw = False
        if f.kind == "spi" and node.spi is not None and node.spi.stl is None:
            assert node.spi.signal is not None and node.spi.threshold is not None
            th = node.spi.threshold
            condition: Formula = Compare(th.op, Signal(node.spi.signal), Num(th.value))
            duration_kind, duration = "for", float(node.spi.for_seconds or 0.0)
        else:
            text = node.spi.stl if f.kind == "spi" and node.spi else f.source
            raw = f.kind == "spi"
            try:
                condition = parse_formula(text or "")
            except FormulaError as exc:
                skipped.append({"formula": f.id, "reason": f"does not parse: {exc}"})
                continue
            if f.kind == "hazard":
                duration_kind, duration = "min_duration", f.min_duration
        found = _swept(condition)
        if found is None:
            skipped.append(
                {"formula": f.id, "reason": "no comparison of a signal with a number to sweep"}
            )
            continue
        bad = [n for n in walk(condition) if not _supported(n)]
        if bad:
            skipped.append(
                {
                    "formula": f.id,
                    "reason": "uses future operators or `since` "
                    "(tuning evaluates past-time formulas)",
                }
            )
            continue
        path, cmp = found
        left = isinstance(cmp.left, Signal)
        sig = cmp.left if left else cmp.right
        num = cmp.right if left else cmp.left
        assert isinstance(sig, Signal) and isinstance(num, Num)
        out.append(
            Knob(
                formula_id=f.id,
                node_id=f.node_id,
                node_text=f.node_text,
                kind=f.kind,
                source=f.source,
                condition=condition,
                path=path,
                signal=sig.name,
                op=cmp.op,
                signal_left=left,
                value=float(num.value),
                duration_kind=duration_kind,
                duration=duration,
                merge_gap=f.merge_gap,
                min_duration=f.min_duration,
                raw_stl=raw,
            )
        )
    return out, skipped


def _supported(node: Node) -> bool:
    from casewatch.spec.ast import Next, Span

    if isinstance(node, Next | Span):
        return False
    return not (isinstance(node, Window) and node.op not in ("once", "historically"))


def _replace(node: Node, path: tuple[int, ...], value: float) -> Node:
    """`node` with the number of the comparison at `path` set to `value`."""
    if not path:
        assert isinstance(node, Compare)
        if isinstance(node.right, Num):
            return dataclasses.replace(node, right=Num(value))
        return dataclasses.replace(node, left=Num(value))
    kids = list(children(node))
    kids[path[0]] = _replace(kids[path[0]], path[1:], value)
    # one child: an operand; two: left and right (spec.ast.children's order)
    fields: dict[str, Any] = (
        {"operand": kids[0]} if len(kids) == 1 else {"left": kids[0], "right": kids[1]}
    )
    return dataclasses.replace(node, **fields)


def formula_for(knob: Knob, threshold: float, duration: float) -> Formula:
    """The condition with the candidate threshold (and, for an SPI, its `for:` window)."""
    condition = cast(Formula, _replace(knob.condition, knob.path, threshold))
    if knob.duration_kind == "for" and duration > 0:
        return Window("once", Interval(Fraction(0), Fraction(repr(duration))), condition)
    return condition


def episodes_from(
    t: np.ndarray, violated: np.ndarray, period: float, merge_gap: float, min_duration: float
) -> list[tuple[float, float]]:
    """Episodes of the violated ticks, as `evaluator.episodes.EpisodeTracker` forms them: a
    new episode where the clean time since the last violated tick's end reaches merge_gap,
    episodes shorter than min_duration dropped (a tick lasts one period); data gaps neither
    extend nor close an episode."""
    tv = t[violated]
    if len(tv) == 0:
        return []
    separation = tv[1:] - tv[:-1] - period
    split = np.flatnonzero((separation > 1e-9) & (separation >= merge_gap - 1e-9))
    starts = tv[np.concatenate([[0], split + 1])]
    ends = tv[np.concatenate([split, [len(tv) - 1]])]
    keep = ends - starts + period >= min_duration - 1e-9
    return list(zip(starts[keep].tolist(), ends[keep].tolist(), strict=True))


def violations(knob: Knob, log: SavedSignals, threshold: float, duration: float) -> np.ndarray:
    """(n,) True at the ticks the formula reads as violated (an SPI failing, a hazard present)
    with the candidate values; data gaps are never violated."""
    formula = formula_for(knob, threshold, duration)
    names = {s.name for s in walk(formula) if isinstance(s, Signal)}
    columns = {name: log.column(name) for name in names}
    try:
        rho = robustness(formula, columns, log.t, log.period, log.max_gap)
    except Unsupported as exc:
        raise TuningError(f"{knob.formula_id}: {exc}") from None
    with np.errstate(invalid="ignore"):
        violated = rho < 0 if knob.kind == "spi" else rho > 0
    if knob.duration_kind == "for" and violated.any():
        violated[filling(log, evaluated_ticks(formula, columns), duration)] = False
    return violated


def filling(log: SavedSignals, evaluated: np.ndarray, duration: float) -> np.ndarray:
    """Indices of the ticks at which an SPI's `for: duration` is still filling: the first
    duration / period evaluated samples after the start of the log and after every restart (a
    gap). `casewatch run` judges no violation there (docs/formulas.md), so neither do tune and
    calibrate."""
    persist = round(duration / log.period) if duration > 0 else 0
    if not persist:
        return np.zeros(0, dtype=np.int64)
    segments = Segments(log.t, evaluated, log.max_gap)
    return segments.index[segments.position < persist]


def episodes_for(knob: Knob, log: SavedSignals, threshold: float, duration: float):
    """The candidate's episodes on one log."""
    min_duration = duration if knob.duration_kind == "min_duration" else knob.min_duration
    return episodes_from(
        log.t, violations(knob, log, threshold, duration), log.period, knob.merge_gap, min_duration
    )


def round_sig(value: float, digits: int = 4) -> float:
    """`value` to `digits` significant digits (what the tuned case will say)."""
    if value == 0 or not math.isfinite(value):
        return float(value)
    return float(f"{value:.{digits}g}")


def threshold_candidates(knob: Knob, logs: Sequence[SavedSignals], count: int) -> list[float]:
    """Quantiles of the signal's observed finite values (rounded), plus the original value."""
    values = np.concatenate([log.column(knob.signal) for log in logs])
    values = values[np.isfinite(values)]
    if len(values) == 0:
        raise TuningError(
            f"{knob.formula_id}: signal {knob.signal!r} has no value in any log; nothing to sweep"
        )
    distinct = np.unique(values)
    if len(distinct) <= count:
        quantiles = distinct
    else:
        # evenly spaced levels, and the tails, where the rare values that decide false alarms
        # and misses lie
        levels = np.union1d(np.linspace(0.0, 1.0, max(2, count)), TAIL_LEVELS)
        quantiles = np.quantile(values, levels)
    found = {round_sig(float(q)) for q in quantiles[1:-1]}
    # the extremes rounded outwards, so that one candidate never flags and one always does
    lo, hi = float(quantiles[0]), float(quantiles[-1])
    found |= {_outward(lo, math.floor), _outward(hi, math.ceil)}
    return sorted(found | {knob.value})


def _outward(value: float, step) -> float:
    """`value` to 4 significant digits, never inwards: rounded down (`math.floor`) or up
    (`math.ceil`) when rounding to nearest would land on the inner side."""
    rounded = round_sig(value)
    if value == 0 or not math.isfinite(value):
        return rounded
    if (step is math.floor and rounded <= value) or (step is math.ceil and rounded >= value):
        return rounded
    unit = 10.0 ** (math.floor(math.log10(abs(value))) - 3)
    return round_sig(rounded - unit if step is math.floor else rounded + unit)


def duration_candidates(knob: Knob, period: float) -> list[float]:
    base = {"for": SPI_WINDOWS, "min_duration": HAZARD_DURATIONS}.get(knob.duration_kind or "")
    if base is None:
        return [knob.duration]
    # windows count whole samples: durations on the period grid
    grid = {round(round(d / period) * period, 9) for d in base}
    return sorted(grid | {knob.duration})


def labels_of(knob: Knob, labels: Sequence[Label]) -> list[tuple[float, float]]:
    """The labelled intervals that name the knob's node (by id or text)."""
    texts = {knob.node_id: knob.node_text}
    return [(lab.start, lab.end) for lab in labels if resolve_hazard(lab.hazard, texts)]


@dataclass
class Sweep:
    """Counts of every candidate on every log: counts[c, log] = (tp, fp, fn, episodes)."""

    knob: Knob
    thresholds: list[float]
    durations: list[float]
    counts: np.ndarray
    logs: list[str]
    labelled: list[int] = field(default_factory=list)  # labels per log

    def candidates(self) -> list[tuple[float, float]]:
        return [(th, d) for d in self.durations for th in self.thresholds]


def sweep(
    knob: Knob,
    logs: Sequence[SavedSignals],
    labels: Sequence[Sequence[Label]] | None,
    count: int = 50,
) -> Sweep:
    """Every (threshold, duration) candidate on every log. Without labels only the episode
    counts are meaningful (calibration)."""
    if not logs:
        raise TuningError(f"{knob.formula_id}: no logs to sweep")
    thresholds = threshold_candidates(knob, logs, count)
    durations = duration_candidates(knob, logs[0].period)
    grid = [(th, d) for d in durations for th in thresholds]
    counts = np.zeros((len(grid), len(logs), 4), dtype=np.int64)
    truth = [labels_of(knob, labels[k]) if labels is not None else [] for k in range(len(logs))]
    for k, log in enumerate(logs):
        for c, (th, d) in enumerate(grid):
            found = episodes_for(knob, log, th, d)
            tp, fp, fn = match_counts(found, truth[k])
            counts[c, k] = (tp, fp, fn, len(found))
    return Sweep(
        knob, thresholds, durations, counts, [log.path for log in logs], [len(x) for x in truth]
    )


def scores(tp: int, fp: int, fn: int) -> dict[str, float | int | None]:
    """Counts with precision, recall (None when undefined) and F1, as plain numbers."""
    tp, fp, fn = int(tp), int(fp), int(fn)
    return {
        "tp": tp,
        "fp": fp,
        "fn": fn,
        "precision": tp / (tp + fp) if tp + fp else None,
        "recall": tp / (tp + fn) if tp + fn else None,
        "f1": 2 * tp / (2 * tp + fp + fn) if tp else 0.0,
    }


def _score_keys(totals: np.ndarray, objective: str, min_precision: float | None) -> np.ndarray:
    """(..., 3) keys of (..., 3) (tp, fp, fn) totals, larger is better, compared in order:
    whether the precision asked is reached (always 1 for f1), then recall (min-precision) or
    F1, then F1."""
    tp, fp, fn = (totals[..., k].astype(float) for k in range(3))
    f1 = np.where(tp > 0, 2 * tp / np.maximum(2 * tp + fp + fn, 1), 0.0)
    if objective != "min-precision":
        return np.stack([np.ones_like(f1), f1, f1], axis=-1)
    assert min_precision is not None
    precise = (tp + fp > 0) & (tp >= min_precision * np.maximum(tp + fp, 1) - 1e-12)
    recall = np.where(tp + fn > 0, tp / np.maximum(tp + fn, 1), 0.0)
    return np.stack([precise.astype(float), recall, f1], axis=-1)


def _is_best(keys: np.ndarray) -> np.ndarray:
    """(n,) True where a row of `keys` (n, 3) equals the lexicographically largest row."""
    top = keys[np.lexsort(keys.T[::-1])[-1]]
    return np.all(np.abs(keys - top) <= 1e-12, axis=1)


def margins(thresholds: np.ndarray, best: np.ndarray) -> np.ndarray:
    """(n,) For each best-scoring threshold (thresholds ascending): its distance to the nearest
    threshold that scores worse, on either side (to the outermost candidate where no worse one
    lies beyond); -1 for the others.

    Why: the labels pin a threshold down only between the errors on either side of it. The edge
    of the best-scoring range sits next to an error (in the worked example of docs/tuning.md,
    0.01 s under legal following), so a log the threshold was not fitted to errs there first;
    the middle of the range keeps the most room both ways."""
    th = np.asarray(thresholds, dtype=float)
    out = np.full(len(th), -1.0)
    good = np.flatnonzero(best)
    worse = np.flatnonzero(~best)
    if len(good) == 0:
        return out
    if len(worse) == 0:
        out[good] = np.minimum(th[good] - th[0], th[-1] - th[good])
        return out
    at = np.searchsorted(worse, good)
    below = np.where(at > 0, th[worse[np.maximum(at - 1, 0)]], th[0])
    above = np.where(at < len(worse), th[worse[np.minimum(at, len(worse) - 1)]], th[-1])
    out[good] = np.minimum(th[good] - below, above - th[good])
    return out


def _threshold_at(sw: Sweep, keys: np.ndarray) -> int:
    """Of the candidates of one duration (`keys`: one row per threshold of `sw.thresholds`,
    ascending), the index with the best key, then the largest margin to the nearest
    worse-scoring thresholds, then the nearest to the original threshold."""
    th = np.asarray(sw.thresholds, dtype=float)
    margin = margins(th, _is_best(keys))
    order = np.lexsort((np.abs(th - sw.knob.value), -margin))
    return int(order[0])


def pick(sw: Sweep, logs: Sequence[int], objective: str, min_precision: float | None) -> int:
    """The operating point on `logs` (indices); a candidate index, or -1 when no candidate
    reaches the precision asked for (`min-precision`).

    - At each duration, the threshold: the best score on `logs` (F1, or the best recall among
      candidates at least `min_precision` precise), then the largest margin to the nearest
      worse-scoring thresholds (`margins`), then the nearest to the original.
    - Of the durations, the one whose threshold scores best on `logs`; among equals, the
      original duration if it is among them (a duration is a delay the author chose, and
      nothing in the data asks to change it); then the best held-out score: leave each of
      `logs` out in turn, and score on it every threshold that scores best on the others at
      that duration, averaged (the others leave the threshold open anywhere in that range; a
      single pick from it would make the comparison of durations hang on which of two nearly
      equal thresholds won), summed over the logs; then the largest margin to the nearest
      worse-scoring durations; then the one nearest the original. Why: several durations
      usually score alike on the logs they were fitted to, and the shortest of them sits next
      to the durations that let short nominal dips through; only logs a duration was not
      fitted to, and the room on either side, tell them apart.
    """
    logs = list(logs)
    per_log = sw.counts[:, logs, :3]  # (candidates, logs, 3)
    keys = _score_keys(per_log.sum(axis=1), objective, min_precision)
    if objective == "min-precision" and not keys[:, 0].any():
        return -1
    n_th = len(sw.thresholds)
    at, fitted, held_keys = [], [], []
    for k in range(len(sw.durations)):
        rows = np.arange(k * n_th, (k + 1) * n_th)
        at.append(int(rows[_threshold_at(sw, keys[rows])]))
        fitted.append(keys[at[-1]])
        held = np.zeros(3)
        for j in range(len(logs) if len(logs) >= 2 else 0):
            others = np.delete(per_log[rows], j, axis=1).sum(axis=1)
            best = _is_best(_score_keys(others, objective, min_precision))
            held += per_log[rows[best], j].mean(axis=0)
        held_keys.append(
            _score_keys(held, objective, min_precision) if len(logs) >= 2 else fitted[-1]
        )
    fitted_keys = np.array(fitted)
    room = margins(np.asarray(sw.durations, dtype=float), _is_best(fitted_keys))
    ranks = [
        (
            *fitted_keys[k].round(12),
            d == sw.knob.duration,
            *held_keys[k].round(12),
            round(float(room[k]), 9),
            -abs(d - sw.knob.duration),
        )
        for k, d in enumerate(sw.durations)
    ]
    return at[max(range(len(ranks)), key=ranks.__getitem__)]


def tune(sw: Sweep, objective: str = "f1", min_precision: float | None = None) -> dict:
    """Fitted operating point on all logs, the original's scores, leave-one-log-out held-out
    scores (each log scored at the point picked on the others), and the PR points."""
    everyone = list(range(len(sw.logs)))
    grid = sw.candidates()
    original = grid.index((sw.knob.value, sw.knob.duration))
    chosen = pick(sw, everyone, objective, min_precision)
    total = sw.counts[:, :, :3].sum(axis=1)
    held = None
    if len(everyone) >= 2:
        counts = np.zeros(3, dtype=np.int64)
        for k in everyone:
            c = pick(sw, [j for j in everyone if j != k], objective, min_precision)
            counts += sw.counts[c if c >= 0 else original, k, :3]
        held = scores(*counts)
    best = chosen if chosen >= 0 else original
    th, d = grid[best]
    curve = [{"threshold": g[0], "duration": g[1], **scores(*total[c])} for c, g in enumerate(grid)]
    return {
        "formula": sw.knob.formula_id,
        "node": sw.knob.node_id,
        "kind": sw.knob.kind,
        "parameter": sw.knob.parameter,
        "duration_kind": sw.knob.duration_kind,
        "logs": len(sw.logs),
        "labels": int(sum(sw.labelled)),
        "original": {
            "threshold": sw.knob.value,
            "duration": sw.knob.duration,
            **scores(*total[original]),
        },
        "tuned": {"threshold": th, "duration": d, **scores(*total[best])},
        "reached": chosen >= 0,
        "heldout": held,
        "curve": curve,
    }
