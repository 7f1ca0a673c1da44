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
`criterion="upper"`) stays at or below `max_rate`, and every `max_mae` bound holds; the
accepted cells are the domain. Plain values in, plain values out.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass

import numpy as np

from evaluator.result import RunResult
from safety_case.model import OddSpec

#: Two-sided 95 % quantiles of Student's t for 1-30 degrees of freedom (beyond: 1.96).
_T95 = (12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179,
        2.160, 2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064,
        2.060, 2.056, 2.052, 2.048, 2.045, 2.042)  # fmt: skip
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


def _cell_of(attributes: dict, by: list[str]) -> tuple:
    return tuple(attributes.get(name) for name in by)


def _mae(spans: list[list[float]], t: np.ndarray, column: np.ndarray) -> tuple[float, int]:
    """(sum of |values|, count) at the ticks inside `spans` where the value is finite."""
    inside = np.zeros(len(t), dtype=bool)
    for a, b in spans:
        inside |= (t >= a - 1e-9) & (t <= b + 1e-9)
    picked = column[inside]
    picked = picked[np.isfinite(picked)]
    return float(np.abs(picked).sum()), int(picked.size)


def analyse(runs: list[RunInput], by: list[str], formulas: list[str] | None, max_rate: float,
            criterion: str = "estimate", max_mae: dict[str, float] | None = None,
            load_signals: SignalLoader | None = None) -> dict:  # fmt: skip
    """The per-cell table and the accepted cells, as plain data (see the module docstring).
    `formulas`: the formula ids that gate acceptance (None: every SPI and contract)."""
    max_mae = max_mae or {}
    stats = {f.id: f for run in runs for f in run.result.formulas}
    gating = formulas if formulas is not None else sorted(
        fid for fid, f in stats.items() if f.kind == "spi")  # fmt: skip
    # cell -> formula -> per run (violated, judged, outside, no_data); cell -> runs, ticks
    per_cell: dict[tuple, dict[str, dict[str, list[int]]]] = {}
    cell_runs: dict[tuple, set[str]] = {}
    cell_ticks: dict[tuple, int] = {}
    truth: dict[tuple, set] = {}
    mae_sums: dict[tuple, dict[str, list[float]]] = {}
    for run in runs:
        truth_meta = run.result.stream.meta.get("odd_truth")
        degraded = truth_meta.get("degraded") if isinstance(truth_meta, dict) else None
        signals = None
        for cond in run.result.conditions:
            cell = _cell_of(cond.attributes, by)
            cell_runs.setdefault(cell, set()).add(run.folder)
            cell_ticks[cell] = cell_ticks.get(cell, 0) + cond.ticks
            if degraded is not None:
                truth.setdefault(cell, set()).add(bool(degraded))
            rows = per_cell.setdefault(cell, {})
            for fid, tally in cond.formulas.items():
                row = rows.setdefault(fid, {"violated": [], "judged": [], "outside": [],
                                            "no_data": [], "runs": []})  # fmt: skip
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
    cells = []
    for cell in sorted(per_cell, key=lambda c: tuple(str(v) for v in c)):
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
            ok = value is not None and value <= max_rate
            if gate and not ok:
                accepted = False
                reasons.append(fid if rate is not None else f"{fid} (never judged)")
            entry["formulas"][fid] = {
                "rate": rate, "low": lo, "high": hi, "interval": method,
                "violated_ticks": sum(row["violated"]), "judged_ticks": sum(row["judged"]),
                "outside_assumption_ticks": sum(row["outside"]),
                "no_data_ticks": sum(row["no_data"]),
                "runs_judged": runs_judged, "runs_violated": runs_violated,
                "runs_violated_low": rlo, "runs_violated_high": rhi,
                "gating": gate, "within": ok,
            }  # fmt: skip
        for name, bound in max_mae.items():
            total, count = mae_sums.get(cell, {}).get(name, [0.0, 0])
            mae = total / count if count else None
            within = mae is not None and mae <= bound
            entry["mae"][name] = {"mae": mae, "ticks": count, "bound": bound, "within": within}
            if not within:
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
        "format": "casewatch-odd", "version": 1, "by": by, "max_violation_rate": max_rate,
        "criterion": criterion, "max_mae": max_mae, "gating": gating, "runs": len(runs),
        "formulas": {fid: {"node_id": f.node_id, "text": f.node_text, "kind": f.kind,
                           "contract": f.contract_use, "assumption": f.assumption,
                           "source": f.source}
                     for fid, f in sorted(stats.items())},
        "cells": cells,
    }  # fmt: skip


def accepted_odd(report: dict, name: str = "accepted") -> OddSpec | None:
    """The accepted cells as an ODD specification: per attribute the accepted values, and the
    accepted cells as its combinations unless they are the whole product of those values (a
    domain need not be a product). None when no cell is accepted (an ODD accepts something)."""
    by = report["by"]
    accepted = [c for c in report["cells"] if c["accepted"]]
    if not accepted or not by:
        return None
    attributes: dict[str, list] = {}
    for cell in accepted:
        for key in by:
            values = attributes.setdefault(key, [])
            if cell["conditions"][key] not in values:
                values.append(cell["conditions"][key])
    combos = [dict(c["conditions"]) for c in accepted]
    product = len(accepted) == math.prod(len(v) for v in attributes.values())
    return OddSpec(name=name, attributes={k: sorted(v, key=str) for k, v in attributes.items()},
                   combinations=[] if product else combos)  # fmt: skip
