"""`casewatch odd` end to end on part of the bundled ODD grid, and its refusals."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
import yaml

from casewatch.cli import main
from casewatch.safety_case.odd import parse_odd

REPO = Path(__file__).resolve().parents[2]
GRID = REPO / "examples" / "data" / "odd-grid"
CASE = REPO / "examples" / "odd" / "contracts-case.yaml"
#: two runs of four cells: two degraded (heavy fog by day, medium rain at night), two not
DRIVES = [
    f"odd-{cell}-r{k}"
    for cell in ("cloudy-light-day", "rain-light-day", "fog-heavy-day", "rain-medium-night")
    for k in (0, 1)
]
#: the study's intensity bins
BINS = ["--bins", "intensity=0,30,70,100:light,medium,heavy"]


@pytest.fixture(scope="module")
def judged(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("odd")
    logs = root / "logs"
    logs.mkdir()
    for name in DRIVES:
        shutil.copy(GRID / f"{name}.jsonl.gz", logs / f"{name}.jsonl.gz")
    code = main(
        [
            "run",
            str(CASE),
            str(logs),
            "--jobs",
            "2",
            "--format",
            "none",
            "--quiet",
            "--save-signals",
            "-o",
            str(root / "runs"),
        ]
    )
    assert code in (0, 1)
    return root / "runs"


def test_the_degraded_cells_are_rejected_and_the_rest_is_the_domain(judged, tmp_path, capsys):
    out = tmp_path / "odd"
    code = main(
        [
            "odd",
            str(judged),
            "-o",
            str(out),
            "--max-mae",
            "lead_gap__camera-gt_lead_gap=3",
            *BINS,
            "--by",
            "environment.weather,environment.intensity,environment.light",
        ]
    )
    printed = capsys.readouterr().out
    assert code == 0
    report = json.loads((out / "odd.json").read_text())
    assert report["by"] == ["environment.weather", "environment.intensity", "environment.light"]
    cells = {tuple(c["conditions"].values()): c for c in report["cells"]}
    assert set(cells) == {
        ("cloudy", "light", "day"),
        ("rain", "light", "day"),
        ("fog", "heavy", "day"),
        ("rain", "medium", "night"),
    }
    assert {k for k, c in cells.items() if c["accepted"]} == {
        ("cloudy", "light", "day"),
        ("rain", "light", "day"),
    }
    fog = cells[("fog", "heavy", "day")]
    assert fog["rejected_by"][:1] == ["Sn1"] and fog["formulas"]["Sn1"]["rate"] > 0.5
    assert fog["mae"]["lead_gap__camera-gt_lead_gap"]["mae"] > 3
    assert cells[("cloudy", "light", "day")]["mae"]["lead_gap__camera-gt_lead_gap"]["mae"] < 1
    sn1 = fog["formulas"]["Sn1"]
    assert sn1["runs_judged"] == 2 and sn1["interval"] == "runs"
    assert sn1["violated_ticks"] <= sn1["judged_ticks"] and sn1["low"] <= sn1["rate"] <= sn1["high"]
    assert "4 of 4 cells agree" in printed
    domain = parse_odd(yaml.safe_load((out / "accepted-odd.yaml").read_text()))
    assert domain.attributes["environment.weather"] == ["cloudy", "rain"]
    assert domain.attributes["environment.light"] == ["day"]
    intensity = domain.attributes["environment.intensity"]  # the light bin, as a range
    assert (intensity.min, intensity.max) == (0.0, 30.0)
    assert domain.combinations == []  # the accepted cells are the whole product
    html = (out / "odd.html").read_text()
    assert "Heatmap" in html and "detection_accuracy" in html and "rejected" in html


def test_the_odd_gates_what_the_case_claims(judged, tmp_path):
    """The example case states the accepted ODD on its root goal's context: a fog drive is
    outside it on every tick, a cloudy one inside."""
    for name, expected in (
        ("odd-fog-heavy-day-r0", "outside"),
        ("odd-cloudy-light-day-r0", "inside"),
    ):
        result = json.loads((judged / name / "result.json").read_text())
        (odd,) = result["odd"]
        assert odd[expected] == 201 and odd["node_id"] == "C1"
        statuses = {s["node_id"]: s["ticks"] for s in result["status"]}
        assert ("outside-odd" in statuses["C1"]) == (expected == "outside")


def test_strict_criterion_and_gating_subsets(judged, tmp_path, capsys):
    code = main(
        [
            "odd",
            str(judged),
            "-o",
            str(tmp_path / "o"),
            "--formulas",
            "Sn3",
            "--criterion",
            "upper",
            "--by",
            "environment.weather",
        ]
    )
    assert code == 0  # lane keeping holds everywhere: every weather is accepted
    report = json.loads((tmp_path / "o" / "odd.json").read_text())
    assert report["gating"] == ["Sn3"] and all(c["accepted"] for c in report["cells"])
    assert "rain" in {c["conditions"]["environment.weather"] for c in report["cells"]}
    capsys.readouterr()
    # by light alone, each cell holds a degraded condition (heavy fog by day, medium rain at
    # night)
    code = main(
        [
            "odd",
            str(judged),
            "-o",
            str(tmp_path / "none"),
            "--by",
            "environment.light",
            "--formulas",
            "Sn1",
        ]
    )
    assert code == 1 and not (tmp_path / "none" / "accepted-odd.yaml").exists()
    assert "no cell accepted" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("extra", "words"),
    [
        (["--max-mae", "lead_gap__camera"], "expected SIGNAL=BOUND"),
        (["--max-mae", "nope=1"], "saved no signal 'nope'"),
        (["--formulas", "Sn7"], "no formula Sn7"),
        (["--max-violation-rate", "5"], "between 0 and 1"),
        (["--max-violation-rate", "0"], "no rate is below 0, so no cell could be accepted"),
        (["--by", "weather"], "--by weather"),
        (["--bins", "fog=0,30,70,100"], "no condition 'fog' in the runs, and none end in .fog"),
        (["--bins", "weather=0,30,70,100"], "environment.weather takes no numbers"),
        (["--bins", "lanes=0,2,4"], "road.lanes is not one of the cells' attributes"),
        (["--bins", "environment.weather=0,30,20"], "the edges must increase"),
    ],
)
def test_refusals(judged, tmp_path, capsys, extra, words):
    assert main(["odd", str(judged), "-o", str(tmp_path / "o"), *extra]) == 2
    err = capsys.readouterr().err
    assert words in err and "Traceback" not in err


def test_the_studys_mae_criterion_is_on_by_default(judged, tmp_path, capsys):
    # the runs saved their signals and the case declares the lateral error lane_offset: the
    # study's MAE < 0.2 m applies without being asked for
    assert main(["odd", str(judged), "-o", str(tmp_path / "o")]) == 0
    report = json.loads((tmp_path / "o" / "odd.json").read_text())
    assert report["max_mae"] == {"lane_offset": 0.2} and report["acceptance"] == "strict"
    assert all(c["mae"]["lane_offset"]["mae"] < 0.2 for c in report["cells"])
    assert "MAE criterion (default): lane_offset < 0.2 m" in capsys.readouterr().out
    assert main(["odd", str(judged), "-o", str(tmp_path / "n"), "--no-mae"]) == 0
    assert json.loads((tmp_path / "n" / "odd.json").read_text())["max_mae"] == {}


def test_binned_lane_counts_on_the_grid(judged, tmp_path, capsys):
    # the grid's only numeric condition is road.lanes (3 on the highway): one bin of two
    code = main(
        [
            "odd",
            str(judged),
            "-o",
            str(tmp_path / "o"),
            "--by",
            "road.lanes,environment.weather",
            "--bins",
            "lanes=0,2,4:few,many",
            "--formulas",
            "Sn3",
        ]
    )
    assert code == 0
    report = json.loads((tmp_path / "o" / "odd.json").read_text())
    assert {c["conditions"]["road.lanes"] for c in report["cells"]} == {"many"}
    assert report["bins"] == {"road.lanes": {"edges": [0.0, 2.0, 4.0], "labels": ["few", "many"]}}
    domain = parse_odd(yaml.safe_load((tmp_path / "o" / "accepted-odd.yaml").read_text()))
    assert domain.attributes["road.lanes"].min == 2.0 and domain.attributes["road.lanes"].max == 4.0
    assert "road.lanes binned: few [0, 2], many (2, 4]" in capsys.readouterr().out


def test_a_folder_without_runs_is_refused(tmp_path, capsys):
    assert main(["odd", str(tmp_path), "-o", str(tmp_path / "o")]) == 2
    assert "neither a run folder" in capsys.readouterr().err


def test_reports_show_the_contracts_and_the_odd(judged):
    from casewatch.reports.html import render_html
    from casewatch.reports.markdown import render_markdown
    from casewatch.reports.render import load_result

    result = load_result(judged / "odd-fog-heavy-day-r0" / "result.json")
    md = render_markdown(result)
    assert "## Contracts" in md and "`gt_lead_gap < 60.0`" in md
    assert "| C1 | accepted | 0 | 201 | 0 | `environment.weather` 201 |" in md
    html = render_html(result)
    assert "Operational design domain" in html and "outside ODD" in html
    assert "library contract <code>detection_accuracy</code>" in html


def test_runs_under_one_condition_make_one_cell_named_by_all(judged, tmp_path, capsys):
    one = tmp_path / "one"
    one.mkdir()
    for k in (0, 1):  # one drive twice: no two drives share a continuous intensity
        shutil.copytree(judged / "odd-cloudy-light-day-r0", one / f"r{k}")
    assert main(["odd", str(one / "r0"), str(one / "r1"), "-o", str(tmp_path / "o")]) == 0
    domain = parse_odd(yaml.safe_load((tmp_path / "o" / "accepted-odd.yaml").read_text()))
    assert domain.attributes["environment.weather"] == ["cloudy"]
    assert domain.attributes["road.type"] == ["highway"]
    assert "ACCEPTED" in capsys.readouterr().out
