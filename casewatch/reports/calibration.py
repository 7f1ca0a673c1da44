"""The calibration page (`casewatch calibrate` writes it as `calibration.html`): per SPI, the
trade-off its sweep offers, with the chosen and the original point, and a table of what was
chosen and why.

With fault labels an SPI's plot is false alarms an hour against the share of its faults
detected, one line per `for:` (the threshold runs along each line): the curve an engineer
reads to see what a quieter SPI costs in detection. Without them it is false alarms an hour
against the threshold. Self-contained like the audit report (inline CSS and SVG, no script); it
reads only the plain values of `calibration.json`.
"""

from __future__ import annotations

from casewatch.reports.page import render_page
from casewatch.reports.plot import PlotFrame

#: One colour per `for:` window, in sweep order.
PALETTE = ("#1f4e8c", "#2e7d32", "#b7860b", "#d35400", "#7b5ea7", "#0e7490", "#c62828")


#: Each SPI's chart box.
_FRAME = PlotFrame(width=340, height=250, left=48, top=12, inner_w=276, inner_h=196)


def _setting(point: dict, op: str) -> str:
    return f"{op} {point['threshold']:g}, for {point['for']:g} s"


def _rate(point: dict) -> str:
    if point["per_hour"] is None:
        return "n/a"
    return f"{point['per_hour']:.1f}/h (95 % bound {point['per_hour_upper']:.1f}/h)"


def _detection(point: dict, faults: int) -> str:
    return "no faults of its families" if not faults else f"{point['detected']} of {faults}"


def _plot(row: dict, budget: float) -> dict | None:
    """The SVG geometry of one SPI's curve: polylines per `for:`, the budget line, the chosen
    point and the original."""
    g = _FRAME
    curve = [p for p in row["curve"] if p["per_hour"] is not None]
    if not curve:
        return None
    tradeoff = row["faults"] > 0
    # the rate axis ends a little past what matters: the budget and the two marked points
    cap = max(3 * budget, row["original"]["per_hour"] or 0.0, row["chosen"]["per_hour"] or 0.0, 1.0)
    thresholds = [p["threshold"] for p in curve]
    lo, hi = min(thresholds), max(thresholds)
    span = (hi - lo) or 1.0

    def xy(p: dict) -> tuple[float, float] | None:
        if p["per_hour"] > cap + 1e-9:
            return None
        if tradeoff:
            x, y = p["per_hour"] / cap, p["detection"]
        else:
            x, y = (p["threshold"] - lo) / span, p["per_hour"] / cap
        return round(g.x(x), 2), round(g.y(y), 2)

    lines, hidden = [], 0
    for k, d in enumerate(sorted({p["for"] for p in curve})):
        points = sorted((p for p in curve if p["for"] == d), key=lambda p: p["threshold"])
        at = [xy(p) for p in points]
        hidden += sum(a is None for a in at)
        text = " ".join(f"{x},{y}" for x, y in (a for a in at if a is not None))
        lines.append({"for": f"{d:g} s", "points": text, "colour": PALETTE[k % len(PALETTE)]})

    def mark(p: dict, what: str) -> dict | None:
        at = xy(p)
        if at is None:
            return None
        detail = _rate(p) + (f", detected {p['detected']} of {row['faults']}" if tradeoff else "")
        return {"x": at[0], "y": at[1], "title": f"{what}: {_setting(p, row['op'])}: {detail}"}

    budget_at = g.x(budget / cap) if tradeoff else g.y(budget / cap)
    if tradeoff:
        x_label, y_label = "false alarms an hour", "faults detected"
        x_ticks = [(f"{v * cap:.3g}", g.x(v)) for v in (0.0, 0.5, 1.0)]
        y_ticks = [(f"{v:.0%}", g.y(v)) for v in (0.0, 0.5, 1.0)]
    else:
        x_label, y_label = f"threshold ({row['parameter']})", "false alarms an hour"
        x_ticks = [(f"{lo + v * span:.3g}", g.x(v)) for v in (0.0, 0.5, 1.0)]
        y_ticks = [(f"{v * cap:.3g}", g.y(v)) for v in (0.0, 0.5, 1.0)]
    return {
        **g.__dict__,
        "lines": lines,
        "hidden": hidden,
        "cap": f"{cap:.3g}",
        "tradeoff": tradeoff,
        "budget_at": round(budget_at, 2),
        "x_label": x_label,
        "y_label": y_label,
        "x_ticks": x_ticks,
        "y_ticks": y_ticks,
        "chosen": mark(row["chosen"], "chosen"),
        "original": mark(row["original"], "original"),
    }


def render_calibration(report: dict) -> str:
    """HTML of a calibration report (`casewatch calibrate`'s `calibration.json` value)."""
    rows = []
    for r in report["spis"]:
        same = (r["original"]["threshold"], r["original"]["for"]) == (
            r["chosen"]["threshold"],
            r["chosen"]["for"],
        )
        rows.append(
            {
                "formula": r["formula"],
                "parameter": r["parameter"],
                "hours": f"{r['hours']:.2f}",
                "original": _setting(r["original"], r["op"]),
                "original_rate": _rate(r["original"]),
                "chosen": "(the original)" if same else _setting(r["chosen"], r["op"]),
                "chosen_rate": _rate(r["chosen"]),
                "status": r["status"],
                "reason": r["reason"],
                "over": r["original_over_budget"],
                "detection": _detection(r["chosen"], r["faults"]),
                "plot": _plot(r, report["per_hour"]),
            }
        )
    return render_page(
        "calibration.html.j2",
        case_name=report["case"],
        logs=report["logs"],
        hours=report["hours"],
        budget=report["per_hour"],
        min_hours=report["min_hours"],
        margin=report["margin"],
        faults=report["faults"],
        tighten=report["tighten"],
        confidence=report["confidence"],
        rows=rows,
    )
