"""The compiled coverage pass (`coverage._view`) against `inside`, its numpy formulation, on
random scenes: the same objects kept and the same core flags, bit for bit (issue 36: both the
live and the whole-log path call the compiled pass, so it must be `inside` exactly)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from casewatch.monitor.coverage import EDGE_EPS, _view, inside
from casewatch.monitor.frames import Coverage, Ego, Objects


def _objects(pos: np.ndarray) -> Objects:
    k = len(pos)
    return Objects(
        ids=[str(i) for i in range(k)],
        cls=["car"] * k,
        pos=pos,
        yaw=np.zeros(k),
        vel=np.zeros((k, 2)),
        footprints=np.zeros((k, 4, 2)),
        pred=np.zeros((k, 0, 3)),
        pred_len=np.zeros(k, dtype=np.int64),
        convex=np.ones(k, dtype=bool),
        half=np.ones((k, 2)),
    )


def _ego(x: float, y: float, yaw: float) -> Ego:
    return Ego(x=x, y=y, yaw=yaw, vx=0.0, vy=0.0, footprint=np.zeros((4, 2)), convex=True)


def _reference(pos, views, margin):
    """`_view`'s definition: `inside` of every coverage that is not all-round, grown and
    shrunk by the margin."""
    outer = np.ones(len(pos), dtype=bool)
    core = np.ones(len(pos), dtype=bool)
    for cov, ego in views:
        if not cov.all_round and len(pos):
            outer &= inside(cov, ego, pos, -margin)
            core &= inside(cov, ego, pos, margin)
    return outer, core


@pytest.mark.parametrize("seed", range(40))
def test_compiled_view_is_inside_exactly(seed):
    rng = np.random.default_rng(seed)
    k = int(rng.integers(0, 30))
    covs = [
        Coverage(fov_deg=float(rng.choice([60.0, 120.0, 200.0, 360.0])), range_m=r)
        for r in rng.choice([30.0, 70.0, math.inf], 2)
    ]
    egos = [_ego(*rng.uniform(-50, 50, 2), float(rng.uniform(-7, 7))) for _ in covs]
    pos = rng.uniform(-90, 90, (k, 2))
    # points placed exactly on a range arc and on an edge ray, where the tests are decided
    # by the EDGE_EPS resolution
    for j in range(0, k, 3):
        cov, ego = covs[j % 2], egos[j % 2]
        r = cov.range_m if math.isfinite(cov.range_m) else 40.0
        bearing = ego.yaw + math.radians(cov.fov_deg) / 2.0 * rng.choice([-1.0, 1.0, 0.3])
        pos[j] = (ego.x + r * math.cos(bearing), ego.y + r * math.sin(bearing))
    margin = float(rng.choice([0.0, 1.0, 2.5]))
    views = tuple(zip(covs, egos, strict=True))
    outer, core = _reference(pos, views, margin)
    kept, flags = _view(_objects(pos), views, margin)
    assert kept.pos.tolist() == pos[outer].tolist()
    assert kept.ids == [str(i) for i in np.flatnonzero(outer)]
    assert flags.tolist() == core[outer].tolist()


def test_all_round_views_keep_everything():
    pos = np.array([[1e4, 0.0], [0.0, -3.0]])
    views = ((Coverage(), _ego(0.0, 0.0, 0.0)), (Coverage(), _ego(5.0, 5.0, 1.0)))
    kept, core = _view(_objects(pos), views, 2.0)
    assert kept.pos.tolist() == pos.tolist()
    assert core.tolist() == [True, True]


def test_a_point_on_the_range_arc_is_core_only_without_a_margin():
    # 70 m straight ahead of a 70 m camera: on the arc; EDGE_EPS keeps it in
    pos = np.array([[70.0, 0.0]])
    views = ((Coverage(fov_deg=120.0, range_m=70.0), _ego(0.0, 0.0, 0.0)),)
    assert _view(_objects(pos), views, 0.0)[1].tolist() == [True]
    kept, core = _view(_objects(pos), views, 1.0)
    assert (len(kept), core.tolist()) == (1, [False])  # in the grown view, not in the core
    assert EDGE_EPS < 1e-6
