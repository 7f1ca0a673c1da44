"""The calibration page (reports/calibration.py): the trade-off plot's geometry from a
hand-written calibration report, computed by hand."""

from __future__ import annotations

from casewatch.reports.calibration import _plot, render_calibration


def point(threshold, duration, episodes, per_hour, detected=None, faults=0, fires=True):
    return {
        "threshold": threshold,
        "for": duration,
        "episodes": episodes,
        "per_hour": per_hour,
        "per_hour_upper": per_hour + 3.0,
        "detected": detected,
        "detection": None if detected is None else detected / faults,
        "fires": fires,
    }


def report(faults: int) -> dict:
    d = (lambda n: n) if faults else (lambda n: None)
    curve = [
        point(0.5, 0.0, 1, 1.0, d(1), faults),
        point(0.6, 0.0, 5, 5.0, d(2), faults),
        point(0.5, 1.0, 0, 0.0, d(0), faults),
        point(0.6, 1.0, 1, 1.0, d(1), faults),
        point(0.9, 0.0, 90, 90.0, d(2), faults),
    ]
    row = {
        "formula": "Sn1",
        "parameter": "els >=",
        "op": ">=",
        "hours": 1.0,
        "faults": faults,
        "original": curve[1],
        "chosen": curve[3],
        "status": "calibrated",
        "reason": "",
        "original_over_budget": True,
        "curve": curve,
    }
    return {
        "case": "c.yaml",
        "logs": 1,
        "hours": 1.0,
        "per_hour": 2.0,
        "min_hours": 0.5,
        "margin": 3.0,
        "faults": faults,
        "tighten": False,
        "confidence": 0.95,
        "spis": [row],
    }


def test_the_trade_off_plot_places_each_candidate_by_hand():
    rep = report(faults=2)
    plot = _plot(rep["spis"][0], 2.0)
    # the rate axis ends at max(3 x budget, original 5/h, chosen 1/h, 1) = 6/h; plot area
    # x 48-324, y 12-208; detection 0-100 % upwards
    assert plot["cap"] == "6" and plot["tradeoff"]
    # for 0 s: (1/h, 50 %), (5/h, 100 %); for 1 s: (0/h, 0 %), (1/h, 50 %)
    assert plot["lines"][0]["points"] == "94.0,110.0 278.0,12.0"
    assert plot["lines"][1]["points"] == "48.0,208.0 94.0,110.0"
    assert plot["hidden"] == 1  # 90/h is past the axis
    assert (plot["chosen"]["x"], plot["chosen"]["y"]) == (94.0, 110.0)
    assert (plot["original"]["x"], plot["original"]["y"]) == (278.0, 12.0)
    assert plot["budget_at"] == 140.0  # 2/h of 6/h
    html = render_calibration(rep)
    assert "faults detected" in html and "1 of 2" in html and "over budget" in html


def test_without_faults_the_plot_is_false_alarms_against_the_threshold():
    plot = _plot(report(faults=0)["spis"][0], 2.0)
    # thresholds 0.5-0.9 across, 0-6/h upwards: for 0 s (0.5, 1/h) and (0.6, 5/h)
    assert not plot["tradeoff"]
    assert plot["lines"][0]["points"] == "48.0,175.33 117.0,44.67"
    assert plot["budget_at"] == 142.67  # 2/h of 6/h, from the bottom
