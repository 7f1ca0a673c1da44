"""Footprint geometry helpers of the frame model."""

from __future__ import annotations

import math

import numpy as np
import pytest

from casewatch.monitor.frames import box_footprint, is_convex, place, polygon_area


def test_box_footprint_and_placement():
    body = box_footprint(4.0, 2.0)
    assert body.tolist() == [[2, 1], [-2, 1], [-2, -1], [2, -1]]
    # turned by 90 degrees and moved to (10, 5): the front-left corner (2, 1) lands at (9, 7)
    world = place(body, np.array([10.0, 5.0]), np.array(math.pi / 2))
    np.testing.assert_allclose(world[0], [9.0, 7.0], atol=1e-12)
    assert polygon_area(world) == pytest.approx(8.0)


def test_area_ignores_padding_and_convexity():
    tri = np.array([[0.0, 0.0], [2.0, 0.0], [0.0, 1.0], [0.0, 1.0]])  # last vertex repeated
    assert polygon_area(tri) == pytest.approx(1.0)  # 2 * 1 / 2
    assert is_convex(tri)
    u = np.array(
        [[-2, 2.5], [-2, 1.5], [2, 1.5], [2, -1.5], [-2, -1.5], [-2, -2.5], [3, -2.5], [3, 2.5]],
        dtype=float,
    )
    assert not is_convex(u)
    # U area: 5 x 5 outer box minus the 4 x 3 notch = 25 - 12 = 13
    assert polygon_area(u) == pytest.approx(13.0)
