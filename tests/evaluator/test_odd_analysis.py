"""The ODD analysis on hand-built runs: the study's strict acceptance (a rate below 5 %), binned
continuous conditions (light [0, 30], medium (30, 70], heavy (70, 100]) and the shape of the
study's 27-cell table, honest intervals."""

from __future__ import annotations

from itertools import product
from types import SimpleNamespace

import pytest

from casewatch.evaluator.odd_analysis import Bins, RunInput, accepted_odd, analyse, parse_bins
from casewatch.reports.odd import render_odd_html, render_odd_text
from casewatch.safety_case.model import OddRange


def run(name: str, attributes: dict, violated: int, judged: int = 100) -> RunInput:
    """A run under one combination of conditions, with one contract Sn1 violated on
    `violated` of `judged` ticks."""
    tally = SimpleNamespace(violated=violated, evaluated=judged, outside_assumption=0, no_data=0)
    cond = SimpleNamespace(
        attributes=attributes, ticks=judged, formulas={"Sn1": tally}, spans=[[0.0, judged / 10]]
    )
    formula = SimpleNamespace(
        id="Sn1",
        kind="spi",
        node_id="Sn1",
        node_text="lane keeping",
        contract_use="lane_keeping",
        assumption=None,
        source="abs(lane_offset) < lane_width / 2",
    )
    result = SimpleNamespace(conditions=[cond], formulas=[formula], stream=SimpleNamespace(meta={}))
    return RunInput(name, result)  # type: ignore[arg-type]


WEATHER = ["environment.weather"]


def test_a_rate_of_exactly_5_percent_is_rejected_as_the_study_says():
    # two runs, 5 of 100 ticks each: rate 0.05, not "less than 5 %"
    runs = [run(name, {"environment.weather": "rain"}, 5) for name in ("a", "b")]
    (cell,) = analyse(runs, WEATHER, None, 0.05)["cells"]
    assert cell["formulas"]["Sn1"]["rate"] == 0.05 and not cell["accepted"]
    (cell,) = analyse(runs, WEATHER, None, 0.05, strict=False)["cells"]
    assert cell["accepted"]  # casewatch's inclusive variant
    assert analyse(runs, WEATHER, None, 0.05)["acceptance"] == "strict"


def test_no_spread_between_runs_is_named_not_printed_as_an_interval():
    # 0 of 100 ticks in each of 4 runs: the cluster interval has zero width, which says
    # nothing; the runs violated, 0 of 4, have a Wilson upper bound of
    # z^2/4 / (1 + z^2/4) = 0.9604 / 1.9604 = 0.4899
    runs = [run(f"r{k}", {"environment.weather": "clear"}, 0) for k in range(4)]
    report = analyse(runs, WEATHER, None, 0.05)
    f = report["cells"][0]["formulas"]["Sn1"]
    assert (f["low"], f["high"], f["interval"]) == (0.0, 0.0, "runs")
    assert "no spread to estimate" in f["interval_method"]
    assert f["runs_violated_high"] == pytest.approx(0.4899, abs=1e-4)
    html = render_odd_html(report)
    assert "[0.0 %, 0.0 %]" not in html and "no spread" in html
    assert "0 of 4 runs, &le; 49.0 %" in html
    text = render_odd_text(report)
    assert "      Sn1 0.0 % no spread, 0/4 (<= 49.0 %)" in text
    assert "[0.0 %, 0.0 %]" not in "".join(text)
    assert max(len(line) for line in text) <= 100


def test_bins_follow_the_study_light_medium_heavy():
    b = parse_bins("fog=0,30,70,100:light,medium,heavy")
    assert (b.attribute, b.edges, b.names) == (
        "fog",
        (0.0, 30.0, 70.0, 100.0),
        ("light", "medium", "heavy"),
    )
    # [0, 30], (30, 70], (70, 100]: 30 is light, 30.5 medium, 70 medium, 70.1 heavy
    assert [b.label(v) for v in (0, 30, 30.5, 70, 70.1, 100)] == [
        "light",
        "light",
        "medium",
        "medium",
        "heavy",
        "heavy",
    ]
    assert b.label(120) == "outside [0, 100]" and b.label(None) is None
    assert Bins("fog", (0.0, 30.0, 70.0, 100.0)).labels() == ["[0, 30]", "(30, 70]", "(70, 100]"]


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("fog", "expected ATTR=EDGE,EDGE"),
        ("fog=0", "expected ATTR=EDGE,EDGE"),
        ("fog=0,a,3", "expected ATTR=EDGE,EDGE"),
        ("fog=0,70,30", "the edges must increase"),
        ("fog=0,30,100:light", "2 bins need 2 names, got 1"),
    ],
)
def test_bad_bins_say_what_is_wrong(text, words):
    with pytest.raises(ValueError, match=words):
        parse_bins(text)


def test_the_studys_27_cell_table_and_its_accepted_domain():
    # 3 weather kinds x 3 intensities (binned 0-100) x 3 times of day: 27 cells, in the
    # study's order; rain and fog above 30 violate 10 %, the rest 1 %
    by = ["environment.weather", "environment.intensity", "environment.light"]
    bins = {
        "environment.intensity": parse_bins("environment.intensity=0,30,70,100:light,medium,heavy")
    }
    runs = []
    for weather, level, light in product(
        ("cloudy", "rain", "fog"), (15, 50, 85), ("noon", "sunset", "night")
    ):
        bad = weather != "cloudy" and level > 30
        attrs = {
            "environment.weather": weather,
            "environment.intensity": float(level),
            "environment.light": light,
        }
        runs += [run(f"{weather}-{level}-{light}-{k}", attrs, 10 if bad else 1) for k in (0, 1)]
    report = analyse(runs, by, None, 0.05, bins=bins)
    cells = report["cells"]
    assert len(cells) == 27
    assert [c["conditions"]["environment.intensity"] for c in cells[:3]] == ["light"] * 3
    assert [c["conditions"]["environment.intensity"] for c in cells[::3][:3]] == [
        "light",
        "medium",
        "heavy",
    ]
    accepted = {
        (c["conditions"]["environment.weather"], c["conditions"]["environment.intensity"])
        for c in cells
        if c["accepted"]
    }
    assert accepted == {
        ("cloudy", "light"),
        ("cloudy", "medium"),
        ("cloudy", "heavy"),
        ("rain", "light"),
        ("fog", "light"),
    }
    # not a product (cloudy heavy is in, rain heavy is not): no interval can say that
    assert accepted_odd(report) is None
    # cloudy alone: every intensity, the whole [0, 100]
    cloudy = analyse([r for r in runs if "cloudy" in r.folder], by, None, 0.05, bins=bins)
    odd = accepted_odd(cloudy)
    assert odd.attributes["environment.intensity"] == OddRange(min=0.0, max=100.0)
    assert odd.attributes["environment.weather"] == ["cloudy"]
