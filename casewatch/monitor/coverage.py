"""Channel coverage: compare objects only where both channels can see.

A forward camera is not "inconsistent" with a 360-degree lidar about the car behind: it cannot
see it. Each channel may declare a field of view (centred on its ego heading) and a range, in the
case (`monitor.coverage`) or in the stream header (`coverage`). The cross-channel object metrics
(`ocs`, `ols`, `oos`, `oas`, `ots`) of a pair read only the objects of either channel whose
centre lies inside both coverages, each shrunk by `coverage_margin` metres: near an edge, one
channel may report a car whose centre the other places just outside, and neither is wrong.

spi-reference "Channel coverage" is the normative text.
"""

from __future__ import annotations

import math

import numpy as np

from casewatch.monitor.frames import Coverage, Ego, Objects

# The compiled pass of `_view` (`coverage_flags`) and the resolution of its edge tests
# (`EDGE_EPS`) live in `monitor.similarity`, beside the similarity family's per-tick kernel that
# calls it (a kernel calls only kernels of its own module: `monitor.jit`).
from casewatch.monitor.similarity import EDGE_EPS, coverage_flags


def inside(coverage: Coverage, ego: Ego, pos: np.ndarray, margin: float) -> np.ndarray:
    """(K,) True where the points `pos` (K, 2) lie inside `coverage` seen from `ego`, at least
    `margin` metres from its edges (the range arc and, below 360 degrees, the two edge rays).
    A negative margin grows the coverage by as much instead."""
    rel = pos - np.array([ego.x, ego.y])
    r = np.hypot(rel[:, 0], rel[:, 1])
    keep = r <= coverage.range_m - margin + EDGE_EPS
    if coverage.fov_deg < 360.0:
        bearing = np.arctan2(rel[:, 1], rel[:, 0]) - ego.yaw
        bearing = np.abs((bearing + math.pi) % (2.0 * math.pi) - math.pi)
        # signed distance to the nearer edge ray (positive inside): r sin(angle to the ray),
        # and r itself once the nearest point of the ray is its apex (past a right angle)
        to_edge = np.clip(math.radians(coverage.fov_deg) / 2.0 - bearing, -math.pi / 2, math.pi / 2)
        keep &= r * np.sin(to_edge) >= margin - EDGE_EPS
    return keep


def _view(
    objects: Objects, views: tuple[tuple[Coverage, Ego], ...], margin: float
) -> tuple[Objects, np.ndarray]:
    """The objects inside every coverage grown by `margin`, and which of them lie inside every
    coverage shrunk by it (the core): `inside` of each coverage, in one compiled call."""
    return _view_rows(objects, _rows(views, margin))


def _rows(views: tuple[tuple[Coverage, Ego], ...], margin: float) -> np.ndarray | None:
    """`coverage_flags`'s views array of the coverages that are not all-round (None: none is)."""
    rows = [
        (ego.x, ego.y, ego.yaw, *view_limits(cov, margin))
        for cov, ego in views
        if not cov.all_round
    ]
    return np.array(rows) if rows else None


def view_limits(cov: Coverage, margin: float) -> tuple[float, float, float, float]:
    """The ego-independent columns of a coverage's row in `coverage_flags`'s views array:
    range_m + margin + EDGE_EPS, range_m - margin + EDGE_EPS, half the field of view in radians
    (inf: all-round in angle), margin; computed in `inside`'s own order of operations, so the
    flags are `inside`'s, bit for bit."""
    return (
        cov.range_m - -margin + EDGE_EPS,
        cov.range_m - margin + EDGE_EPS,
        math.radians(cov.fov_deg) / 2.0 if cov.fov_deg < 360.0 else math.inf,
        margin,
    )


def pair_views(cov_a: Coverage, cov_b: Coverage, margin: float) -> np.ndarray:
    """A channel pair's coverages as `similarity.PairTracker` reads them: (2, 5) rows, one per
    side, [1 if the coverage filters (not all-round) else 0, *view_limits]. Built once per
    coverage (the family checks at every tick that the engine's coverage is still the one it
    was built from): only the egos change from tick to tick, and the kernel reads them."""
    out = np.zeros((2, 5))
    for side, cov in enumerate((cov_a, cov_b)):
        if not cov.all_round:
            out[side, 0] = 1.0
            out[side, 1:] = view_limits(cov, margin)
    return out


def _view_rows(objects: Objects, rows: np.ndarray | None) -> tuple[Objects, np.ndarray]:
    """`_view` with its views array built (`_rows`): a pair's two sides share it."""
    if rows is None or not len(objects):
        return objects, np.ones(len(objects), dtype=bool)
    outer, core, kept = coverage_flags(objects.pos, rows)
    if kept == len(outer):
        return objects, core
    return objects.subset(outer), core[outer]


def common_view(
    a: Objects,
    ego_a: Ego,
    cov_a: Coverage,
    b: Objects,
    ego_b: Ego,
    cov_b: Coverage,
    margin: float,
) -> tuple[Objects, np.ndarray | None, Objects, np.ndarray | None]:
    """What the pair (A, B) compares: each channel's objects within `margin` of the coverage of
    both (each coverage seen from its own channel's ego estimate), with a core flag per object:
    inside both coverages by at least `margin`. The object metrics count a pair when either
    object is core and an unpaired object only when it is core (spi-reference "Channel
    coverage"): a car whose centre one channel places just inside an edge and the other just
    outside is neither a disagreement nor dropped from one side only. Two all-round channels
    of unlimited range: the objects as they are and None for the flags (all core)."""
    if cov_a.all_round and cov_b.all_round:
        return a, None, b, None  # every object is core: nothing to filter
    rows = _rows(((cov_a, ego_a), (cov_b, ego_b)), margin)
    va, core_a = _view_rows(a, rows)
    vb, core_b = _view_rows(b, rows)
    return va, core_a, vb, core_b
