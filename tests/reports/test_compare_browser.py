"""Headless Chromium opens the comparison page: no console errors, every marker drawn inside
its map, on the lane and on the track it belongs to, and the off-road marker on none."""

from __future__ import annotations

from pathlib import Path

import pytest

from casewatch.cli import main
from tests.casewatch.test_compare_cli import NET, four_runs  # noqa: F401 (a fixture)
from tools.screenshot import find_chromium, open_page

pytestmark = [
    pytest.mark.browser,
    pytest.mark.skipif(find_chromium() is None, reason="needs Chromium (Debian package chromium)"),
]


def test_compare_page_in_chromium(tmp_path: Path, four_runs: list[Path]) -> None:  # noqa: F811
    net = tmp_path / "straight.net.xml"
    net.write_text(NET)
    out = tmp_path / "out"
    assert main(["compare", *map(str, four_runs), "--net", str(net), "-o", str(out)]) == 0
    shot = tmp_path / "compare.png"
    with open_page(out / "compare.html", width=1200) as (page, errors):
        page.screenshot(path=str(shot), full_page=True)
        maps = page.evaluate(
            """() => Array.from(document.querySelectorAll('svg.map')).map(svg => {
                const box = svg.getBoundingClientRect();
                const lanes = Array.from(svg.querySelectorAll('polyline.lane'));
                const use = svg.querySelector('use');
                const laneSource = lanes.length ? lanes
                    : Array.from(document.querySelectorAll('#network polyline.lane'));
                return {
                    title: svg.getAttribute('aria-label'), usesNetwork: !!use,
                    lanes: laneSource.length,
                    markers: Array.from(svg.querySelectorAll('circle.marker')).map(c => {
                        const r = c.getBoundingClientRect();
                        const p = new DOMPoint(c.cx.baseVal.value, c.cy.baseVal.value);
                        const track = Array.from(svg.querySelectorAll('polyline.track'))
                            .some(t => t.isPointInStroke(p));
                        return {
                            inside: r.left >= box.left && r.right <= box.right
                                && r.top >= box.top && r.bottom <= box.bottom,
                            w: r.width, offRoad: c.classList.contains('off-road'),
                            onLane: laneSource.some(l => l.isPointInStroke(p)),
                            onTrack: track, title: c.querySelector('title').textContent,
                        };
                    }),
                };
            })"""
        )
        # where the second map (drawing its network through <use>) shows lane e_1 at 25 m
        lane_pixel = page.evaluate(
            """() => {
                const svg = document.querySelectorAll('svg.map')[1];
                const lane = document.querySelectorAll('#network polyline.lane')[1].points;
                const p = new DOMPoint(0.75 * lane[0].x + 0.25 * lane[1].x, lane[0].y)
                    .matrixTransform(svg.getScreenCTM());
                return [Math.round(p.x + window.scrollX), Math.round(p.y + window.scrollY)];
            }"""
        )
        charts = page.evaluate("() => document.querySelectorAll('svg.chart').length")
        scripts = page.evaluate("() => document.querySelectorAll('script').length")
    assert errors == []
    assert scripts == 0 and charts == 4  # penalty score, driving score, penalty and events
    assert [m["title"] for m in maps] == ["violation map of curve", "violation map of straight"]
    assert [m["usesNetwork"] for m in maps] == [False, True]  # drawn once, reused
    assert all(m["lanes"] == 2 for m in maps)
    markers = [mk for m in maps for mk in m["markers"]]
    assert len(markers) == 4  # one per hazard episode with a position
    assert all(mk["inside"] and mk["w"] > 5 for mk in markers)
    straight = {mk["title"].split(" · ")[0]: mk for mk in maps[1]["markers"]}
    assert straight["red_light"]["onLane"] and straight["red_light"]["onTrack"]
    assert not straight["red_light"]["offRoad"]
    collision = straight["collision"]  # 20 m beside the road: drawn there, ringed, listed
    assert collision["offRoad"] and not collision["onLane"] and not collision["onTrack"]
    assert "OFF ROAD: 20.0 m" in collision["title"]
    assert shot.stat().st_size > 10_000
    image = pytest.importorskip("PIL.Image")
    with image.open(shot) as png:
        assert png.convert("RGB").getpixel(tuple(lane_pixel)) == (201, 204, 209)  # lane grey
