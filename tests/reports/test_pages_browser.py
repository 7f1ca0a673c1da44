"""Headless Chromium opens every standalone page (fleet, diff, tuning, odd, compare): the
stylesheet applies (the body font is the report's, not the browser's serif default), no CSS
arrives HTML-escaped, there are no console errors and nothing scrolls sideways at 1280 px."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from casewatch.cli import main
from tests.evaluator.streams import SMALL_CASE, frame
from tools.screenshot import find_chromium, open_page

pytestmark = [
    pytest.mark.browser,
    pytest.mark.skipif(find_chromium() is None, reason="needs Chromium (Debian package chromium)"),
]

TEMPLATES = Path(__file__).resolve().parents[2] / "casewatch" / "reports" / "templates"
CSS = (TEMPLATES / "report.css").read_text()


def families(value: str) -> list[str]:
    """`Inter, "Segoe UI", sans-serif` -> ["Inter", "Segoe UI", "sans-serif"]."""
    return [name.strip().strip('"') for name in value.split(",")]


#: the families of `body { font-family: ... }` and `code { ... }` in report.css
BODY_FONT = families(re.search(r"body \{[^}]*?font-family: ([^;]+);", CSS).group(1))
CODE_FONT = families(re.search(r"code, \.mono \{ font-family: ([^;]+);", CSS).group(1))
PAGES = (
    "fleet/fleet.html",
    "diff/diff.html",
    "tune/tuning.html",
    "odd/odd.html",
    "compare/compare.html",
)


@pytest.fixture(scope="module")
def pages(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two small labelled logs under two weathers, judged, then every page written (4 s)."""
    root = tmp_path_factory.mktemp("pages")
    logs = root / "logs"
    logs.mkdir()
    for name in ("clear", "rain"):
        meta = {"odd": {"environment": {"weather": name}}, "agent": name, "scenario": "s"}
        header = {
            "header": {
                "format": "casewatch-frames",
                "version": 1,
                "period": 0.1,
                "channels": ["lav", "tfuse"],
                "meta": meta,
            }
        }
        lines = [json.dumps(header)] + [json.dumps(frame(i)) for i in range(100)]
        (logs / f"{name}.jsonl").write_text("\n".join(lines) + "\n")
        (logs / f"{name}.labels.jsonl").write_text('{"hazard": "CSn1", "start": 1, "end": 2}\n')
    case = root / "case.yaml"
    case.write_text(SMALL_CASE.replace('"speed > 20"', '"speed > 5"'))
    fleet = str(root / "fleet")
    assert (
        main(
            [
                "run",
                str(case),
                str(logs),
                "--labels",
                "auto",
                "--save-signals",
                "-o",
                fleet,
                "--quiet",
            ]
        )
        == 1
    )
    assert main(["report", fleet]) == 0
    assert main(["diff", fleet, fleet, "-o", str(root / "diff")]) == 0
    assert main(["tune", str(case), fleet, "-o", str(root / "tune")]) == 0
    assert main(["odd", fleet, "--by", "environment.weather", "-o", str(root / "odd")]) in (0, 1)
    assert main(["compare", fleet, "--by", "agent,scenario", "-o", str(root / "compare")]) == 0
    return root


@pytest.mark.parametrize("page_path", PAGES)
def test_every_page_is_styled_and_fits_1280_px(pages: Path, page_path: str) -> None:
    html = pages / page_path
    style = html.read_text().split("<style>", 1)[1].split("</style>", 1)[0]
    assert "&#34;" not in style and "&quot;" not in style and "&gt;" not in style
    with open_page(html, width=1280) as (page, errors):
        seen = page.evaluate(
            """() => ({
                body: getComputedStyle(document.body).fontFamily,
                code: document.querySelector('code')
                    ? getComputedStyle(document.querySelector('code')).fontFamily : null,
                h1: getComputedStyle(document.querySelector('h1')).fontSize,
                scroll: document.documentElement.scrollWidth,
                width: window.innerWidth,
                scripts: document.querySelectorAll('script').length,
            })"""
        )
    assert errors == []
    assert BODY_FONT[0] == "Inter" and families(seen["body"]) == BODY_FONT, seen["body"]
    if seen["code"] is not None:
        assert families(seen["code"]) == CODE_FONT, seen["code"]
    assert seen["h1"] == "23.25px", seen["h1"]  # 1.55rem of html { font-size: 15px }, not 32 px
    assert seen["scroll"] <= seen["width"], f"{page_path} scrolls sideways at 1280 px"
    assert seen["scripts"] == 0


def test_a_compare_page_of_many_rules_fits_1280_px(tmp_path: Path) -> None:
    """Twelve groups by fourteen rules with long names (the bundled rule drives): the rules
    table wraps its headers after underscores instead of widening the page to 1615 px."""
    from tests.casewatch.test_compare_cli import STRAIGHT, scores, write_run

    rules = [
        "broken_no_indicator",
        "collision",
        "collision_victim",
        "double_solid",
        "neither_light",
        "no_fog_lights",
        "no_headlights",
        "red_light",
        "solid_line",
        "speeding_heavy",
        "speeding_light",
        "stop_sign",
        "wrong_way_driving",
        "unsafe_lane_change",
    ]
    runs = []
    for k, (agent, scenario) in enumerate(
        (a, s)
        for a in ("careful", "hurried", "sloppy")
        for s in ("night-fog", "rear-end", "stop-and-merge", "urban-lights")
    ):
        per_rule = {rule: (1 + (k + i) % 3, 250.0 / (1 + i)) for i, rule in enumerate(rules)}
        runs.append(
            write_run(
                tmp_path / "runs" / f"r{k}",
                {"agent": agent, "scenario": scenario},
                60.0,
                [],
                STRAIGHT,
                scores(50.0, 30.0, per_rule),
            )
        )
    out = tmp_path / "compare"
    assert main(["compare", *map(str, runs), "--by", "agent,scenario", "-o", str(out)]) == 0
    with open_page(out / "compare.html", width=1280) as (page, errors):
        seen = page.evaluate(
            """() => ({scroll: document.documentElement.scrollWidth, width: innerWidth,
                       headers: document.querySelectorAll('table.rules th').length,
                       table: document.querySelector('table.rules').getBoundingClientRect().right,
                       swatch: document.querySelector('table.rules .sw.rule')
                           .getBoundingClientRect().width})"""
        )
    assert errors == []
    assert seen["headers"] == len(rules) + 1
    assert seen["scroll"] <= seen["width"] and seen["table"] <= seen["width"], seen
    assert seen["swatch"] >= 8  # each rule's colour is shown beside its name
