"""The HTML audit report: one self-contained file (inline CSS and SVG, no script, no URL).

Jinja2 renders it with autoescaping on for every template, so node texts, stream metadata and
defect messages reach the page only as escaped text; geometry comes from `layout` and `plot` as
numbers. The file must open offline years later, so it references nothing outside itself.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import jinja2
import markupsafe

from casewatch.evaluator.result import STATUS_SEVERITY, RunResult, Series
from casewatch.reports.layout import LINE_HEIGHT, SKEW, Diagram, layout_case
from casewatch.reports.plot import PlotView, StripRect, plot_series, status_strip
from casewatch.reports.view import (
    INCIDENT_WINDOW,
    STATUS_LABELS,
    STATUS_MEANING,
    ReportView,
    build_view,
    fmt_number,
    fmt_ratio,
    fmt_time,
)

#: Episodes beyond this number show a link to their node's trace instead of repeating it, so a
#: run with thousands of episodes still renders a report of bounded size.
TRACE_LIMIT = 1000
STRIP_WIDTH = 1000
EPISODE_LINK_CAP = 300


@dataclass(frozen=True)
class PlotCard:
    formula_id: str
    node_id: str
    title: str
    note: str
    plot: PlotView


_CONTROL = re.compile(r"[\x00-\x08\x0b\x0c\x0e-\x1f\x7f]")


def _finalize(value: object) -> object:
    """Drop control characters (not allowed in HTML text) from every value the templates print."""
    if isinstance(value, str) and not isinstance(value, markupsafe.Markup):
        return _CONTROL.sub("", value)
    return value


def _environment() -> jinja2.Environment:
    env = jinja2.Environment(
        finalize=_finalize,
        loader=jinja2.PackageLoader("casewatch.reports", "templates"),
        autoescape=True,  # every template, whatever its extension
        undefined=jinja2.StrictUndefined,
        trim_blocks=False,
        lstrip_blocks=False,
    )
    env.globals.update(
        status_label=lambda s: STATUS_LABELS.get(s, s),
        fmt_time=fmt_time,
        fmt_ratio=fmt_ratio,
        fmt_rob=lambda v: "–" if v is None else f"{v:+.3f}",
        fmt_number=fmt_number,
    )
    return env


_ENV = _environment()


def subtitles(result: RunResult) -> dict[str, str]:
    """The second line of an SPI node in the diagram: its signal and threshold."""
    out: dict[str, str] = {}
    for formula in result.formulas:
        if formula.kind == "spi" and formula.signal and formula.threshold:
            out[formula.node_id] = f"{formula.signal} {formula.threshold}"
        elif formula.kind == "spi":
            out[formula.node_id] = "STL"
        else:
            out[formula.node_id] = "hazard"
    return out


def _plots(result: RunResult) -> list[PlotCard]:
    """One plot per formula: its signal series when recorded, else its robustness."""
    chosen: dict[str, Series] = {}
    for series in result.series:
        current = chosen.get(series.formula_id)
        if current is None or (current.quantity == "robustness" and series.quantity == "signal"):
            chosen[series.formula_id] = series
    span = (result.stream.t_start, result.stream.t_end)
    t_range = None
    if span[0] is not None and span[1] is not None:
        t_range = (span[0], span[1] + result.case.period)
    cards = []
    order = {f.id: i for i, f in enumerate(result.formulas)}
    for formula in sorted(result.formulas, key=lambda f: (f.kind != "spi", order[f.id])):
        shown = chosen.get(formula.id)
        if shown is None:
            continue
        episodes = [e for e in result.episodes if e.formula_id == formula.id]
        gaps = [g for g in result.data_gaps if g.formula_id == formula.id]
        labels = [
            (lab.start, lab.end)
            for lab in (result.ground_truth.labels if result.ground_truth else [])
            if lab.node_id == formula.node_id
        ]
        plot = plot_series(shown, episodes, gaps, result.case.period, t_range, labels)
        if shown.quantity == "signal":
            title = f"{shown.name} {formula.threshold or ''}".strip()
        else:
            title = f"robustness of {formula.id}"
        note = f"{len(episodes)} episodes · {len(gaps)} gaps"
        if labels:
            note += f" · {len(labels)} labelled (top strip)"
        if plot.buckets and plot.bucket > result.case.period * 1.5:
            note += f" · min–max per {plot.bucket:g} s"
        cards.append(PlotCard(formula.id, formula.node_id, title, note, plot))
    return cards


def _strips(view: ReportView, result: RunResult) -> dict[str, list[StripRect]]:
    t0 = result.stream.t_start or 0.0
    t1 = (result.stream.t_end if result.stream.t_end is not None else t0) + result.case.period
    return {
        n.id: status_strip(n.timeline, t0, t1, result.case.period, STRIP_WIDTH) for n in view.nodes
    }


@dataclass(frozen=True)
class ArbitrationRect:
    x: float
    w: float
    status: str  # the CSS class of its channel
    label: str


def _arbitration(result: RunResult) -> tuple[list[ArbitrationRect], dict[str, str]]:
    """The recommended channel over the run as a strip (one rectangle per pixel column at
    most, the channel covering most of a column wins it) and each channel's CSS class."""
    channels = sorted({iv.channel or "none" for iv in result.arbitration})
    css = {
        c: ("arb-none" if c == "none" else f"arb-{k % 4}")
        for k, c in enumerate([c for c in channels if c != "none"])
    }
    css.setdefault("none", "arb-none")
    t0 = result.stream.t_start or 0.0
    t1 = (result.stream.t_end if result.stream.t_end is not None else t0) + result.case.period
    if not result.arbitration or t1 <= t0:
        return [], css
    scale = STRIP_WIDTH / (t1 - t0)
    rects: list[ArbitrationRect] = []
    for iv in result.arbitration:
        name = iv.channel or "none"
        x = (iv.start - t0) * scale
        w = max((iv.end + result.case.period - iv.start) * scale, 0.5)
        if rects and rects[-1].status == css[name] and abs(rects[-1].x + rects[-1].w - x) < 0.5:
            last = rects[-1]
            rects[-1] = ArbitrationRect(last.x, x + w - last.x, last.status, last.label)
        else:
            rects.append(ArbitrationRect(round(x, 2), round(w, 2), css[name], name))
    return rects, css


def render_html(result: RunResult) -> str:
    """The complete HTML report of `result`."""
    view = build_view(result)
    diagram: Diagram = layout_case(result.case, subtitles(result))
    plots = _plots(result)
    strips = _strips(view, result)
    traces = {}
    for node in result.case.nodes:
        episode = next((e for e in result.episodes if e.node_id == node.id), None)
        traces[node.id] = episode.trace if episode is not None else []
    statuses = sorted(STATUS_SEVERITY, key=lambda s: -STATUS_SEVERITY[s])
    arbitration_strip, arbitration_class = _arbitration(result)
    template = _ENV.get_template("report.html.j2")
    return template.render(
        incident_window=f"{INCIDENT_WINDOW:g}",
        arbitration_strip=arbitration_strip,
        arbitration_class=arbitration_class,
        view=view,
        result=result,
        diagram=diagram,
        plots=plots,
        plot_ids={p.formula_id for p in plots},
        strips=strips,
        root_strip=strips.get(result.case.root_id, []),
        strip_width=STRIP_WIDTH,
        traces=traces,
        statuses=statuses,
        status_meaning=STATUS_MEANING,
        line_height=LINE_HEIGHT,
        skew=SKEW,
        trace_limit=TRACE_LIMIT,
        episode_link_cap=EPISODE_LINK_CAP,
    )
