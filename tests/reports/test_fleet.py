"""`casewatch report FLEET_DIR`: the fleet page, from summary.json, in Chromium too."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from casewatch.cli import main
from tools.screenshot import find_chromium, open_page

REPO = Path(__file__).resolve().parents[2]
DATA = REPO / "examples" / "data"


@pytest.fixture(scope="module")
def fleet(tmp_path_factory) -> Path:
    logs = tmp_path_factory.mktemp("logs")
    for name in ("highway-tailgating", "urban-realstack"):
        for suffix in (".jsonl.gz", ".labels.jsonl"):
            shutil.copy(DATA / f"{name}{suffix}", logs / f"{name}{suffix}")
    out = tmp_path_factory.mktemp("fleet")
    assert (
        main(
            [
                "run",
                str(REPO / "examples" / "reference-case.yaml"),
                str(logs),
                "--labels",
                "auto",
                "--format",
                "html",
                "--quiet",
                "-o",
                str(out),
            ]
        )
        == 1
    )
    assert main(["report", str(out)]) == 0
    return out


def test_fleet_page_numbers_come_from_the_summary(fleet):
    summary = json.loads((fleet / "summary.json").read_text())
    html = (fleet / "fleet.html").read_text()
    assert "<script" not in html
    assert f"{summary['logs']} logs" in html
    hazards = {f["node_id"]: f for f in summary["formulas"] if f["kind"] == "hazard"}
    csn2 = hazards["CSn2"]
    assert f'<td class="left">CSn2</td><td>{csn2["episodes"]}</td>' in html
    assert html.index(">Sn2<") < html.index(">Sn10<")  # natural order
    # every log links its own report, relative to the fleet folder
    for log in summary["per_log"]:
        name = Path(log["out_dir"]).name
        assert f'href="{name}/report.html"' in html


def test_a_damaged_summary_is_refused(tmp_path, capsys):
    (tmp_path / "summary.json").write_text("[1, 2]")
    assert main(["report", str(tmp_path)]) == 2
    assert "not a casewatch fleet summary" in capsys.readouterr().err


@pytest.mark.browser
@pytest.mark.skipif(find_chromium() is None, reason="needs Chromium (Debian package chromium)")
def test_fleet_page_in_chromium(fleet):
    with open_page(fleet / "fleet.html", width=1300) as (page, errors):
        links = page.evaluate(
            "() => Array.from(document.querySelectorAll('a')).map(a => a.getAttribute('href'))"
        )
        tables = page.evaluate("() => document.querySelectorAll('table.fleet').length")
    assert errors == [] and tables == 4
    assert links and all((fleet / link).is_file() for link in links)
