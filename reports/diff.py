"""The run diff as Markdown and as a self-contained HTML page (`casewatch diff`).

Reads only the plain values of `evaluator.diff`; the page is rendered by jinja2 with
autoescaping, inline CSS, no script.
"""

from __future__ import annotations

from reports.page import render_page


def _span(s: dict) -> str:
    return f"{s['start']:.1f}-{s['end']:.1f} s (worst {s['worst_robustness']:+.3f})"


def _rate(v: float | None) -> str:
    return "n/a" if v is None else f"{v:.1f}"


def render_diff_md(report: dict) -> str:
    """Markdown: a summary line per log, then the nodes with differences."""
    lines = [f"# Run diff: {report['a']} -> {report['b']}", "",
             f"Policy `--fail-on {report['fail_on']}`: {report['regressions']} regression(s) "
             f"(new episodes it counts).", ""]  # fmt: skip
    for name in report["only_a"]:
        lines.append(f"- `{name}`: only in A")
    for name in report["only_b"]:
        lines.append(f"- `{name}`: only in B")
    for d in report["logs"]:
        lines += ["", f"## {d['log']}", "",
                  f"Verdict {d['verdict_a']} -> {d['verdict_b']}; episodes per hour "
                  f"{_rate(d['per_hour_a'])} -> {_rate(d['per_hour_b'])}"
                  + ("" if d["same_stream"] else " (the two runs read different streams)"), ""]
        rows = [r for r in d["nodes"] if r["new"] or r["fixed"] or r["changed"]]
        if not rows:
            lines.append("No episode differs.")
            continue
        lines += ["| node | kind | A | B | new | fixed | changed |",
                  "| --- | --- | --- | --- | --- | --- | --- |"]  # fmt: skip
        for r in rows:
            lines.append(f"| {r['formula']} | {r['kind']} | {r['a']} | {r['b']} | "
                         f"{len(r['new'])} | {len(r['fixed'])} | {len(r['changed'])} |")
        for r in rows:
            for s in r["new"]:
                lines.append(f"- new {r['formula']}: {_span(s)}")
            for s in r["fixed"]:
                lines.append(f"- fixed {r['formula']}: {_span(s)}")
            for c in r["changed"]:
                lines.append(f"- changed {r['formula']}: {_span(c['a'])} -> {_span(c['b'])}")
    return "\n".join(lines) + "\n"


def render_diff_html(report: dict) -> str:
    return render_page("diff.html.j2", {"span": _span, "rate": _rate}, r=report)
