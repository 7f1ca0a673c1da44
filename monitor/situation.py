"""Situation signals: what tailgating *is*, measured per channel.

The study's hazard rules combine similarity scores, none of which measures a short time gap to
the vehicle ahead. These signals do, from each channel's own world model (spi-reference
"Situation signals" is the normative text, with hand-computed examples):

- the **leader**: the nearest object whose centre lies within `lane_half_width` of the ego's
  planned path (its heading when it has no plan), ahead of the ego;
- the **follower**: the nearest such object along the path the ego has driven, behind it;
- gaps are bumper to bumper along the path; time headway and time to collision follow the
  criticality-measure conventions of CommonRoad-CriMe (THW = gap / speed of the one behind,
  TTC = gap / closing speed);
- with no leader (or follower) in range, headway and TTC read `TIME_CAP` and the gap `GAP_CAP`:
  nothing to tailgate is not missing data.

Arrays in, arrays out: every object of a channel is projected onto every segment of the path
in one numpy expression.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from monitor.frames import Ego, Objects

#: Headway and TTC [s] when there is no leader / follower, or it is not closing in.
TIME_CAP = 60.0
#: Gap [m] when there is no leader / follower within the look-ahead.
GAP_CAP = 200.0
#: Below this speed [m/s] a vehicle is standing: its headway is TIME_CAP.
STANDING = 0.1


@dataclass(frozen=True, slots=True)
class Neighbour:
    """The leader or the follower of one channel's ego: gap [m], speed along the path [m/s]
    (0 when there is none), and whether there is one."""

    gap: float
    speed: float
    present: bool


NONE = Neighbour(GAP_CAP, 0.0, False)


def path_ahead(ego: Ego, plan: np.ndarray, lookahead: float) -> np.ndarray:
    """(P, 2) polyline from the ego along its plan (points after the first that move away),
    extended straight along the last direction to `lookahead` metres; the ego's heading when
    the plan does not move."""
    start = np.array([ego.x, ego.y])
    pts = plan[:, 1:3] if len(plan) else np.zeros((0, 2))
    return _extend(np.vstack([start, pts]), ego.yaw, lookahead)


def path_behind(ego: Ego, history: np.ndarray, lookahead: float) -> np.ndarray:
    """(P, 2) polyline from the ego back along its driven positions `history` (oldest first),
    extended straight backwards to `lookahead` metres; straight back along its heading when
    it has not moved."""
    start = np.array([ego.x, ego.y])
    return _extend(np.vstack([start, history[::-1]]), ego.yaw + math.pi, lookahead)


def _extend(points: np.ndarray, heading: float, lookahead: float) -> np.ndarray:
    """Drop points that do not move on from the previous kept one (< 1 cm), then add a point
    `lookahead` metres beyond the last one, along the last segment (or `heading`)."""
    seg = np.diff(points, axis=0)
    keep = np.concatenate([[True], np.hypot(seg[:, 0], seg[:, 1]) > 0.01])
    pts = points[keep]
    if len(pts) >= 2:
        d = pts[-1] - pts[-2]
        u = d / np.hypot(d[0], d[1])
    else:
        u = np.array([math.cos(heading), math.sin(heading)])
    return np.vstack([pts, pts[-1] + lookahead * u])


def project(path: np.ndarray, pos: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Project points (K, 2) onto a polyline (P, 2): arc length s (K,) of the nearest point,
    its distance d (K,), and the unit tangent (K, 2) of that segment."""
    a = path[:-1]
    ab = path[1:] - a
    length = np.hypot(ab[:, 0], ab[:, 1])
    unit = ab / length[:, None]
    rel = pos[:, None, :] - a[None, :, :]
    along = np.clip(np.einsum("ksi,si->ks", rel, unit), 0.0, length[None, :])
    foot = a[None, :, :] + along[..., None] * unit[None, :, :]
    dist = np.hypot(*(pos[:, None, :] - foot).transpose(2, 0, 1))
    best = np.argmin(dist, axis=1)
    rows = np.arange(len(pos))
    start_s = np.concatenate([[0.0], np.cumsum(length)[:-1]])
    return start_s[best] + along[rows, best], dist[rows, best], unit[best]


def neighbour(
    ego: Ego, objects: Objects, path: np.ndarray, half_width: float, ego_half_length: float
) -> Neighbour:
    """The nearest object within `half_width` of `path` (from the ego outwards): the gap from
    the ego's bumper to the object's near side along the path, and the object's speed along
    the path (positive: moving the path's way, away from the ego)."""
    if len(objects) == 0:
        return NONE
    s, d, tangent = project(path, objects.pos)
    inside = (d <= half_width) & (s > 0.0)
    if not inside.any():
        return NONE
    # the object's extent along the path: its box projected on the tangent
    heading = np.stack([np.cos(objects.yaw), np.sin(objects.yaw)], axis=1)
    cos = np.abs(np.einsum("ki,ki->k", heading, tangent))
    half = objects.half
    hl = np.where(np.isnan(half[:, 0]), objects.radii, half[:, 0])
    hw = np.where(np.isnan(half[:, 1]), objects.radii, half[:, 1])
    extent = hl * cos + hw * np.sqrt(np.maximum(0.0, 1.0 - cos * cos))
    gap = np.maximum(s - ego_half_length - extent, 0.0)
    gap = np.where(inside, gap, np.inf)
    k = int(np.argmin(gap))
    speed = float(objects.vel[k] @ tangent[k])
    return Neighbour(min(float(gap[k]), GAP_CAP), speed, True)


def headway(gap: float, speed: float) -> float:
    """Time headway [s]: gap over the speed of the vehicle behind; TIME_CAP when it stands."""
    return TIME_CAP if speed < STANDING else min(gap / speed, TIME_CAP)


def time_to_collision(gap: float, closing: float) -> float:
    """TTC [s]: gap over the closing speed; TIME_CAP when the two are not closing in."""
    return TIME_CAP if closing <= 1e-3 else min(gap / closing, TIME_CAP)


def ego_half_length(ego: Ego) -> float:
    """Half the ego's length along its heading (box, or the footprint's extent forward)."""
    if ego.half is not None:
        return ego.half[0]
    return float(np.max(np.abs(ego.footprint[:, 0])))
