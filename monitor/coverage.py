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

from monitor.frames import Coverage, Ego, Objects


def inside(coverage: Coverage, ego: Ego, pos: np.ndarray, margin: float) -> np.ndarray:
    """(K,) True where the points `pos` (K, 2) lie inside `coverage` seen from `ego`, at least
    `margin` metres from its edges (the range arc and, below 360 degrees, the two edge rays)."""
    rel = pos - np.array([ego.x, ego.y])
    r = np.hypot(rel[:, 0], rel[:, 1])
    keep = r <= coverage.range_m - margin
    if coverage.fov_deg < 360.0:
        bearing = np.arctan2(rel[:, 1], rel[:, 0]) - ego.yaw
        bearing = np.abs((bearing + math.pi) % (2.0 * math.pi) - math.pi)
        # distance to the nearer edge ray: r sin(angle to it), or r past a right angle
        to_edge = np.minimum(math.radians(coverage.fov_deg) / 2.0 - bearing, math.pi / 2.0)
        keep &= (to_edge >= 0.0) & (r * np.sin(np.maximum(to_edge, 0.0)) >= margin)
    return keep


def common_view(
    a: Objects, ego_a: Ego, cov_a: Coverage,
    b: Objects, ego_b: Ego, cov_b: Coverage,
    margin: float,
) -> tuple[Objects, Objects]:
    """The objects of A and of B inside the coverage of both channels (each channel's coverage
    seen from its own ego estimate). All-round channels of unlimited range filter nothing."""
    if cov_a.all_round and cov_b.all_round:
        return a, b
    out = []
    for objects in (a, b):
        keep = np.ones(len(objects), dtype=bool)
        for cov, ego in ((cov_a, ego_a), (cov_b, ego_b)):
            if not cov.all_round and len(objects):
                keep &= inside(cov, ego, objects.pos, margin)
        out.append(objects if keep.all() else objects.subset(keep))
    return out[0], out[1]
