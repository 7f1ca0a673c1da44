"""The ODD analysis as a self-contained HTML heatmap and as text (`casewatch odd`).

Reads only the plain values of `evaluator.odd_analysis`: rows are condition cells, columns the
contracts and SPIs, each cell coloured by its violation rate against the acceptance bound.
jinja2 with autoescaping, inline CSS, no script.
"""

from __future__ import annotations

import textwrap

from casewatch.reports.page import render_page


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
    return (
        ", ".join(f"{k}={value_text(v)}" for k, v in conditions.items())
        or "(no conditions reported)"
    )


def render_odd_html(report: dict) -> str:
    return render_page("odd.html.j2", {"pct": pct, "label": cell_label}, r=report, heat=heat)


def interval_text(f: dict) -> str:
    """A rate's interval with its method, never a zero-width interval the runs cannot give."""
    if f["interval"] == "runs" and f["high"] > f["low"]:
        return f"[{pct(f['low'])}, {pct(f['high'])}]"
    if f["interval"] == "ticks":
        return f"[{pct(f['low'])}, {pct(f['high'])}] ticks"
    if f["interval"] == "runs":
        return "no spread"
    return "nothing judged"


#: The terminal table's width: the cell lines wrap their formulas to stay within it.
WIDTH = 100


def _wrap(entries: list[str], indent: str) -> list[str]:
    lines: list[str] = []
    for entry in entries:
        if lines and len(lines[-1]) + 3 + len(entry) <= WIDTH:
            lines[-1] += "   " + entry
        else:
            lines.append(indent + entry)
    return lines


def render_odd_text(report: dict) -> list[str]:
    """The table printed on the terminal, within 100 columns: per cell its verdict and
    conditions, then each gating formula's rate, its interval (method named) and the runs
    violated with their Wilson upper bound over runs, and each MAE."""
    gating = report["gating"]
    which = "upper bound" if report["criterion"] == "upper" else "estimate"
    relation = "at or below" if report.get("acceptance") == "inclusive" else "below"
    lines = [
        f"{len(report['cells'])} cells over {', '.join(report['by']) or '(nothing)'}; "
        f"{report['runs']} runs",
        f"accepted: every gating formula's violation rate ({which}) {relation} "
        f"{pct(report['max_violation_rate'])}",
    ]
    for name, b in (report.get("bins") or {}).items():
        edges, labels = b["edges"], b["labels"]
        spans = [
            f"{'[' if k == 0 else '('}{edges[k]:g}, {edges[k + 1]:g}]" for k in range(len(labels))
        ]
        lines.append(
            f"{name} binned: "
            + ", ".join(
                span if span == label else f"{label} {span}"
                for span, label in zip(spans, labels, strict=True)
            )
        )
    if report.get("mae_note"):
        lines += textwrap.wrap(report["mae_note"], WIDTH, subsequent_indent="  ")
    lines += [
        "per formula: rate, 95 % interval over runs (no spread: every run had the same "
        "rate; ticks: one run,",
        "Wilson over its ticks), runs violated / judged (<= their Wilson 95 % upper bound)",
    ]
    for cell in report["cells"]:
        verdict = "ACCEPTED" if cell["accepted"] else "rejected"
        values = ", ".join(value_text(v) for v in cell["conditions"].values())
        lines.append(
            f"  {verdict} {values or cell_label(cell['conditions'])} "
            f"({cell['runs']} runs, {cell['ticks']} ticks)"
        )
        entries = [
            f"{fid} {pct(f['rate'])} {interval_text(f)}, {f['runs_violated']}/"
            f"{f['runs_judged']} (<= {pct(f['runs_violated_high'])})"
            for fid in gating
            if (f := cell["formulas"].get(fid)) is not None
        ]
        entries += [
            f"MAE {n} {m['mae']:.3g}" if m["mae"] is not None else f"MAE {n} n/a"
            for n, m in cell["mae"].items()
        ]
        lines += _wrap(entries, "      ")
    return lines
