"""From many judged runs to an Operational Design Domain (`casewatch odd`, docs/odd.md).

Each run's `result.json` counts, per combination of reported conditions, every formula's
judged, violated, outside-assumption and no-data ticks (`RunResult.conditions`). Grouped by
the chosen attributes (a *cell*: `road.type=highway, environment.weather=fog`), they give per
cell and formula:

- the **violation rate**: violated ticks / judged ticks (ticks outside a contract's assumption
  and without data are not judged), with a 95 % confidence interval that treats runs as the
  independent units (ticks of one drive are not independent): the cluster-robust ratio
  estimator, `r +- t(n-1) * sqrt(n / (n - 1) * sum((v_i - r e_i)^2)) / sum(e_i)`, clipped to
  [0, 1]. With one run there is no spread to estimate: the interval is then the Wilson score
  interval over its ticks, marked `ticks` (optimistic);
- the **runs violated**: runs with at least one violated tick, of the runs judged there.

A cell is **accepted** when every gating formula's rate (its upper confidence bound with
`criterion="upper"`) stays below `max_rate` (the study's rule, "less than 5 %"; `strict=False`
accepts a rate equal to it), and every `max_mae` bound holds (below it, likewise); the accepted
cells are the domain. Continuous conditions (a fog density 0-100) can be binned (`Bins`: the
study's light [0, 30], medium (30, 70], heavy (70, 100]). Plain values in, plain values out.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from itertools import pairwise
from typing import Any

import numpy as np

from casewatch.evaluator.result import RunResult
from casewatch.safety_case.model import OddRange, OddSpec

#: Two-sided 95 % quantiles of Student's t for 1-30 degrees of freedom (beyond: 1.96).
_T95 = (
    12.706,
    4.303,
    3.182,
    2.776,
    2.571,
    2.447,
    2.365,
    2.306,
    2.262,
    2.228,
    2.201,
    2.179,
    2.160,
    2.145,
    2.131,
    2.120,
    2.110,
    2.101,
    2.093,
    2.086,
    2.080,
    2.074,
    2.069,
    2.064,
    2.060,
    2.056,
    2.052,
    2.048,
    2.045,
    2.042,
)
Z95 = 1.959964


def t95(df: int) -> float:
    return _T95[df - 1] if 1 <= df <= len(_T95) else Z95


def wilson(successes: int, n: int, z: float = Z95) -> tuple[float, float]:
    """The Wilson score interval of a binomial proportion ((0, 1) for n = 0)."""
    if n <= 0:
        return 0.0, 1.0
    p = successes / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return max(0.0, centre - half), min(1.0, centre + half)


#: How each interval code of `cluster_rate` was computed, as the page names it.
INTERVAL_METHODS = {
    "runs": "cluster-robust ratio estimator over runs, Student t, 95 %",
    "ticks": "Wilson score interval over the ticks of one run, 95 % (optimistic: ticks of one "
    "drive are not independent)",
    "none": "nothing judged",
}


@dataclass(frozen=True)
class Bins:
    """Bins of a continuous condition: `edges` e0 < e1 < ... < en make the bins [e0, e1],
    (e1, e2], ..., (en-1, en] (the study's [0, 30], (30, 70], (70, 100]), named by `names` or
    by their interval."""

    attribute: str
    edges: tuple[float, ...]
    names: tuple[str, ...] = ()

    def labels(self) -> list[str]:
        if self.names:
            return list(self.names)
        e = self.edges
        return [f"{'[' if k == 0 else '('}{e[k]:g}, {e[k + 1]:g}]" for k in range(len(e) - 1)]

    def index(self, value: object) -> int | None:
        """The bin of `value`; None for a value that is no number or outside every bin."""
        if isinstance(value, bool) or not isinstance(value, int | float):
            return None
        e = self.edges
        if e[0] <= value <= e[1]:
            return 0
        for k in range(1, len(e) - 1):
            if e[k] < value <= e[k + 1]:
                return k
        return None

    def label(self, value: object) -> object:
        k = self.index(value)
        if k is not None:
            return self.labels()[k]
        if value is None or isinstance(value, bool) or not isinstance(value, int | float):
            return value  # not reported, or a text the bins cannot place: as it is
        return f"outside [{self.edges[0]:g}, {self.edges[-1]:g}]"

    def to_data(self) -> dict:
        return {"edges": list(self.edges), "labels": self.labels()}


def parse_bins(text: str) -> Bins:
    """`ATTR=e0,e1,...,en` or `ATTR=e0,...,en:name1,...` (one name per bin); ValueError with
    what is wrong."""
    name, sep, rest = text.partition("=")
    edges_text, _, names_text = rest.partition(":")
    try:
        edges = tuple(float(x) for x in edges_text.split(","))
    except ValueError:
        edges = ()
    if not sep or not name.strip() or len(edges) < 2 or any(not math.isfinite(e) for e in edges):
        raise ValueError(
            f"{text!r}: expected ATTR=EDGE,EDGE[,...][:NAME,...], e.g. "
            "environment.fog=0,30,70,100:light,medium,heavy"
        )
    if any(b <= a for a, b in pairwise(edges)):
        raise ValueError(f"{text!r}: the edges must increase ({edges_text})")
    names = tuple(n.strip() for n in names_text.split(",")) if names_text else ()
    if names and (len(names) != len(edges) - 1 or not all(names)):
        raise ValueError(
            f"{text!r}: {len(edges) - 1} bins need {len(edges) - 1} names, got {len(names)}"
        )
    return Bins(name.strip(), edges, names)


def cluster_rate(violated: list[int], judged: list[int]) -> tuple[float | None, float, float, str]:
    """(rate, low, high, method) over runs (clusters) with `violated[i]` of `judged[i]` ticks;
    rate None when nothing was judged."""
    pairs = [(v, e) for v, e in zip(violated, judged, strict=True) if e > 0]
    total = sum(e for _, e in pairs)
    if not total:
        return None, 0.0, 1.0, "none"
    rate = sum(v for v, _ in pairs) / total
    n = len(pairs)
    if n == 1:
        lo, hi = wilson(pairs[0][0], pairs[0][1])
        return rate, lo, hi, "ticks"
    residual = sum((v - rate * e) ** 2 for v, e in pairs)
    se = math.sqrt(n / (n - 1) * residual) / total
    half = t95(n - 1) * se
    return rate, max(0.0, rate - half), min(1.0, rate + half), "runs"


@dataclass(frozen=True)
class RunInput:
    """One judged run: its folder (for signals) and its result."""

    folder: str
    result: RunResult


#: Reads a run folder's saved signals for `--max-mae`: (tick times, {name: values}).
SignalLoader = Callable[[str], tuple[np.ndarray, dict[str, np.ndarray]]]


def varying_attributes(runs: Iterable[RunInput]) -> list[str]:
    """The condition attributes that take more than one value over the runs, sorted."""
    seen: dict[str, set] = {}
    for run in runs:
        for cond in run.result.conditions:
            for k, v in cond.attributes.items():
                seen.setdefault(k, set()).add(repr(v))
    return sorted(k for k, vals in seen.items() if len(vals) > 1)


def _cell_of(attributes: dict, by: list[str], bins: dict[str, Bins]) -> tuple:
    return tuple(
        bins[name].label(attributes.get(name)) if name in bins else attributes.get(name)
        for name in by
    )


def _mae(spans: list[list[float]], t: np.ndarray, column: np.ndarray) -> tuple[float, int]:
    """(sum of |values|, count) at the ticks inside `spans` where the value is finite."""
    inside = np.zeros(len(t), dtype=bool)
    for a, b in spans:
        inside |= (t >= a - 1e-9) & (t <= b + 1e-9)
    picked = column[inside]
    picked = picked[np.isfinite(picked)]
    return float(np.abs(picked).sum()), int(picked.size)


def analyse(
    runs: list[RunInput],
    by: list[str],
    formulas: list[str] | None,
    max_rate: float,
    criterion: str = "estimate",
    max_mae: dict[str, float] | None = None,
    load_signals: SignalLoader | None = None,
    bins: dict[str, Bins] | None = None,
    strict: bool = True,
) -> dict:
    """The per-cell table and the accepted cells, as plain data (see the module docstring).
    `formulas`: the formula ids that gate acceptance (None: every SPI and contract); `bins`:
    continuous conditions by attribute; `strict`: a rate (an MAE) must stay below its bound,
    else at or below it."""
    max_mae = max_mae or {}
    bins = bins or {}

    def within(value: float | None, bound: float) -> bool:
        return value is not None and (value < bound if strict else value <= bound)

    stats = {f.id: f for run in runs for f in run.result.formulas}
    gating = (
        formulas
        if formulas is not None
        else sorted(fid for fid, f in stats.items() if f.kind == "spi")
    )
    # cell -> formula -> per run (violated, judged, outside, no_data); cell -> runs, ticks
    #: per cell, per formula: per run's ticks (violated, judged, outside, no_data) and folders
    per_cell: dict[tuple, dict[str, dict[str, list[Any]]]] = {}
    cell_runs: dict[tuple, set[str]] = {}
    cell_ticks: dict[tuple, int] = {}
    truth: dict[tuple, set] = {}
    #: per cell, per signal: [sum of absolute errors, ticks]
    mae_sums: dict[tuple, dict[str, list[Any]]] = {}
    for run in runs:
        truth_meta = run.result.stream.meta.get("odd_truth")
        degraded = truth_meta.get("degraded") if isinstance(truth_meta, dict) else None
        signals = None
        for cond in run.result.conditions:
            cell = _cell_of(cond.attributes, by, bins)
            cell_runs.setdefault(cell, set()).add(run.folder)
            cell_ticks[cell] = cell_ticks.get(cell, 0) + cond.ticks
            if degraded is not None:
                truth.setdefault(cell, set()).add(bool(degraded))
            rows = per_cell.setdefault(cell, {})
            for fid, tally in cond.formulas.items():
                row = rows.setdefault(
                    fid, {"violated": [], "judged": [], "outside": [], "no_data": [], "runs": []}
                )
                if not row["runs"] or row["runs"][-1] != run.folder:  # else: the same run
                    row["runs"].append(run.folder)  # under this cell again (conditions came back)
                    for key in ("violated", "judged", "outside", "no_data"):
                        row[key].append(0)
                row["violated"][-1] += tally.violated
                row["judged"][-1] += tally.evaluated
                row["outside"][-1] += tally.outside_assumption
                row["no_data"][-1] += tally.no_data
            if max_mae:
                if signals is None:
                    assert load_signals is not None
                    signals = load_signals(run.folder)
                t, columns = signals
                sums = mae_sums.setdefault(cell, {})
                for name in max_mae:
                    total, count = _mae(cond.spans, t, columns[name])
                    acc = sums.setdefault(name, [0.0, 0])
                    acc[0] += total
                    acc[1] += count

    def order(cell: tuple) -> tuple:  # bins in their order, the rest by name
        return tuple(
            (0, f"{bins[n].labels().index(v):04d}")
            if n in bins and v in bins[n].labels()
            else (1, str(v))
            for n, v in zip(by, cell, strict=True)
        )

    cells = []
    for cell in sorted(per_cell, key=order):
        entry: dict = {
            "conditions": dict(zip(by, cell, strict=True)),
            "runs": len(cell_runs[cell]),
            "ticks": cell_ticks[cell],
            "formulas": {},
            "mae": {},
        }
        accepted = True
        reasons = []
        for fid, row in per_cell[cell].items():
            rate, lo, hi, method = cluster_rate(row["violated"], row["judged"])
            runs_judged = sum(1 for e in row["judged"] if e > 0)
            runs_violated = sum(1 for v in row["violated"] if v > 0)
            rlo, rhi = wilson(runs_violated, runs_judged)
            gate = fid in gating
            value = None if rate is None else (hi if criterion == "upper" else rate)
            ok = within(value, max_rate)
            spread = method != "runs" or hi > lo
            if gate and not ok:
                accepted = False
                reasons.append(fid if rate is not None else f"{fid} (never judged)")
            entry["formulas"][fid] = {
                "rate": rate,
                "low": lo,
                "high": hi,
                "interval": method,
                "interval_method": INTERVAL_METHODS[method]
                + (
                    ""
                    if spread
                    else "; every run had the same rate: "
                    "no spread to estimate, the "
                    "interval says nothing"
                ),
                "violated_ticks": sum(row["violated"]),
                "judged_ticks": sum(row["judged"]),
                "outside_assumption_ticks": sum(row["outside"]),
                "no_data_ticks": sum(row["no_data"]),
                "runs_judged": runs_judged,
                "runs_violated": runs_violated,
                "runs_violated_low": rlo,
                "runs_violated_high": rhi,
                "gating": gate,
                "within": ok,
            }
        for name, bound in max_mae.items():
            total, count = mae_sums.get(cell, {}).get(name, [0.0, 0])
            mae = total / count if count else None
            ok = within(mae, bound)
            entry["mae"][name] = {"mae": mae, "ticks": count, "bound": bound, "within": ok}
            if not ok:
                accepted = False
                reasons.append(f"MAE {name}")
        unreported = [name for name, value in zip(by, cell, strict=True) if value is None]
        if unreported:
            accepted = False  # a condition no run reported is not a domain anyone tested
            reasons.append(f"not reported: {', '.join(unreported)}")
        entry["accepted"] = accepted
        entry["rejected_by"] = reasons
        if cell in truth and len(truth[cell]) == 1:
            entry["degraded_truth"] = next(iter(truth[cell]))
        cells.append(entry)
    return {
        "format": "casewatch-odd",
        "version": 1,
        "by": by,
        "max_violation_rate": max_rate,
        "acceptance": "strict" if strict else "inclusive",
        "bins": {name: b.to_data() for name, b in bins.items()},
        "criterion": criterion,
        "max_mae": max_mae,
        "mae_note": "",
        "gating": gating,
        "runs": len(runs),
        "formulas": {
            fid: {
                "node_id": f.node_id,
                "text": f.node_text,
                "kind": f.kind,
                "contract": f.contract_use,
                "assumption": f.assumption,
                "source": f.source,
            }
            for fid, f in sorted(stats.items())
        },
        "cells": cells,
    }


def accepted_odd(report: dict, name: str = "accepted") -> OddSpec | None:
    """The accepted cells as an ODD specification: per attribute the accepted values, and the
    accepted cells as its combinations unless they are the whole product of those values (a
    domain need not be a product). None when no cell is accepted (an ODD accepts something)."""
    by = report["by"]
    accepted = [c for c in report["cells"] if c["accepted"]]
    if not accepted or not by or binned_domain_problem(report):
        return None
    attributes: dict[str, list] = {}
    for cell in accepted:
        for key in by:
            values = attributes.setdefault(key, [])
            if cell["conditions"][key] not in values:
                values.append(cell["conditions"][key])
    combos = [dict(c["conditions"]) for c in accepted]
    product = len(accepted) == math.prod(len(v) for v in attributes.values())
    out: dict = {k: sorted(v, key=str) for k, v in attributes.items()}
    for key, b in (report.get("bins") or {}).items():
        picked = sorted(b["labels"].index(v) for v in attributes[key])
        out[key] = OddRange(min=b["edges"][picked[0]], max=b["edges"][picked[-1] + 1])
    return OddSpec(name=name, attributes=out, combinations=[] if product else combos)


def binned_domain_problem(report: dict) -> str | None:
    """Why the accepted cells cannot be written as an ODD when conditions were binned (an ODD
    holds a binned condition as one interval, so its accepted bins must be adjacent, and the
    accepted cells a product), or None."""
    bins = report.get("bins") or {}
    accepted = [c for c in report["cells"] if c["accepted"]]
    if not bins or not accepted:
        return None
    for key, b in bins.items():
        values = {c["conditions"][key] for c in accepted}
        if not values <= set(b["labels"]):
            return f"accepted cells with {key} outside its bins"
        picked = sorted(b["labels"].index(v) for v in values)
        if picked != list(range(picked[0], picked[-1] + 1)):
            return f"the accepted {key} bins are not adjacent ({', '.join(sorted(values))})"
    sizes = [len({c["conditions"][k] for c in accepted}) for k in report["by"]]
    if len(accepted) != math.prod(sizes):
        return (
            "the accepted cells are no product of the binned values (an ODD's interval "
            "cannot say which combinations)"
        )
    return None
