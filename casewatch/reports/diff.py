"""The run diff as Markdown and as a self-contained HTML page (`casewatch diff`).

Reads only the plain values of `evaluator.diff`; the page is rendered by jinja2 with
autoescaping, inline CSS, no script. Regressions (new episodes, lost detections) are red,
improvements (fixed false alarms, new detections) green, and what cannot be judged without
labels (gone, moved, changed) is neutral.
"""

from __future__ import annotations

from casewatch.evaluator.diff import (
    CHANGE_KINDS,
    CHANGE_LABELS,
    IMPROVEMENT_KINDS,
    REGRESSION_KINDS,
)
from casewatch.reports.page import render_page

#: The columns of a node row, in order; a log without labels has only the first three.
COLUMNS = (*CHANGE_KINDS, "changed")
UNLABELLED_COLUMNS = ("new", "gone", "changed")
#: What each change means, for the page's legend and the Markdown report.
MEANING = {
    "new": "in B only; with labels: it matches no label (a new false alarm). A regression",
    "lost": "a labelled hazard A found and B no longer finds. A regression",
    "new_detection": "a labelled hazard B finds and A did not",
    "fixed": "in A only, and it matched no label: a false alarm gone",
    "gone": "in A only, without labels to say whether it was a false alarm or a hazard",
    "moved": "in one run only, but the other run finds its label with another episode",
    "changed": "paired by overlap, but moved by more than a period or with another worst "
    "robustness",
}


def tone(kind: str) -> str:
    """The CSS class of a change: `bad`, `good` or `neutral`."""
    return "bad" if kind in REGRESSION_KINDS else "good" if kind in IMPROVEMENT_KINDS else "neutral"


def _span(s: dict) -> str:
    text = f"{s['start']:.1f}-{s['end']:.1f} s (worst {s['worst_robustness']:+.3f})"
    if "label" in s:
        text += f", label {s['label']['start']:.1f}-{s['label']['end']:.1f} s"
    if "run" in s:
        text += f", in {s['run'].upper()} only"
    return text


def columns_of(d: dict) -> tuple[str, ...]:
    """The change columns of a log's table: the label-aware ones only when it has labels."""
    return COLUMNS if d.get("labelled") else UNLABELLED_COLUMNS


def _rate(v: float | None) -> str:
    return "n/a" if v is None else f"{v:.1f}"


def _labels_line(d: dict) -> str:
    if d.get("labelled"):
        return f"hazards judged against the labels {d.get('labels', '')}"
    return (
        f"no labels ({d.get('labels') or 'not given'}): episodes in A only are 'gone', not 'fixed'"
    )


def render_diff_md(report: dict) -> str:
    """Markdown: a summary line per log, then the nodes with differences."""
    lines = [
        f"# Run diff: {report['a']} -> {report['b']}",
        "",
        f"Policy `--fail-on {report['fail_on']}`: {report['regressions']} regression(s) "
        f"(new episodes and lost detections it counts).",
        "",
    ]
    for name in report["only_a"]:
        lines.append(f"- `{name}`: only in A")
    for name in report["only_b"]:
        lines.append(f"- `{name}`: only in B")
    for d in report["logs"]:
        lines += [
            "",
            f"## {d['log']}",
            "",
            f"Verdict {d['verdict_a']} -> {d['verdict_b']}; episodes per hour "
            f"{_rate(d['per_hour_a'])} -> {_rate(d['per_hour_b'])}"
            + ("" if d["same_stream"] else " (the two runs read different streams)")
            + f"; {_labels_line(d)}.",
            "",
        ]
        rows = [r for r in d["nodes"] if any(r[k] for k in COLUMNS)]
        if not rows:
            lines.append("No episode differs.")
            continue
        columns = columns_of(d)
        lines += [
            "| node | kind | A | B | " + " | ".join(CHANGE_LABELS[k] for k in columns) + " |",
            "| --- " * (4 + len(columns)) + "|",
        ]
        for r in rows:
            lines.append(
                f"| {r['formula']} | {r['kind']} | {r['a']} | {r['b']} | "
                + " | ".join(str(len(r[k])) for k in columns)
                + " |"
            )
        for r in rows:
            for kind in CHANGE_KINDS:
                for s in r[kind]:
                    lines.append(f"- {CHANGE_LABELS[kind]} {r['formula']}: {_span(s)}")
            for c in r["changed"]:
                lines.append(f"- changed {r['formula']}: {_span(c['a'])} -> {_span(c['b'])}")
    lines += [
        "",
        "Meaning: " + "; ".join(f"**{CHANGE_LABELS[k]}**: {MEANING[k]}" for k in COLUMNS) + ".",
    ]
    return "\n".join(lines) + "\n"


def render_diff_html(report: dict) -> str:
    return render_page(
        "diff.html.j2",
        {"span": _span, "rate": _rate, "tone": tone},
        r=report,
        columns=COLUMNS,
        columns_of=columns_of,
        kinds=CHANGE_KINDS,
        names=CHANGE_LABELS,
        meaning=MEANING,
        labels_line=_labels_line,
    )
