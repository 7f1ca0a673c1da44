"""Channel coverage: the cross-channel object metrics compare only what both channels can see
(spi-reference "Channel coverage")."""

from __future__ import annotations

import math

import numpy as np
import pytest

from casewatch.monitor.coverage import common_view, inside
from casewatch.monitor.engine import MetricEngine
from casewatch.monitor.frames import Coverage, Ego
from casewatch.safety_case.model import MetricParams
from tests.monitor.builders import channel, ego, frame, obj

CAMERA = Coverage(fov_deg=120.0, range_m=70.0)
LIDAR = Coverage(fov_deg=360.0, range_m=80.0)


def ego_at(x: float = 0.0, y: float = 0.0, yaw: float = 0.0) -> Ego:
    return frame(0.0, {"a": channel(ego(x, y, yaw))}).channels["a"].ego


def test_inside_hand_computed():
    e = ego_at(10.0, 5.0, math.pi / 2)  # looking along +y
    pts = np.array(
        [
            [10.0, 25.0],  # 20 m straight ahead
            [10.0, -15.0],  # 20 m behind
            [30.0, 5.0],  # 20 m to the right: bearing -90 deg, outside +-60
            [10.0, 76.0],  # 71 m ahead: beyond the range
            # on the +60 deg edge ray at 20 m: 0 m from the edge, in without a margin only
            [10.0 - 20 * math.sin(math.pi / 3), 5.0 + 20 * math.cos(math.pi / 3)],
        ]
    )
    assert inside(CAMERA, e, pts, 0.0).tolist() == [True, False, False, False, True]
    # a 2 m margin: 20 m at 50 deg from the axis is 20 sin(10 deg) = 3.47 m from the edge
    b = math.radians(50)
    at50 = np.array([[10.0 - 20 * math.sin(b), 5.0 + 20 * math.cos(b)]])
    assert inside(CAMERA, e, at50, 2.0).tolist() == [True]
    assert inside(CAMERA, e, at50, 3.5).tolist() == [False]
    assert inside(CAMERA, e, pts[:1], 2.0).tolist() == [True]
    # the range shrinks by the margin too: 69 m ahead is in at 0 m, out at 2 m
    far = np.array([[10.0, 74.0]])
    assert inside(CAMERA, e, far, 0.0).tolist() == [True]
    assert inside(CAMERA, e, far, 2.0).tolist() == [False]


def test_common_view_keeps_what_both_can_see():
    lidar = frame(
        0.0,
        {
            "a": channel(
                ego(),
                objects=[
                    obj(1, 20.0, 0.0),
                    obj(2, -15.0, 0.0),
                    obj(3, 0.0, 30.0),
                    obj(4, 75.0, 0.0),
                    obj(5, 69.0, 0.0),
                ],
            )
        },
    )
    camera = frame(0.0, {"a": channel(ego(0.2, 0.0), objects=[obj(7, 20.3, 0.1)])})
    oa, core_a, ob, core_b = common_view(
        lidar.channels["a"].objects,
        lidar.channels["a"].ego,
        LIDAR,
        camera.channels["a"].objects,
        camera.channels["a"].ego,
        CAMERA,
        2.0,
    )
    # behind (2), to the side (3) and beyond the camera's 70 + 2 m (4) are out of view; 5 is
    # in the camera's range margin (68.8 m from the camera's ego, 68-72 m): kept, not core
    assert oa.ids == ["1", "5"] and core_a.tolist() == [True, False]
    assert ob.ids == ["7"] and core_b.tolist() == [True]
    # all-round unlimited channels filter nothing
    same = common_view(oa, ego_at(), Coverage(), ob, ego_at(), Coverage(), 2.0)
    assert same == (oa, None, ob, None)


def test_a_car_straddling_the_range_edge_is_neither_dropped_nor_a_disagreement():
    # the lead 68 m ahead: the lidar places it at 68.2 m, the camera at 67.9 m, around the
    # camera's 70 - 2 m core edge. Compared as a pair (one core member): ols = 1 / 1.3
    eng = MetricEngine(MetricParams(), ["a", "b"], {"b": CAMERA})
    out = eng.step(
        frame(
            0.0,
            {
                "a": channel(ego(), objects=[obj(1, 68.2, 0.0)]),
                "b": channel(ego(), objects=[obj(1, 67.9, 0.0)]),
            },
        )
    )
    assert out["ols"] == pytest.approx(1 / 1.3) and out["ocs"] == 1.0
    # both in the margin: nothing to compare, which is agreement, not a gap
    out = eng.step(
        frame(
            0.1,
            {
                "a": channel(ego(), objects=[obj(1, 69.2, 0.0)]),
                "b": channel(ego(), objects=[]),
            },
        )
    )
    assert out["ols"] == 1.0 and out["ocs"] == 1.0


def run(coverage: dict[str, Coverage] | None) -> dict[str, float | None]:
    """A lidar channel (a) that sees a car ahead and one behind; a camera (b) that sees only
    the car ahead."""
    eng = MetricEngine(MetricParams(), ["a", "b"], coverage)
    ahead = obj(1, 20.0, 0.0, prediction=[[0.1 * n, 20.0 + n, 0.0] for n in range(1, 21)])
    behind = obj(2, -12.0, 0.0, prediction=[[0.1 * n, -12.0 + n, 0.0] for n in range(1, 21)])
    return eng.step(
        frame(
            0.0,
            {
                "a": channel(ego(), objects=[ahead, behind]),
                "b": channel(ego(), objects=[ahead]),
            },
        )
    )


def test_a_camera_blind_behind_is_not_inconsistent():
    blind = run(None)
    # without coverage, the car behind is one object more and an unpaired one:
    # ocs = 1 / (1 + 1) = 0.5 and ols = mean over the one pair = 1.0 (unpaired objects do not
    # enter the mean, but the count difference does)
    assert blind["ocs"] == pytest.approx(0.5)
    declared = run({"b": CAMERA})
    for m in ("ocs", "ols", "oos", "oas", "ots"):
        assert declared[m] == pytest.approx(1.0), m


def test_coverage_from_case_beats_header():
    from casewatch.evaluator.session import channel_coverage
    from casewatch.monitor.frames import Header
    from casewatch.safety_case.model import ChannelCoverage, MonitorConfig

    class CaseLike:
        monitor = MonitorConfig(
            channels=["lav", "tfuse"], coverage={"tfuse": ChannelCoverage(fov_deg=90.0)}
        )

    header = Header(channels=["lav", "tfuse"], coverage={"lav": LIDAR, "tfuse": CAMERA})
    got = channel_coverage(CaseLike, header)  # type: ignore[arg-type]
    assert got == {"lav": LIDAR, "tfuse": Coverage(90.0, math.inf)}
    assert channel_coverage(CaseLike, None)["lav"] == Coverage()  # type: ignore[arg-type]
