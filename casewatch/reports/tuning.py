"""The tuning page: a precision-recall curve per rule with its operating point, and a table
of original, fitted and held-out scores (`casewatch tune` writes it as `tuning.html`).

Self-contained like the audit report (inline CSS and SVG, no script), rendered by jinja2 with
autoescaping; it reads only the plain values `evaluator.tuning.tune` returns.
"""

from __future__ import annotations

from casewatch.evaluator.score_text import pr_text
from casewatch.reports.page import render_page
from casewatch.reports.plot import PlotFrame

#: The precision-recall chart's box.
_PLOT = PlotFrame(width=300, height=240, left=42, top=10, inner_w=246, inner_h=196)


def _pr(row: dict | None) -> str:
    return "n/a (one log)" if row is None else pr_text(row, counts=True)


def _setting(point: dict, duration_kind: str | None) -> str:
    text = f"{point['threshold']:g}"
    if duration_kind == "for":
        text += f", for {point['duration']:g} s"
    elif duration_kind == "min_duration":
        text += f", min {point['duration']:g} s"
    return text


def _plot(result: dict) -> dict:
    g = _PLOT

    def at(point: dict) -> dict | None:
        if point["precision"] is None or point["recall"] is None:
            return None
        return {
            "x": round(g.x(point["recall"]), 2),
            "y": round(g.y(point["precision"]), 2),
            "title": f"{_setting(point, result['duration_kind'])}: P {point['precision']:.0%}, "
            f"R {point['recall']:.0%}",
        }

    points = [p for p in (at(c) for c in result["curve"]) if p is not None]
    ticks = [{"label": f"{v:.1f}", "x": g.x(v), "y": g.y(v)} for v in (0.0, 0.5, 1.0)]
    return {
        **g.__dict__,
        "points": points,
        "ticks": ticks,
        "original": at(result["original"]),
        "tuned": at(result["tuned"]),
        "hidden": len(result["curve"]) - len(points),
    }


def render_tuning(report: dict) -> str:
    """HTML of a tuning report (`casewatch tune`'s `tuning.json` value)."""
    rows = []
    for r in report["rules"]:
        rows.append(
            {
                "formula": r["formula"],
                "node_text": r.get("node_text", ""),
                "parameter": r["parameter"],
                "labels": r["labels"],
                "original_text": _setting(r["original"], r["duration_kind"]),
                "tuned_text": _setting(r["tuned"], r["duration_kind"])
                + ("" if r["reached"] else " (none reaches the precision asked)"),
                "original_pr": _pr(r["original"]),
                "tuned_pr": _pr(r["tuned"]),
                "heldout_pr": _pr(r["heldout"]),
                "plot": _plot(r),
            }
        )
    skipped: dict[str, list[str]] = {}
    for s in report["skipped"]:
        skipped.setdefault(s["reason"], []).append(s["formula"])
    return render_page(
        "tuning.html.j2",
        case_name=report["case"],
        logs=report["logs"],
        hours=report["hours"],
        labels=sum(r["labels"] for r in report["rules"]),
        objective=report["objective"],
        rows=rows,
        skipped=list(skipped.items()),
    )
