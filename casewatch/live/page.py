"""The live page: one self-contained HTML file (inline style and script, no network).

The GSN diagram is the report's own (`reports.layout` and the report's diagram macro), drawn
once when the run starts; the page's script recolours its nodes and fills the panels from the
server's events. Nothing is loaded from anywhere but the page's own server.
"""

from __future__ import annotations

import jinja2

from casewatch.evaluator.result import CaseInfo
from casewatch.reports.layout import LINE_HEIGHT, SKEW, layout_case
from casewatch.reports.view import STATUS_LABELS
from casewatch.spec.model import CompiledSpec


def _environment() -> jinja2.Environment:
    env = jinja2.Environment(
        loader=jinja2.ChoiceLoader(
            [
                jinja2.PackageLoader("casewatch.live", "templates"),
                jinja2.PackageLoader("casewatch.reports", "templates"),  # _macros, report.css
            ]
        ),
        autoescape=True,
        undefined=jinja2.StrictUndefined,
    )
    env.globals.update(status_label=lambda s: STATUS_LABELS.get(s, s))
    return env


def diagram_subtitles(spec: CompiledSpec) -> dict[str, str]:
    """An SPI node's second line, as in the report: its signal and threshold, or STL."""
    out: dict[str, str] = {}
    for f in spec.formulas:
        if f.kind == "spi":
            out[f.node_id] = f"{f.signal} {f.threshold}" if f.signal and f.threshold else "STL"
        else:
            out[f.node_id] = "hazard"
    return out


def render_live_page(case: CaseInfo, spec: CompiledSpec, stream_name: str) -> str:
    """The page for a run of `case` on `stream_name`, every node 'no data' until the first
    tick arrives."""
    diagram = layout_case(case, diagram_subtitles(spec))
    return (
        _environment()
        .get_template("live.html.j2")
        .render(
            case=case,
            stream_name=stream_name,
            diagram=diagram,
            status_of={},
            line_height=LINE_HEIGHT,
            skew=SKEW,
            labels=STATUS_LABELS,
        )
    )
