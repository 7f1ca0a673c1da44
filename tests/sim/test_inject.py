"""Fault injection on hand-built channel reports (examples.sim.inject), no simulator needed."""

from __future__ import annotations

import math

import numpy as np
import pytest

from examples.sim.inject import InjectedFault, Injector


def report(t: float = 0.0) -> dict:
    """A channel's report: ego at (10 t, 0) heading +x at 10 m/s, two cars, a straight plan."""
    x = 10.0 * t
    car = {
        "id": "1",
        "cls": "car",
        "x": x + 20.0,
        "y": 0.0,
        "yaw": 0.0,
        "vx": 8.0,
        "vy": 0.0,
        "length": 4.5,
        "width": 1.8,
        "prediction": [[0.5, x + 24.0, 0.0], [1.0, x + 28.0, 0.0]],
    }
    parked = {
        **car,
        "id": "2",
        "x": x + 30.0,
        "y": 5.0,
        "vx": 0.0,
        "prediction": [[0.5, x + 30.0, 5.0]],
    }
    return {
        "ego": {"x": x, "y": 0.0, "yaw": 0.0, "vx": 10.0, "vy": 0.0, "length": 4.5, "width": 1.8},
        "plan": [[0.0, x, 0.0], [1.0, x + 10.0, 0.0], [2.0, x + 20.0, 0.0]],
        "objects": [car, parked],
    }


REPORTED = np.array([4, 7])  # true vehicle index of each object


def test_no_active_fault_returns_the_report_itself() -> None:
    r = report()
    inj = Injector([InjectedFault("phantom", "a", 5, 6)])
    assert inj.apply(4, "a", r, REPORTED) is r
    assert inj.apply(5, "b", r, REPORTED) is r


def test_object_drop_removes_that_vehicle_only() -> None:
    inj = Injector([InjectedFault("object_drop", "a", 0, 9, {"vehicle": "v7", "_vehicle": 7})])
    out = inj.apply(3, "a", report(), REPORTED)
    assert [o["id"] for o in out["objects"]] == ["1"]
    assert len(report()["objects"]) == 2  # the clean report is untouched


def test_phantom_is_15_m_ahead_and_drives_along() -> None:
    out = Injector([InjectedFault("phantom", "a", 0, 19)]).apply(0, "a", report(), REPORTED)
    ghost = out["objects"][-1]
    assert (ghost["x"], ghost["y"], ghost["vx"]) == (15.0, 0.0, 10.0)
    assert ghost["prediction"][9] == [1.0, 25.0, 0.0]


def test_plan_shift_whole_and_diverging() -> None:
    whole = InjectedFault(
        "plan_lateral", "a", 0, 19, {"offset_m": 1.5, "side": "left", "ramp_s": 0.0}
    )
    out = Injector([whole]).apply(0, "a", report(), REPORTED)
    assert [p[2] for p in out["plan"]] == [1.5, 1.5, 1.5]
    ramp = InjectedFault(
        "plan_lateral", "a", 0, 19, {"offset_m": 2.0, "side": "right", "ramp_s": 2.0}
    )
    out = Injector([ramp]).apply(0, "a", report(), REPORTED)
    assert [p[2] for p in out["plan"]] == [0.0, -1.0, -2.0]


def test_reversed_predictions_point_back_for_moving_objects_only() -> None:
    out = Injector([InjectedFault("prediction_reversed", "a", 0, 19)]).apply(
        0, "a", report(), REPORTED
    )
    moving, parked = out["objects"]
    assert moving["prediction"] == [[0.5, 16.0, 0.0], [1.0, 12.0, 0.0]]
    assert parked["prediction"] == [[0.5, 30.0, 5.0]]


def test_drift_moves_everything_the_channel_places() -> None:
    fault = InjectedFault("localisation_drift", "a", 10, 39, {"rate_m_s": 1.0, "heading_deg": 90.0})
    # tick 14 is the fifth of the fault: 0.5 s of drift at 1 m/s, straight up (+y)
    out = Injector([fault]).apply(14, "a", report(1.4), REPORTED)
    assert out["ego"]["y"] == pytest.approx(0.5)
    assert out["ego"]["x"] == pytest.approx(14.0)
    assert [p[2] for p in out["plan"]] == pytest.approx([0.5] * 3)
    assert out["objects"][0]["y"] == pytest.approx(0.5)
    assert out["objects"][0]["prediction"][0][2] == pytest.approx(0.5)
    assert math.isclose(out["objects"][1]["y"], 5.5)


def test_frozen_channel_repeats_its_first_frame() -> None:
    inj = Injector([InjectedFault("frozen_channel", "a", 10, 30)])
    first = inj.apply(10, "a", report(1.0), REPORTED)
    later = inj.apply(20, "a", report(2.0), REPORTED)
    assert later == first
    assert later["ego"]["x"] == 10.0
