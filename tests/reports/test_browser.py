"""Headless Chromium opens the HTML report: no console errors, all nodes drawn, no overlap."""

from __future__ import annotations

import itertools
from pathlib import Path

import pytest

from casewatch.evaluator.result import RunResult
from casewatch.reports.render import render_reports
from tools.screenshot import find_chromium, open_page

pytestmark = [
    pytest.mark.browser,
    pytest.mark.skipif(find_chromium() is None, reason="needs Chromium (Debian package chromium)"),
]


def test_report_in_chromium(real_run_result: RunResult, tmp_path: Path) -> None:
    """The reference case on a real bundled drive with violations."""
    reference_result = real_run_result
    assert reference_result.episodes, "the run must have violations"
    html = render_reports(reference_result, tmp_path, ("html",))["html"]
    shot = tmp_path / "report.png"
    with open_page(html, width=1600) as (page, errors):
        page.screenshot(path=str(shot), full_page=True)
        boxes = page.evaluate(
            """() => Array.from(document.querySelectorAll('svg.gsn g.gsn-node')).map(g => {
                   const r = g.getBoundingClientRect();
                   return {id: g.dataset.node, x: r.x, y: r.y, w: r.width, h: r.height};
               })"""
        )
        missing = page.evaluate(
            "(n) => Array.from({length: n}, (_, i) => 'episode-' + (i + 1))"
            ".filter(id => !document.getElementById(id))",
            len(reference_result.episodes),
        )
        scripts = page.evaluate("() => document.querySelectorAll('script').length")
        # the triage parts: TP/FP marks drawn, the arbitration strip as wide as its cell,
        # labelled intervals on the hazard plots, incident cards holding their members
        triage = page.evaluate(
            """() => ({
                marks: Array.from(document.querySelectorAll('span.mark'))
                    .filter(m => m.getBoundingClientRect().width > 5).map(m => m.textContent),
                strip: document.querySelector('svg.strip.arbitration')
                    .getBoundingClientRect().width,
                labels: document.querySelectorAll('rect.label-span').length,
                incidents: Array.from(document.querySelectorAll('.episode.incident'))
                    .map(i => i.querySelectorAll('li[id^=episode-]').length),
            })"""
        )
    assert errors == []
    assert scripts == 0
    events = reference_result.ground_truth.marks
    assert sorted(triage["marks"][2:]) == sorted(m.match for m in events)  # 2: the legend
    assert triage["strip"] > 400 and triage["labels"] >= 1
    assert all(n >= 2 for n in triage["incidents"])
    assert shot.stat().st_size > 10_000
    assert sorted(b["id"] for b in boxes) == sorted(n.id for n in reference_result.case.nodes)
    assert missing == []
    assert all(b["w"] > 10 and b["h"] > 10 for b in boxes)  # drawn, not collapsed
    for a, b in itertools.combinations(boxes, 2):
        overlap_x = min(a["x"] + a["w"], b["x"] + b["w"]) - max(a["x"], b["x"])
        overlap_y = min(a["y"] + a["h"], b["y"] + b["h"]) - max(a["y"], b["y"])
        assert overlap_x <= 0.5 or overlap_y <= 0.5, f"{a['id']} overlaps {b['id']}"


def test_report_is_legible_at_1280_px(real_run_result: RunResult, tmp_path: Path) -> None:
    """Every diagram text is drawn at 11 px or more (the reference case's diagram is 2280 px
    wide: fitted to the window it was 6 px), and the page itself never scrolls sideways."""
    html = render_reports(real_run_result, tmp_path, ("html",))["html"]
    with open_page(html, width=1280) as (page, errors):
        seen = page.evaluate(
            """() => {
                const svg = document.querySelector('svg.gsn');
                const scale = svg.getBoundingClientRect().width / svg.viewBox.baseVal.width;
                const sizes = Array.from(svg.querySelectorAll('text'))
                    .map(t => parseFloat(getComputedStyle(t).fontSize) * scale);
                const wrap = document.querySelector('.diagram-wrap');
                const frame = wrap.getBoundingClientRect();
                const root = document.getElementById('diagram-G1').getBoundingClientRect();
                return {smallest: Math.min(...sizes), texts: sizes.length,
                        rootInView: root.left >= frame.left && root.right <= frame.right,
                        page: document.documentElement.scrollWidth, width: window.innerWidth,
                        wrap: wrap.scrollWidth > wrap.clientWidth,
                        clipped: document.querySelectorAll('svg.plot text.clipped').length};
            }"""
        )
    assert errors == []
    assert seen["texts"] > 50 and round(seen["smallest"], 1) >= 11.0, seen  # 10.9999: subpixel
    assert seen["page"] <= seen["width"]  # the diagram scrolls inside its frame, not the page
    assert seen["wrap"]  # ... which it does: it is wider than the window
    assert seen["rootInView"], seen  # it opens on the root goal (scroll-initial-target)
    assert seen["clipped"] >= 1  # CSn2 and CSn3 saturate at 59 s of headway: clipped, said so
