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
from casewatch.monitor.jit import kernel

#: Resolution [m] of the edge tests: a point on an edge is inside whatever the rounding of
#: arctan2 and sin in the numpy build at hand (one build put a point on the edge ray 4e-15 m
#: outside it).
EDGE_EPS = 1e-9


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


@kernel
def _flags(pos, views):  # pragma: no cover - compiled
    """`inside` of every view for the outer (margin -m) and the core (margin m) test at once.

    views (V, 7): ego x, y, yaw, then range_m + m + EDGE_EPS, range_m - m + EDGE_EPS, half
    the field of view in radians (inf: all-round in angle), m. The thresholds are computed by
    the caller in `inside`'s own order of operations, so each flag is `inside`'s, bit for bit.
    Returns (outer, core), each (K,) bool, and the number of outer flags set."""
    k = pos.shape[0]
    outer = np.ones(k, dtype=np.bool_)
    core = np.ones(k, dtype=np.bool_)
    for v in range(views.shape[0]):
        ex, ey, yaw = views[v, 0], views[v, 1], views[v, 2]
        reach_out, reach_core, half_fov, m = views[v, 3], views[v, 4], views[v, 5], views[v, 6]
        for i in range(k):
            rx = pos[i, 0] - ex
            ry = pos[i, 1] - ey
            r = np.hypot(rx, ry)
            keep_out = r <= reach_out
            keep_core = r <= reach_core
            if half_fov != np.inf:
                bearing = np.arctan2(ry, rx) - yaw
                bearing = np.abs((bearing + np.pi) % (2.0 * np.pi) - np.pi)
                to_edge = min(max(half_fov - bearing, -np.pi / 2), np.pi / 2)
                side = r * np.sin(to_edge)
                keep_out = keep_out and side >= -m - EDGE_EPS
                keep_core = keep_core and side >= m - EDGE_EPS
            outer[i] = outer[i] and keep_out
            core[i] = core[i] and keep_core
    kept = 0
    for i in range(k):
        if outer[i]:
            kept += 1
    return outer, core, kept


def _view(
    objects: Objects, views: tuple[tuple[Coverage, Ego], ...], margin: float
) -> tuple[Objects, np.ndarray]:
    """The objects inside every coverage grown by `margin`, and which of them lie inside every
    coverage shrunk by it (the core): `inside` of each coverage, in one compiled call."""
    return _view_rows(objects, _rows(views, margin))


def _rows(views: tuple[tuple[Coverage, Ego], ...], margin: float) -> np.ndarray | None:
    """`_flags`'s views array of the coverages that are not all-round (None: none is)."""
    rows = [
        (
            ego.x,
            ego.y,
            ego.yaw,
            cov.range_m - -margin + EDGE_EPS,
            cov.range_m - margin + EDGE_EPS,
            math.radians(cov.fov_deg) / 2.0 if cov.fov_deg < 360.0 else math.inf,
            margin,
        )
        for cov, ego in views
        if not cov.all_round
    ]
    return np.array(rows) if rows else None


def _view_rows(objects: Objects, rows: np.ndarray | None) -> tuple[Objects, np.ndarray]:
    """`_view` with its views array built (`_rows`): a pair's two sides share it."""
    if rows is None or not len(objects):
        return objects, np.ones(len(objects), dtype=bool)
    outer, core, kept = _flags(objects.pos, rows)
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
