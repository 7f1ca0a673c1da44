"""The Markdown report: the headline, tables and traces, for pull requests and tickets.

Every piece of user text is escaped so it cannot break a table (`|`, newlines) or turn into
markup (`<script>`, `*`, `[`...). Long lists are capped with a count of what was left out, since
a pull-request comment has a size limit; the HTML report and result.json hold everything.
"""

from __future__ import annotations

import re

from casewatch.evaluator.result import RunResult, TraceStep
from casewatch.reports.view import STATUS_LABELS, build_view, fmt_ratio, fmt_time

#: Episodes listed with their traces; the rest are counted.
MD_EPISODE_CAP = 100

_CONTROL = re.compile(r"[\x00-\x08\x0b\x0c\x0e-\x1f\x7f]")
_SPECIAL = re.compile(r"([\\`*_{}\[\]<>()#+!|~])")


def md_escape(text: object) -> str:
    """Plain text that renders literally inside a Markdown paragraph or table cell."""
    flat = " ".join(_CONTROL.sub("", str(text)).split())
    return _SPECIAL.sub(r"\\\1", flat).replace("&", "&amp;")


def md_code(text: object) -> str:
    """Inline code; backticks inside are replaced since they cannot be escaped there."""
    flat = " ".join(_CONTROL.sub("", str(text)).split()).replace("`", "'").replace("|", "¦")
    return f"`{flat}`" if flat else ""


def _table(header: list[str], rows: list[list[str]], align: list[str]) -> list[str]:
    lines = ["| " + " | ".join(header) + " |"]
    lines.append("| " + " | ".join("---:" if a == "r" else "---" for a in align) + " |")
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return lines


def _trace(paths: list[list[TraceStep]]) -> list[str]:
    return [
        "  - " + " → ".join(f"**{md_escape(s.id)}** {md_escape(s.text)}" for s in path)
        for path in paths
    ]


def _contracts(result: RunResult) -> list[str]:
    """The contracts (docs/contracts.md): judged only where their assumption held."""
    rows = [f for f in result.formulas if f.assumption is not None]
    if not rows:
        return []
    return [
        "",
        "## Contracts",
        "",
        "Judged only where the assumption holds; elsewhere *outside assumption*, neither a "
        "pass nor a violation.",
        "",
        *_table(
            [
                "node",
                "library",
                "assume",
                "guarantee",
                "violated / judged",
                "outside assumption",
                "no data",
            ],
            [
                [
                    f"**{md_escape(f.node_id)}** {md_escape(f.node_text)}",
                    md_code(f.contract_use) if f.contract_use else "",
                    md_code(f.assumption),
                    md_code(f.source),
                    f"{f.ticks_violated:,} / {f.ticks_evaluated:,}",
                    f"{f.ticks_outside_assumption:,}",
                    f"{f.ticks_no_data:,}",
                ]
                for f in rows
            ],
            ["l", "l", "l", "l", "r", "r", "r"],
        ),
    ]


def _odd(result: RunResult) -> list[str]:
    """How the run stood against each ODD (docs/odd.md)."""
    if not result.odd:
        return []

    def by(counts: dict[str, int]) -> str:
        return ", ".join(f"{md_code(k)} {v:,}" for k, v in counts.items())

    return [
        "",
        "## Operational design domain",
        "",
        "Outside the ODD the argument claims nothing: what would be satisfied there is "
        "*outside ODD*; violations stay violations.",
        "",
        *_table(
            ["context", "ODD", "inside", "outside", "not reported", "outside by", "not reported"],
            [
                [
                    md_escape(o.node_id),
                    md_escape(o.name),
                    f"{o.inside:,}",
                    f"{o.outside:,}",
                    f"{o.unknown:,}",
                    by(o.outside_by),
                    by(o.unknown_by),
                ]
                for o in result.odd
            ],
            ["l", "l", "r", "r", "r", "l", "l"],
        ),
    ]


def _scores(result: RunResult) -> list[str]:
    """The traffic-rule scores (docs/traffic-rules.md)."""
    sc = result.scores
    if not sc:
        return []
    out = ["", "## Traffic rules: scores", ""]
    p, c = sc.get("penalty"), sc.get("carla")
    if p is not None:
        out.append(
            f"- penalty score (eq. 6.1) **{p['score']:.2f}**, made of: "
            f"{md_escape(p.get('made_of', ''))}"
        )
    if c is not None:
        out.append(
            f"- CARLA Leaderboard driving score **{c['driving_score']:.2f}**, made of: "
            f"{md_escape(c.get('made_of', ''))}"
        )
    if sc.get("reason"):
        out.append(f"No {'penalty ' if c else ''}score: {md_escape(sc.get('reason'))}.")
    rules = (p or sc).get("per_rule") or {}
    if rules:
        out += [
            "",
            *_table(
                ["rule", "events", "while speeding", "penalty"],
                [
                    [md_escape(k), str(r["events"]), str(r["while_speeding"]), f"{r['penalty']:g}"]
                    for k, r in rules.items()
                ],
                ["l", "r", "r", "r"],
            ),
        ]
    return out


def render_markdown(result: RunResult) -> str:
    """The complete Markdown report of `result`."""
    view = build_view(result)
    h = view.headline
    out: list[str] = [f"# casewatch audit report: {md_escape(h.module)}", ""]
    if not h.complete:
        out += ["> **Incomplete run**: the run stopped before the end of the stream.", ""]
    out += [
        f"**Top claim {md_escape(h.root_id)}: {md_escape(h.verdict_label.upper())}** — "
        f"{md_escape(h.root_text)}",
        "",
    ]
    if h.worst_note:  # the colour rule (docs/reports.md, "Node colours") hid a worse tick
        out += [h.worst_note[0].upper() + h.worst_note[1:] + ".", ""]  # our own words
    if h.root_shares:
        shares = ", ".join(f"{label} {share}" for _, label, share in h.root_shares)
        out += [f"Share of the run: {shares}.", ""]
    out += _table(
        ["frames", "duration", "SPI episodes", "hazard events", "data gaps", "stream defects"],
        [
            [
                f"{h.frames:,}",
                h.duration,
                str(h.episodes_spi),
                str(h.episodes_hazard),
                str(h.data_gaps),
                str(h.defects),
            ]
        ],
        ["r"] * 6,
    )
    out += [
        "",
        f"- case: {md_code(h.case_path)} digest {md_code(h.case_digest)}",
        f"- stream: {md_code(h.stream_path)} digest {md_code(h.stream_digest)}",
        f"- created {md_escape(h.created)} by casewatch {md_escape(h.casewatch_version)}",
        "",
        "## Safety Performance Indicators",
        "",
    ]
    if view.spi_rows:
        out += _table(
            [
                "node",
                "signal",
                "threshold",
                "ticks violated",
                "time violated",
                "episodes",
                "worst robustness",
                "data gaps",
                "status",
            ],
            [
                [
                    f"**{md_escape(r.node_id)}** {md_escape(r.node_text)}",
                    md_code(r.signal),
                    md_code(r.threshold),
                    f"{r.ticks_violated:,} / {r.ticks_evaluated:,}",
                    r.share_violated,
                    str(r.episodes),
                    f"{r.worst_robustness} at {r.t_worst}",
                    r.gap_share,
                    STATUS_LABELS.get(r.status, r.status),
                ]
                for r in view.spi_rows
            ],
            ["l", "l", "l", "r", "r", "r", "r", "r", "l"],
        )
    else:
        out.append("The case binds no SPI.")
    out += _contracts(result)
    out += _odd(result)
    out += _scores(result)
    out += ["", "## Hazards", ""]
    if view.hazard_rows:
        labelled = view.labels_path is not None
        header = ["node", "condition", "events", "time active", "data gaps"]
        if labelled:
            header += ["TP", "FP", "FN", "precision", "recall"]
        rows = []
        for r in view.hazard_rows:
            row = [
                f"**{md_escape(r.node_id)}** {md_escape(r.node_text)}",
                md_code(r.condition),
                str(r.events),
                r.share_active,
                r.gap_share,
            ]
            if labelled:
                s = r.score
                row += [
                    str(s.true_positives) if s else "–",
                    str(s.false_positives) if s else "–",
                    str(s.false_negatives) if s else "–",
                    r.precision,
                    r.recall,
                ]
            rows.append(row)
        if labelled and view.overall_score is not None:
            o = view.overall_score
            rows.append(
                [
                    "**all hazards**",
                    "",
                    "",
                    "",
                    "",
                    str(o.true_positives),
                    str(o.false_positives),
                    str(o.false_negatives),
                    fmt_ratio(o.precision),
                    fmt_ratio(o.recall),
                ]
            )
        out += _table(header, rows, ["l", "l"] + ["r"] * (len(header) - 2))
        if not labelled:
            out += ["", "No ground-truth labels were given."]
    else:
        out.append("The case declares no hazard.")
    out += ["", f"## Episodes ({len(view.episodes)})", ""]
    if not view.episodes:
        out.append("No SPI violation and no hazard event over the run.")
    for e in view.episodes[:MD_EPISODE_CAP]:
        kind = "SPI violation" if e.kind == "spi" else "hazard event"
        out.append(
            f"- **#{e.number} {md_escape(e.node_id)}** ({kind}) {e.start} to {e.end} "
            f"({e.ticks} ticks), worst robustness {e.worst_robustness} at {e.t_worst}; trace:"
        )
        out += _trace(e.trace)
    if len(view.episodes) > MD_EPISODE_CAP:
        out += ["", f"… and {len(view.episodes) - MD_EPISODE_CAP} more episodes (see report.html)."]
    if result.near_misses:
        out += [
            "",
            f"## Near misses ({len(result.near_misses)})",
            "",
            "Formulas with a warning margin (`warn:`) that held, but by less than the "
            "margin: reported, never violations.",
            "",
        ]
        out += _table(
            ["node", "from", "to", "ticks", "least robustness", "margin"],
            [
                [
                    md_escape(n.node_id),
                    fmt_time(n.start),
                    fmt_time(n.end),
                    str(n.ticks),
                    f"{n.least_robustness:.4g}",
                    f"{n.warn:g}",
                ]
                for n in result.near_misses[:MD_EPISODE_CAP]
            ],
            ["l", "r", "r", "r", "r", "r"],
        )
    out += ["", f"## Data gaps ({len(result.data_gaps)})", ""]
    if view.gaps.shown:
        out += _table(
            ["node", "from", "to", "ticks", "missing inputs"],
            [
                [
                    md_escape(g.node_id),
                    fmt_time(g.start),
                    fmt_time(g.end),
                    str(g.ticks),
                    md_code(", ".join(g.missing)),
                ]
                for g in view.gaps.shown
            ],
            ["l", "r", "r", "r", "l"],
        )
        if view.gaps.omitted:
            out += ["", f"… and {view.gaps.omitted} more data gaps (all in result.json)."]
    else:
        out.append("No data gaps.")
    out += ["", f"## Stream defects ({h.defects})", ""]
    if view.defects.shown:
        out += _table(
            ["line", "kind", "message"],
            [[str(d.line), md_code(d.kind), md_escape(d.message)] for d in view.defects.shown],
            ["r", "l", "l"],
        )
        if view.defects.omitted:
            out += ["", f"… and {view.defects.omitted} more defects."]
    else:
        out.append("No stream defects.")
    if h.topic_gaps:
        out += [
            "",
            "Bag topics missing or stale: "
            + "; ".join(
                f"{md_code(t)} {n} ticks" + (f", {late} late" if late else "")
                for t, n, late in h.topic_gaps
            ),
        ]
    if h.meta:
        out += ["", "Stream meta: " + "; ".join(f"{md_code(k)} = {md_code(v)}" for k, v in h.meta)]
    out.append("")
    return "\n".join(out)
