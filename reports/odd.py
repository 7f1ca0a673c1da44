"""The ODD analysis as a self-contained HTML heatmap and as text (`casewatch odd`).

Reads only the plain values of `evaluator.odd_analysis`: rows are condition cells, columns the
contracts and SPIs, each cell coloured by its violation rate against the acceptance bound.
jinja2 with autoescaping, inline CSS, no script.
"""

from __future__ import annotations

from reports.page import render_page


def pct(v: float | None) -> str:
    return "n/a" if v is None else f"{100 * v:.1f} %"


def _mix(a: tuple[int, int, int], b: tuple[int, int, int], x: float) -> str:
    return "rgb({},{},{})".format(*(round(p + (q - p) * x) for p, q in zip(a, b, strict=True)))


GREEN, AMBER, RED = (46, 125, 50), (176, 118, 20), (183, 28, 28)


def heat(rate: float | None, bound: float) -> str:
    """Background of a heatmap cell: grey without data; green to amber up to the acceptance
    bound, amber to red beyond it (red at twice the bound and above)."""
    if rate is None:
        return "#e7eaee"
    if bound <= 0:
        return _mix(GREEN, RED, 1.0 if rate > 0 else 0.0)
    if rate <= bound:
        return _mix(GREEN, AMBER, rate / bound)
    return _mix(AMBER, RED, min((rate - bound) / bound, 1.0))


def value_text(value: object) -> str:
    """A condition value as written: `3` for the lane count 3.0, `rain`, `true`."""
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, float):
        return f"{value:g}"
    return "(not reported)" if value is None else str(value)


def cell_label(conditions: dict) -> str:
    return ", ".join(f"{k}={value_text(v)}" for k, v in conditions.items()) or \
        "(no conditions reported)"  # fmt: skip


def render_odd_html(report: dict) -> str:
    return render_page("odd.html.j2", {"pct": pct, "label": cell_label}, r=report, heat=heat)


def interval_text(f: dict) -> str:
    """A rate's interval with its method, never a zero-width interval the runs cannot give."""
    if f["interval"] == "runs" and f["high"] > f["low"]:
        return f"[{pct(f['low'])}, {pct(f['high'])}] runs"
    if f["interval"] == "ticks":
        return f"[{pct(f['low'])}, {pct(f['high'])}] ticks"
    if f["interval"] == "runs":
        return "no spread"
    return "nothing judged"


def render_odd_text(report: dict) -> list[str]:
    """The table printed on the terminal: a line per cell, the gating formulas' rates with
    their intervals (method named) and the runs violated (Wilson upper bound over runs)."""
    gating = report["gating"]
    which = "upper bound" if report["criterion"] == "upper" else "estimate"
    relation = "<=" if report.get("acceptance") == "inclusive" else "<"
    binned = "".join(f"; {k} binned {', '.join(b['labels'])}"
                     for k, b in (report.get("bins") or {}).items())  # fmt: skip
    lines = [f"{len(report['cells'])} cells over {', '.join(report['by']) or '(nothing)'}; "
             f"{report['runs']} runs; accepted: violation rate ({which}) {relation} "
             f"{pct(report['max_violation_rate'])}{binned}"]  # fmt: skip
    if report.get("mae_note"):
        lines.append(f"  {report['mae_note']}")
    for cell in report["cells"]:
        rates = "  ".join(
            f"{fid} {pct(f['rate'])} {interval_text(f)}, {f['runs_violated']}/{f['runs_judged']} "
            f"runs (<= {pct(f['runs_violated_high'])})"
            for fid in gating if (f := cell["formulas"].get(fid)) is not None
        )
        maes = "  ".join(f"MAE {n} {m['mae']:.3g}" if m["mae"] is not None else f"MAE {n} n/a"
                         for n, m in cell["mae"].items())  # fmt: skip
        verdict = "ACCEPTED" if cell["accepted"] else "rejected"
        lines.append(f"  {verdict:8} {cell_label(cell['conditions'])}  ({cell['runs']} runs, "
                     f"{cell['ticks']} ticks)  {rates}{'  ' + maes if maes else ''}")
    return lines
