"""The run comparison as Markdown and as a self-contained HTML page (`casewatch compare`).

Reads only the plain values of `evaluator.compare` (and the road network of
`reports.roadmap`, when given). This module computes the charts' and maps' pixel coordinates;
the template draws them as inline SVG. The page is rendered by jinja2 with autoescaping,
inline CSS, no script and nothing fetched from the network.
"""

from __future__ import annotations

import math

import numpy as np
from markupsafe import Markup, escape

from casewatch.reports.page import render_page
from casewatch.reports.roadmap import MapTransform, RoadNetwork, fit_transform

#: Colours of the traffic rules (docs/traffic-rules.md); other rules take the palette in turn.
RULE_COLOURS = {
    "collision": "#b71c1c",
    "collision_victim": "#f06292",
    "red_light": "#e53935",
    "stop_sign": "#6a1b9a",
    "speeding_light": "#fb8c00",
    "speeding_heavy": "#e65100",
    "solid_line": "#1565c0",
    "double_solid": "#0d47a1",
    "broken_no_indicator": "#00838f",
    "no_headlights": "#5d4037",
    "no_fog_lights": "#827717",
}
PALETTE = [
    "#1f77b4",
    "#ff7f0e",
    "#2ca02c",
    "#d62728",
    "#9467bd",
    "#8c564b",
    "#e377c2",
    "#7f7f7f",
    "#bcbd22",
    "#17becf",
]
CHART_W, CHART_LEFT, CHART_RIGHT, ROW_H, CHART_TOP, CHART_BOTTOM = 880, 220, 70, 24, 8, 42
MARKER_R = 5.0
MAP_W = 1200.0  # pixels; the page scales the map down to its width


def rule_colours(rules: list[str]) -> dict[str, str]:
    others = iter(PALETTE * (1 + len(rules) // len(PALETTE)))
    return {r: RULE_COLOURS.get(r) or next(others) for r in rules}


def _nice_ticks(lo: float, hi: float) -> list[float]:
    """Round ticks covering lo..hi (and 0), in at most 6 steps."""
    lo, hi = min(lo, 0.0), max(hi, 0.0)
    if hi - lo <= 0:
        return [0.0, 1.0]
    step = 10 ** math.floor(math.log10((hi - lo) / 5))
    for mult in (1, 2, 2.5, 5, 10):
        if (math.ceil(hi / (step * mult) - 1e-9) - math.floor(lo / (step * mult) + 1e-9)) <= 6:
            step *= mult
            break
    first, last = math.floor(lo / step + 1e-9), math.ceil(hi / step - 1e-9)
    return [round(i * step, 10) for i in range(first, last + 1)]


def _fmt(v: float | None, digits: int = 3) -> str:
    return "n/a" if v is None else f"{v:.{digits}g}" if abs(v) >= 1000 else f"{v:.{digits}f}"


def bar_chart(
    title: str,
    x_title: str,
    labels: list[str],
    segments: list[list[dict] | None],
    whiskers: list[tuple[float, float] | None] | None = None,
    counts: bool = False,
) -> dict:
    """A horizontal bar chart: per label a stack of {value, colour, name} segments, the total
    written after the bar (n/a for a label without any), optional (min, max) whiskers; axis
    ticks from 0. `counts`: the values are whole numbers."""
    fmt = (lambda v: f"{v:g}") if counts else _fmt
    totals = [sum(s["value"] for s in row or []) for row in segments]
    spans = [w for w in whiskers or [] if w]
    ticks = _nice_ticks(
        min([*totals, *(w[0] for w in spans)], default=0.0),
        max([*totals, *(w[1] for w in spans)], default=0.0),
    )
    inner = CHART_W - CHART_LEFT - CHART_RIGHT
    scale = inner / (ticks[-1] - ticks[0])
    zero = CHART_LEFT - ticks[0] * scale  # a negative score's bar runs left of zero
    rows = []
    for i, (label, row, total) in enumerate(zip(labels, segments, totals, strict=True)):
        y = CHART_TOP + i * ROW_H
        x, parts = zero, []
        for s in row or []:
            w = s["value"] * scale
            parts.append(
                {
                    "x": round(min(x, x + w), 1),
                    "w": round(abs(w), 1),
                    "colour": s["colour"],
                    "title": f"{label}: {s['name']} {fmt(s['value'])}",
                }
            )
            x += w
        whisker = (whiskers or [None] * len(labels))[i]
        right = max(x, zero, zero + whisker[1] * scale if whisker else zero)
        rows.append(
            {
                "label": label,
                "y": y,
                "bar_y": y + 4,
                "bar_h": ROW_H - 8,
                "text_y": y + ROW_H / 2,
                "parts": parts,
                "value_x": round(right + 6, 1),
                "value": "n/a" if row is None else fmt(total),
                "whisker": None
                if whisker is None
                else {
                    "x1": round(zero + whisker[0] * scale, 1),
                    "x2": round(zero + whisker[1] * scale, 1),
                    "y": y + ROW_H / 2,
                },
            }
        )
    legend = list(
        dict.fromkeys(
            (s["name"], s["colour"])
            for row in segments
            for s in row or []
            if row is not None and (len(row) > 1 or s["name"] != "mean")
        )
    )
    height = CHART_TOP + len(labels) * ROW_H + CHART_BOTTOM
    axis_y = CHART_TOP + len(labels) * ROW_H
    return {
        "title": title,
        "x_title": x_title,
        "width": CHART_W,
        "height": height,
        "left": CHART_LEFT,
        "right": CHART_W - CHART_RIGHT,
        "axis_y": axis_y,
        "zero": round(zero, 1),
        "legend": sorted(legend),
        "ticks": [{"x": round(zero + t * scale, 1), "label": f"{t:g}"} for t in ticks],
        "rows": rows,
        "title_x": CHART_LEFT + inner / 2,
        "title_y": height - 8,
    }


def _charts(report: dict, colours: dict[str, str]) -> list[dict]:
    groups = report["groups"]
    labels = [g["label"] for g in groups]
    charts = []
    for key, title, axis in (
        (
            "penalty_score",
            "Penalty score per group",
            "penalty score (mean over runs; line: min to max)",
        ),
        (
            "driving_score",
            "CARLA driving score per group",
            "driving score (mean over runs; line: min to max)",
        ),
    ):
        if any(g[key] for g in groups):
            charts.append(
                bar_chart(
                    title,
                    axis,
                    labels,
                    [
                        [{"value": g[key]["mean"], "colour": "#1f4e8c", "name": "mean"}]
                        if g[key]
                        else None
                        for g in groups
                    ],
                    [(g[key]["min"], g[key]["max"]) if g[key] else None for g in groups],
                )
            )
    for key, title, axis in (
        ("penalty", "Penalty per rule per group", "penalty (sum over runs)"),
        ("events", "Rule events per group", "events (sum over runs)"),
    ):
        if any((g["per_rule"][r][key] or 0) > 0 for g in groups for r in report["rules"]):
            charts.append(
                bar_chart(
                    title,
                    axis,
                    labels,
                    [
                        [
                            {"value": g["per_rule"][r][key] or 0.0, "colour": colours[r], "name": r}
                            for r in report["rules"]
                            if (g["per_rule"][r][key] or 0) > 0
                        ]
                        if key == "events" or g["scored_runs"]
                        else None  # unscored: no penalty
                        for g in groups
                    ],
                    counts=key == "events",
                )
            )
    return charts


def _points(xy: np.ndarray) -> str:
    """An SVG `points` list at 0.1 px, without repeated points."""
    xy = np.round(np.asarray(xy, dtype=float), 1)
    if len(xy) > 1:
        keep = np.r_[True, np.any(np.diff(xy, axis=0) != 0, axis=1)]
        xy = xy[keep]
    return " ".join(f"{x:g},{y:g}" for x, y in xy)


def _network_view(network: RoadNetwork, tf: MapTransform) -> dict:
    return {
        "lanes": [
            {"points": _points(tf.apply(ln.centre)), "w": round(ln.width * tf.scale, 2)}
            for ln in network.lanes
        ],
        "other": [
            {"points": _points(tf.apply(ln.centre)), "w": round(ln.width * tf.scale, 2)}
            for ln in network.other_lanes
        ],
        "references": [_points(tf.apply(r)) for r in network.reference_lines],
        "edges": [_points(tf.apply(e)) for e in network.edges],
    }


def _bounds(parts: list[np.ndarray]) -> tuple[float, float, float, float] | None:
    parts = [p for p in parts if len(p)]
    if not parts:
        return None
    xy = np.concatenate(parts)
    return (
        float(xy[:, 0].min()),
        float(xy[:, 1].min()),
        float(xy[:, 0].max()),
        float(xy[:, 1].max()),
    )


def _union(a: tuple | None, b: tuple | None) -> tuple | None:
    if a is None or b is None:
        return a or b
    return (min(a[0], b[0]), min(a[1], b[1]), max(a[2], b[2]), max(a[3], b[3]))


def map_views(
    report: dict, tracks: dict[str, list], network: RoadNetwork | None, colours: dict[str, str]
) -> list[dict]:
    """One map per scenario (a run without a scenario gets its own): the network underneath,
    each run's track coloured by agent, each positioned hazard episode as a marker."""
    runs = report["runs"]
    agents = sorted({r["agent"] for r in runs})
    agent_colour = {a: PALETTE[i % len(PALETTE)] for i, a in enumerate(agents)}
    maps: dict[str, list[dict]] = {}
    for r in runs:
        maps.setdefault(r["scenario"] if r["scenario"] != "(none)" else r["name"], []).append(r)
    xy = {
        name: np.asarray([p[1:] for p in t], dtype=float).reshape(-1, 2)
        for name, t in tracks.items()
    }
    markers = report["markers"]
    shared = None
    if network is not None:  # one transform for every map: the network is drawn once
        shared = _union(
            network.bounds(),
            _bounds([*xy.values(), np.array([(m["x"], m["y"]) for m in markers]).reshape(-1, 2)]),
        )
    views = []
    for index, (key, members) in enumerate(sorted(maps.items())):
        names = {r["name"] for r in members}
        own = [(i, m) for i, m in enumerate(markers) if m["run"] in names]
        bounds = shared or _bounds(
            [*(xy[n] for n in names), np.array([(m["x"], m["y"]) for _, m in own]).reshape(-1, 2)]
        )
        if bounds is None:
            continue
        tf = fit_transform(bounds, width=MAP_W)
        drawn = []
        for i, m in own:
            ((cx, cy),) = tf.apply(np.array([(m["x"], m["y"])]))
            note = ""
            if m["off_road"]:
                note += f"; OFF ROAD: {m['network_distance']:.1f} m from the nearest lane centre"
            if m["off_track"]:
                note += f"; {m['track_distance']:.1f} m from its run's track"
            drawn.append(
                {
                    "index": i,
                    "cx": round(float(cx), 1),
                    "cy": round(float(cy), 1),
                    "r": MARKER_R,
                    "colour": colours.get(m["rule"], "#444"),
                    "off": bool(m["off_road"]),
                    "title": f"{m['rule']} · agent {m['agent']} · run {m['run']} · "
                    f"t {m['start']:.1f}-{m['end']:.1f} s · ({m['x']:.1f}, {m['y']:.1f}) m" + note,
                }
            )
        views.append(
            {
                "id": f"map-{index + 1}",
                "key": key,
                "width": tf.width,
                "height": round(tf.height, 1),
                "scale": tf.scale,
                "network": (
                    _network_view(network, tf) if network is not None and index == 0 else None
                ),
                "use_network": network is not None and index > 0,
                "tracks": [
                    {
                        "run": r["name"],
                        "agent": r["agent"],
                        "colour": agent_colour[r["agent"]],
                        "points": _points(tf.apply(xy[r["name"]])),
                    }
                    for r in members
                    if len(xy.get(r["name"], []))
                ],
                "markers": drawn,
                "agents": [(a, agent_colour[a]) for a in sorted({r["agent"] for r in members})],
                "rules": [(r, colours[r]) for r in sorted({m["rule"] for _, m in own})],
                "scale_bar": _scale_bar(tf),
            }
        )
    return views


def _scale_bar(tf: MapTransform) -> dict:
    """A round length about a sixth of the map wide, bottom left."""
    target = tf.width / 6 / tf.scale
    metres = 10 ** math.floor(math.log10(target))
    for mult in (5, 2, 1):
        if metres * mult <= target:
            metres *= mult
            break
    return {
        "x": 16,
        "y": round(tf.height - 10, 1),
        "w": round(metres * tf.scale, 1),
        "label": f"{metres:g} m",
    }


def compare_view(report: dict, tracks: dict[str, list], network: RoadNetwork | None = None) -> dict:
    colours = rule_colours(sorted({*report["rules"], *(m["rule"] for m in report["markers"])}))
    return {
        "r": report,
        "charts": _charts(report, colours),
        "maps": map_views(report, tracks, network, colours),
        "colours": colours,
    }


def stat_text(s: dict | None) -> str:
    if s is None:
        return "n/a"
    if s["min"] == s["max"]:
        return f"{s['mean']:.3f}"
    return f"{s['mean']:.3f} ({s['min']:.3f}-{s['max']:.3f})"


def _tally(t: dict) -> str:
    """`events / penalty` of one rule in one group, e.g. `2 / 60` (empty when neither)."""
    if not t["events"] and not t["penalty"]:
        return ""
    return f"{t['events']}" + ("" if t["penalty"] is None else f" / {t['penalty']:g}")


def breakable(name: str) -> Markup:
    """A rule name that may wrap after its underscores (`broken_no_indicator` is one word to a
    browser; fourteen of them in a header row made the page scroll sideways at 1280 px)."""
    return Markup("_<wbr>").join(escape(part) for part in str(name).split("_"))


def check_lines(report: dict) -> list[str]:
    """The marker checks in words (terminal, Markdown and page say the same)."""
    c = report["checks"]
    lines = [
        f"markers: {c['markers']} of {c['hazard_events']} hazard events have a position"
        + (f" ({c['without_position']} without)" if c["without_position"] else "")
    ]
    t = c["track"]
    lines.append(
        f"off-track markers: {t['off']} (farther than {t['tolerance_m']:g} m from "
        f"their run's track; {t['checked']} checked"
        + (f", {t['unchecked']} without a track" if t["unchecked"] else "")
        + ")"
    )
    n = c["network"]
    if n is None:
        lines.append("off-road markers: not checked (no --net or --xodr)")
    else:
        lines.append(
            f"off-road markers: {n['off_road']} (farther than half a lane width + "
            f"{n['margin_m']:g} m from every lane of {n['path']}; {n['checked']} "
            "checked)"
        )
        if n["hint"]:
            lines.append(f"hint: {n['hint']}")
    return lines


def _marker_line(m: dict) -> str:
    return (
        f"{m['rule']} in run {m['run']} (agent {m['agent']}) at {m['start']:.1f} s, "
        f"({m['x']:.1f}, {m['y']:.1f}) m"
    )


def render_compare_md(report: dict) -> str:
    by = report["by"]
    lines = [
        f"# Run comparison by {', '.join(by)}",
        "",
        f"{len(report['runs'])} runs in {len(report['groups'])} groups.",
    ]
    for key, names in report["without_key"].items():
        if names:
            lines.append(
                f"{len(names)} run(s) without `{key}` in the stream meta, grouped under "
                f"`(none)`: {', '.join(names)}."
            )
    lines += [
        "",
        "## Groups",
        "",
        "| " + " | ".join(by) + " | runs | hours | penalty score | driving score | "
        "route completion | hazard events |",
        "|" + " --- |" * (len(by) + 6),
    ]
    for g in report["groups"]:
        lines.append(
            "| " + " | ".join(g["key"][k] for k in by) + f" | {g['runs']} | "
            f"{g['hours']:.3f} | {stat_text(g['penalty_score'])} | "
            f"{stat_text(g['driving_score'])} | {stat_text(g['route_completion'])} | "
            f"{g['hazard_events']} |"
        )
    t = report["table"]
    lines += [
        "",
        f"## Penalty score, {t['rows_key']} x {t['cols_key'] or 'all'}",
        "",
        f"| {t['rows_key']} | " + " | ".join(t["cols"]) + " |",
        "|" + " --- |" * (len(t["cols"]) + 1),
    ]
    for row, cells in zip(t["rows"], t["cells"], strict=True):
        lines.append(f"| {row} | " + " | ".join(stat_text(c) if c else "" for c in cells) + " |")
    if report["rules"]:
        lines += [
            "",
            "## Rules (events / penalty)",
            "",
            "| group | " + " | ".join(report["rules"]) + " |",
            "|" + " --- |" * (len(report["rules"]) + 1),
        ]
        for g in report["groups"]:
            lines.append(
                f"| {g['label']} | "
                + " | ".join(_tally(g["per_rule"][r]) for r in report["rules"])
                + " |"
            )
    lines += ["", "## Violation map checks", ""] + [f"- {x}" for x in check_lines(report)]
    c = report["checks"]
    for title, key in (("Off-road", "network"), ("Off-track", "track")):
        part = c[key]
        listed = (part or {}).get("off_road_markers" if key == "network" else "off_markers")
        if listed:
            lines += ["", f"{title} markers:", ""]
            lines += [f"- {_marker_line(report['markers'][i])}" for i in listed]
    return "\n".join(lines) + "\n"


def render_compare_html(
    report: dict, tracks: dict[str, list], network: RoadNetwork | None = None
) -> str:
    """The page; `tracks` is {run name: [[t, x, y], ...]} (the runs' `track`)."""
    return render_page(
        "compare.html.j2",
        {"stat": stat_text, "tally": _tally, "marker": _marker_line, "breakable": breakable},
        v=compare_view(report, tracks, network),
        checks=check_lines(report),
    )
