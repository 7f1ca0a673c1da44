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

from casewatch.monitor.frames import Ego, Objects
from casewatch.monitor.jit import kernel

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


#: Resolution [m] of every geometric decision below: points on a boundary (the corridor's
#: edge, beside the ego, a vertex equidistant from two segments) fall the same way whatever
#: the world frame's rounding (the pairing's tie rule, spi-reference "Building blocks").
EPS = 1e-9

#: An object in the corridor is a leader (follower) only if its velocity across the path
#: keeps it in the corridor for this long [s]: a car changing lanes through the ego's path
#: (two cars swapping lanes, one cutting across) is passing, not leading; it crosses the
#: 3.5 m corridor in about a second. The hazard rules' minimum duration is a second too.
LANE_HOLD = 1.0

#: The leader must also share the ego's lane now (`_shares_lane`), not only lie in the
#: planned path: during the ego's lane change the plan already runs in the new lane, and a car
#: there (often pulling away from the merging ego) read as tailgated about a second before the
#: ego's centre crossed the lane line, which is where lane-based ground truth switches. The
#: chord test holds on bends (an arc's chord halves its turn) but not across a turn followed by
#: a straight, so it applies only while the two headings differ by less than this angle (a
#: lane change turns the ego 3-12 degrees).
LEAD_LANE = math.radians(15.0)
LEAD_LANE_COS = math.cos(LEAD_LANE)

#: Largest angle between the ego's and a follower's headings for the follower's own lane
#: test (`_in_own_lane`): beyond it, the two are not driving the same way.
FOLLOW_ALIGN = math.radians(30.0)

#: The second point of a path is the first at least this far [m] from the ego: its direction
#: is the path's initial heading, and nearer plan points add only rounding.
PATH_SPACING = 2.0
#: A path point is kept when it strays more than this [m] from the line through the last two
#: kept points: a straight plan becomes one segment, a 15 m radius turn keeps a point every
#: metre or so, and the polyline never strays more than a few centimetres from the plan.
PATH_TOLERANCE = 0.1


@kernel
def _strays(out, m, x, y, norm):  # pragma: no cover - compiled
    """True when (x, y) lies more than PATH_TOLERANCE from the line through the last two kept
    points out[m - 2], out[m - 1] (m >= 2), whose distance apart is `norm` (`_norm`)."""
    px = out[m - 1, 0]
    py = out[m - 1, 1]
    lx = px - out[m - 2, 0]
    ly = py - out[m - 2, 1]
    return abs(lx * (y - py) - ly * (x - px)) / norm > PATH_TOLERANCE + EPS


@kernel
def _norm(out, m):  # pragma: no cover - compiled
    """The distance between the last two kept points out[m - 2], out[m - 1]: `_strays`'s
    divisor, computed once per kept point instead of once per test (the same double)."""
    return math.hypot(out[m - 1, 0] - out[m - 2, 0], out[m - 1, 1] - out[m - 2, 1])


@kernel
def _path(x0, y0, xs, ys, reverse, heading, lookahead):  # pragma: no cover - compiled
    """(P, 2) polyline from (x0, y0) through the points (xs[i], ys[i]) (in reverse order when
    `reverse`), simplified (see PATH_SPACING, PATH_TOLERANCE; the last point is kept when it
    moves on by more than 1 cm) and extended straight by `lookahead` metres along the last
    segment, or along `heading` when the points do not move."""
    n = xs.shape[0] + 1
    x = np.empty(n)
    y = np.empty(n)
    x[0] = x0
    y[0] = y0
    for i in range(n - 1):
        j = n - 2 - i if reverse else i
        x[i + 1] = xs[j]
        y[i + 1] = ys[j]
    out = np.empty((n + 1, 2))
    out[0, 0] = x[0]
    out[0, 1] = y[0]
    m = 1
    last = 0  # index of the last kept input point
    norm_m = 0  # the m whose `_norm` is `norm`
    norm = 0.0
    for i in range(1, n):
        if m == 1:
            if math.hypot(x[i] - out[0, 0], y[i] - out[0, 1]) >= PATH_SPACING - EPS:
                out[1, 0] = x[i]
                out[1, 1] = y[i]
                m = 2
                last = i
            continue
        if norm_m != m:
            norm = _norm(out, m)
            norm_m = m
        if _strays(out, m, x[i], y[i], norm) and last < i - 1:
            # point i leaves the line: the point before it ends the straight stretch
            out[m, 0] = x[i - 1]
            out[m, 1] = y[i - 1]
            m += 1
            last = i - 1
            norm = _norm(out, m)
            norm_m = m
        if _strays(out, m, x[i], y[i], norm):
            out[m, 0] = x[i]
            out[m, 1] = y[i]
            m += 1
            last = i
    if last < n - 1 and math.hypot(x[n - 1] - out[m - 1, 0], y[n - 1] - out[m - 1, 1]) > 0.01:
        out[m, 0] = x[n - 1]
        out[m, 1] = y[n - 1]
        m += 1
    if m >= 2:
        dx = out[m - 1, 0] - out[m - 2, 0]
        dy = out[m - 1, 1] - out[m - 2, 1]
        length = math.hypot(dx, dy)
        ux = dx / length
        uy = dy / length
    else:
        ux = math.cos(heading)
        uy = math.sin(heading)
    out[m, 0] = out[m - 1, 0] + lookahead * ux
    out[m, 1] = out[m - 1, 1] + lookahead * uy
    return out[: m + 1]


@kernel
def _shares_lane(x0, y0, heading, px, py, yaw, half_width):  # pragma: no cover - compiled
    """The ego at (x0, y0) heading `heading` and a vehicle ahead at (px, py) heading `yaw`
    drive in one lane: the chord between them is within `half_width` of the direction halfway
    between the two headings. On a bend of any radius that direction is the chord's own (an
    arc's chord halves its turn), so the offset is the lateral one; in a lane change the ego's
    path bends one way and back, and the chord leans across the lane (LEAD_LANE). True
    whenever the headings differ by LEAD_LANE or more."""
    if math.cos(heading - yaw) < LEAD_LANE_COS:
        return True  # a turn between them: the chord says nothing about lanes (see LEAD_LANE)
    mx = math.cos(heading) + math.cos(yaw)
    my = math.sin(heading) + math.sin(yaw)
    norm = math.hypot(mx, my)
    return abs(mx * (py - y0) - my * (px - x0)) / norm <= half_width + EPS


@kernel
def _nearest(
    path, pos, yaw, hl, hw, vel, half_width, ego_half, hold, lane_x, lane_y, lane_heading, lane
):  # pragma: no cover - compiled
    """The object with the smallest gap among those within `half_width` of `path` at positive
    arc length whose velocity across the path keeps it there for `hold` seconds (its signed
    offset from the nearest segment's line plus `hold` times its velocity across it stays
    within `half_width`) and, when `lane`, that drives in one lane with the ego at
    (lane_x, lane_y) heading `lane_heading` (`_shares_lane`): (index or -1, gap, tangent x,
    tangent y). See `neighbour`."""
    best_k = -1
    best_gap = np.inf
    best_ux = 0.0
    best_uy = 0.0
    # per segment: length, unit tangent and arc length at its start, the same for every
    # object (computed once: the same doubles as per object)
    segs = path.shape[0] - 1
    seg = np.empty((max(segs, 0), 4))
    s0 = 0.0
    for j in range(segs):
        dx = path[j + 1, 0] - path[j, 0]
        dy = path[j + 1, 1] - path[j, 1]
        length = math.hypot(dx, dy)
        seg[j, 0] = length
        seg[j, 1] = dx / length
        seg[j, 2] = dy / length
        seg[j, 3] = s0
        s0 += length
    for k in range(pos.shape[0]):
        dist = np.inf
        s_best = 0.0
        ux_best = 0.0
        uy_best = 0.0
        lat_best = 0.0
        for j in range(segs):
            ax = path[j, 0]
            ay = path[j, 1]
            length = seg[j, 0]
            ux = seg[j, 1]
            uy = seg[j, 2]
            along = (pos[k, 0] - ax) * ux + (pos[k, 1] - ay) * uy
            along = min(max(along, 0.0), length)
            d = math.hypot(pos[k, 0] - ax - along * ux, pos[k, 1] - ay - along * uy)
            if d < dist - EPS:  # an equidistant vertex keeps the earlier segment
                dist = d
                s_best = seg[j, 3] + along
                ux_best = ux
                uy_best = uy
                lat_best = ux * (pos[k, 1] - ay) - uy * (pos[k, 0] - ax)
        if dist > half_width + EPS or s_best <= EPS:
            continue
        drift = ux_best * vel[k, 1] - uy_best * vel[k, 0]
        if abs(lat_best + hold * drift) > half_width + EPS:
            continue  # crossing the corridor: passing through, not in the lane (LANE_HOLD)
        if lane and not _shares_lane(
            lane_x, lane_y, lane_heading, pos[k, 0], pos[k, 1], yaw[k], half_width
        ):
            continue  # in the planned path, but not yet in the ego's lane (LEAD_LANE)
        # |cos| and |sin| of the heading against the tangent, the sine from the cross product:
        # sqrt(1 - cos^2) turns a rounding error of 1e-16 in cos into 1e-8 (a rigid motion of
        # the world moved the gap by 7.5e-9 m)
        hx = math.cos(yaw[k])
        hy = math.sin(yaw[k])
        cos = abs(hx * ux_best + hy * uy_best)
        sin = abs(hx * uy_best - hy * ux_best)
        extent = hl[k] * cos + hw[k] * sin
        gap = max(s_best - ego_half - extent, 0.0)
        if gap < best_gap - EPS:
            best_gap = gap
            best_k = k
            best_ux = ux_best
            best_uy = uy_best
    return best_k, best_gap, best_ux, best_uy


def path_ahead(ego: Ego, plan: np.ndarray, lookahead: float) -> np.ndarray:
    """(P, 2) polyline from the ego along its plan, extended straight along the last direction
    to `lookahead` metres; along the ego's heading when the plan does not move."""
    return _path(ego.x, ego.y, plan[:, 1], plan[:, 2], False, float(ego.yaw), float(lookahead))


def path_behind(ego: Ego, history: np.ndarray, lookahead: float) -> np.ndarray:
    """(P, 2) polyline from the ego back along its driven positions `history` (oldest first),
    extended straight backwards to `lookahead` metres; straight back along its heading when
    it has not moved."""
    return _path(
        ego.x, ego.y, history[:, 0], history[:, 1], True, float(ego.yaw) + math.pi, float(lookahead)
    )


@kernel
def _in_own_lane(
    x0, y0, heading, ego_half, ego_hw, pos, yaw, hl, half_width, lookahead
):  # pragma: no cover - compiled
    """The nearest object behind the ego whose own lane holds the ego: the ego's centre lies
    ahead of it, within `half_width` of the line along its heading, and the two head less
    than FOLLOW_ALIGN apart. (index or -1, gap, and the unit vector from the ego towards it,
    the direction of the path behind.) The gap is the ego's centre ahead of the object along
    its heading, less its half length and the ego's box projected on that heading."""
    best_k = -1
    best_gap = np.inf
    best_ux = 0.0
    best_uy = 0.0
    ex = math.cos(heading)
    ey = math.sin(heading)
    align = math.cos(FOLLOW_ALIGN)
    for k in range(pos.shape[0]):
        hx = math.cos(yaw[k])
        hy = math.sin(yaw[k])
        cos = hx * ex + hy * ey
        if cos < align:
            continue
        dx = x0 - pos[k, 0]
        dy = y0 - pos[k, 1]
        ahead = dx * hx + dy * hy
        if ahead <= EPS or ahead > lookahead or abs(hx * dy - hy * dx) > half_width + EPS:
            continue
        sin = abs(hx * ey - hy * ex)
        gap = max(ahead - hl[k] - (ego_half * cos + ego_hw * sin), 0.0)
        if gap < best_gap - EPS:
            best_gap = gap
            best_k = k
            best_ux = -hx
            best_uy = -hy
    return best_k, best_gap, best_ux, best_uy


@kernel
def _neighbours(
    x0,
    y0,
    heading,
    plan_x,
    plan_y,
    driven_x,
    driven_y,
    behind,
    pos,
    yaw,
    hl,
    hw,
    vel,
    half_width,
    ego_half,
    ego_hw,
    lookahead,
):  # pragma: no cover - compiled
    """Leader along the plan and (when `behind`) follower in one call: (lead gap, lead speed
    along the path, 1.0 if there is a leader, and the same three for the follower). The
    follower is the nearer of the one along the driven path and the one whose own lane holds
    the ego (`_in_own_lane`). See `neighbour`."""
    out = np.zeros(6)
    _neighbours_into(
        out,
        x0,
        y0,
        heading,
        plan_x,
        plan_y,
        driven_x,
        driven_y,
        behind,
        pos,
        yaw,
        hl,
        hw,
        vel,
        half_width,
        ego_half,
        ego_hw,
        lookahead,
    )
    return out


@kernel
def _neighbours_into(
    out,
    x0,
    y0,
    heading,
    plan_x,
    plan_y,
    driven_x,
    driven_y,
    behind,
    pos,
    yaw,
    hl,
    hw,
    vel,
    half_width,
    ego_half,
    ego_hw,
    lookahead,
):  # pragma: no cover - compiled
    """`_neighbours` into `out` (6,), which must hold zeros: the tick kernel's scratch."""
    out[0] = out[3] = GAP_CAP
    path = _path(x0, y0, plan_x, plan_y, False, heading, lookahead)
    k, gap, ux, uy = _nearest(
        path, pos, yaw, hl, hw, vel, half_width, ego_half, LANE_HOLD, x0, y0, heading, True
    )
    if k >= 0:
        out[0] = min(gap, GAP_CAP)
        out[1] = vel[k, 0] * ux + vel[k, 1] * uy
        out[2] = 1.0
    if behind:
        path = _path(x0, y0, driven_x, driven_y, True, heading + math.pi, lookahead)
        k, gap, ux, uy = _nearest(
            path, pos, yaw, hl, hw, vel, half_width, ego_half, LANE_HOLD, x0, y0, heading, False
        )
        k2, gap2, ux2, uy2 = _in_own_lane(
            x0, y0, heading, ego_half, ego_hw, pos, yaw, hl, half_width, lookahead
        )
        if k2 >= 0 and (k < 0 or gap2 < gap - EPS):
            k, gap, ux, uy = k2, gap2, ux2, uy2
        if k >= 0:
            out[3] = min(gap, GAP_CAP)
            out[4] = vel[k, 0] * ux + vel[k, 1] * uy
            out[5] = 1.0


@kernel
def _box_extents(half):  # pragma: no cover - compiled
    """The two columns of `half` (K, 2) as contiguous copies, and whether every row is a box
    (no NaN half length): `_half_extents`'s common case in one call."""
    k = half.shape[0]
    hl = np.empty(k)
    hw = np.empty(k)
    boxes = True
    for i in range(k):
        hl[i] = half[i, 0]
        hw[i] = half[i, 1]
        if math.isnan(half[i, 0]):
            boxes = False
    return hl, hw, boxes


def _half_extents(objects: Objects) -> tuple[np.ndarray, np.ndarray]:
    """(K,) half length and half width per object; a polygon footprint counts as the circle
    around it (its bounding radius both ways)."""
    half = objects.half
    hl, hw, boxes = _box_extents(half)
    if boxes:
        # contiguous, as np.where's below: one compiled variant of the kernels that read them
        return hl, hw
    box = ~np.isnan(half[:, 0])
    radii = objects.radii
    return np.where(box, half[:, 0], radii), np.where(box, half[:, 1], radii)


def neighbours(
    ego: Ego,
    plan: np.ndarray,
    driven: np.ndarray | None,
    objects: Objects,
    half_width: float,
    ego_half: float,
    lookahead: float,
) -> tuple[Neighbour, Neighbour | None]:
    """The leader along `plan` and, when `driven` (the ego's earlier positions, oldest first)
    is given, the follower (along that path, or in whose own lane the ego drives): one
    compiled call for both."""
    if len(objects) == 0:
        return NONE, (None if driven is None else NONE)
    hl, hw = _half_extents(objects)
    d = driven if driven is not None else _NO_POINTS
    ego_hw = ego_half_width(ego)
    v = _neighbours(
        ego.x,
        ego.y,
        float(ego.yaw),
        # contiguous columns: one compiled variant whatever the plan's length (a column of
        # one row is contiguous, of more is not; each layout would compile on its own)
        np.ascontiguousarray(plan[:, 1]),
        np.ascontiguousarray(plan[:, 2]),
        np.ascontiguousarray(d[:, 0]),
        np.ascontiguousarray(d[:, 1]),
        driven is not None,
        objects.pos,
        objects.yaw,
        hl,
        hw,
        objects.vel,
        float(half_width),
        float(ego_half),
        ego_hw,
        float(lookahead),
    )
    lead_gap, lead_speed, lead_there, gap, speed, there = v.tolist()  # Python floats at once
    lead = Neighbour(lead_gap, lead_speed, bool(lead_there))
    if driven is None:
        return lead, None
    return lead, Neighbour(gap, speed, bool(there))


_NO_POINTS = np.zeros((0, 2))


def project(path: np.ndarray, pos: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Project points (K, 2) onto a polyline (P, 2): arc length s (K,) of the nearest point,
    its distance d (K,), and the unit tangent (K, 2) of that segment (numpy; the reference
    the compiled `_nearest` is tested against)."""
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
    """The nearest object within `half_width` of `path` (from the ego outwards) that stays
    there for LANE_HOLD: the gap from the ego's bumper to the object's near side along the
    path (its box projected on the path's tangent), and the object's speed along the path
    (positive: moving the path's way, away from the ego). One compiled call over every object
    and path segment. The geometry alone: the engine's leader (`neighbours`) also asks that
    the car share the ego's lane, and its follower may be found in the car's own lane."""
    if len(objects) == 0:
        return NONE
    hl, hw = _half_extents(objects)
    k, gap, ux, uy = _nearest(
        path,
        objects.pos,
        objects.yaw,
        hl,
        hw,
        objects.vel,
        float(half_width),
        float(ego_half_length),
        LANE_HOLD,
        ego.x,
        ego.y,
        float(ego.yaw),
        False,
    )
    if k < 0:
        return NONE
    speed = float(objects.vel[k, 0] * ux + objects.vel[k, 1] * uy)
    return Neighbour(min(gap, GAP_CAP), speed, True)


@kernel
def _slope(t, v, span):  # pragma: no cover - compiled
    """Least-squares slope of v over the samples of the last `span` seconds (t ascending);
    NaN before half the span is covered by three samples."""
    n = t.shape[0]
    first = 0
    while first < n and t[first] < t[n - 1] - span - 1e-9:
        first += 1
    if n - first < 3 or t[n - 1] - t[first] < 0.5 * span - 1e-9:
        return math.nan
    tm = 0.0
    vm = 0.0
    for i in range(first, n):
        tm += t[i]
        vm += v[i]
    tm /= n - first
    vm /= n - first
    num = 0.0
    den = 0.0
    for i in range(first, n):
        num += (t[i] - tm) * (v[i] - vm)
        den += (t[i] - tm) * (t[i] - tm)
    return num / den


def acceleration(times: np.ndarray, speeds: np.ndarray, span: float = 1.0) -> float | None:
    """`ego_accel`: the least-squares slope of the reported speeds of the last `span` seconds
    (times ascending, the last is now); None before half the span is covered by 3 samples."""
    value = _slope(times, speeds, float(span))
    return None if math.isnan(value) else float(value)


def headway(gap: float, speed: float) -> float:
    """Time headway [s]: gap over the speed of the vehicle behind; TIME_CAP when it stands."""
    return TIME_CAP if speed < STANDING else min(gap / speed, TIME_CAP)


def time_to_collision(gap: float, closing: float) -> float:
    """TTC [s]: gap over the closing speed; TIME_CAP when the two are not closing in."""
    return TIME_CAP if closing <= 1e-3 else min(gap / closing, TIME_CAP)


def ego_half_width(ego: Ego) -> float:
    """Half the ego's width: the footprint's largest extent sideways. A box's is its half
    width (`Ego.half`: its footprint's corners are (+-hl, +-hw)), without an array call."""
    if ego.half is not None:
        return abs(ego.half[1])
    return float(np.max(np.abs(ego.footprint[:, 1])))


def ego_half_length(ego: Ego) -> float:
    """Half the ego's length along its heading (box, or the footprint's extent forward)."""
    if ego.half is not None:
        return ego.half[0]
    return float(np.max(np.abs(ego.footprint[:, 0])))


#: The per-channel values of `situation_tick`, in the order of its output rows (the
#: catalogue's, `safety_case.signals.SITUATION_METRICS`; a test holds them equal).
TICK_METRICS = (
    "lead_gap",
    "lead_thw",
    "lead_ttc",
    "lead_speed",
    "follow_gap",
    "follow_thw",
    "follow_ttc",
    "follow_speed",
    "ego_speed",
    "ego_accel",
)
#: Rows of TICK_METRICS: the follower's four (worst over the channels that see behind), and
#: the two whose worst is the largest (`safety_case.signals.WORST_IS_MAX`).
_FOLLOW_FIRST = 4
_FOLLOW_LAST = 7
_MAX_ROWS = (7, 8)
_ROWS = len(TICK_METRICS)


@kernel
def push_row(buf, start, end, i, t, a, b, span, max_gap):  # pragma: no cover - compiled
    """`PoseWindow.push(t, a, b)` (the reference in tests/monitor/reference_windows.py) on
    window i of `family.PoseWindows` (rows buf[i, start[i]:end[i]]): the same rows kept, the
    same tests. The caller keeps a free row
    (`PoseWindows.make_room`); returns the window's rows after the push."""
    s = start[i]
    e = end[i]
    if e > s and t - buf[i, e - 1, 0] > max_gap + 1e-9:
        s = 0
        e = 0
    if e == buf.shape[1]:  # move the live rows to the front (there is room: make_room)
        live = e - s
        for r in range(live):
            buf[i, r, 0] = buf[i, s + r, 0]
            buf[i, r, 1] = buf[i, s + r, 1]
            buf[i, r, 2] = buf[i, s + r, 2]
        s = 0
        e = live
        if e == buf.shape[1]:
            raise IndexError("a full window: PoseWindows.make_room was not called")
    buf[i, e, 0] = t
    buf[i, e, 1] = a
    buf[i, e, 2] = b
    e += 1
    limit = t - span + 1e-9
    while e - s > 1 and buf[i, s + 1, 0] <= limit:
        s += 1
    start[i] = s
    end[i] = e
    return e - s


@kernel
def _headway(gap, speed):  # pragma: no cover - compiled
    """`headway`, to the bit (Python's `min(a, b)` is `b if b < a else a`)."""
    if speed < STANDING:
        return TIME_CAP
    r = gap / speed
    return TIME_CAP if r > TIME_CAP else r


@kernel
def _ttc(gap, closing):  # pragma: no cover - compiled
    """`time_to_collision`, to the bit."""
    if closing <= 1e-3:
        return TIME_CAP
    r = gap / closing
    return TIME_CAP if r > TIME_CAP else r


@kernel
def situation_tick(
    t,
    chans,
    driven,
    d_start,
    d_end,
    speeds,
    s_start,
    s_end,
    half_width,
    lookahead,
    max_gap,
    all_seeing,
    vals,
    nones,
):  # pragma: no cover - compiled
    """Every situation signal of one tick in one call (issue 36: the family's glue was most of
    its cost): per channel the TICK_METRICS rows `vals[10 i: 10 i + 10]`, then their worst
    over the channels `vals[10 n:]`, as `families.situation` computed them with `neighbours`,
    `headway`, `time_to_collision`, `acceleration` and `family.worst`.

    `chans[i]` is (present, sees behind, x, y, yaw, speed, half length, half width, plan,
    pos, yaw, half, vel, radii) of channel i (`radii`: the objects' bounding radii, or empty
    when their footprints are all boxes). `driven` is the comfort family's windows of ego
    positions (the path driven: every row but the newest), `speeds` this family's windows of
    (t, reported speed, 0) for ego_accel, pushed here. A value with no value is NaN in `vals`
    and its row is listed in `nones`. Returns (bit mask of the rows with no value, or -1 when
    there are more than 62 rows, their count, the most rows in a speed window), or (-2, 0, 0)
    before changing anything when a channel has polygon footprints and no `radii`."""
    nc = len(chans)
    for i in range(nc):
        ch = chans[i]
        half = ch[11]
        if ch[0] and ch[13].shape[0] != half.shape[0]:
            for k in range(half.shape[0]):
                if math.isnan(half[k, 0]):
                    return -2, 0, 0
    rows = _ROWS * (nc + 1)
    none = np.zeros(rows, dtype=np.bool_)
    six = np.zeros(6)
    live = 0
    for i in range(nc):
        ch = chans[i]
        base = _ROWS * i
        if not ch[0]:
            for m in range(_ROWS):
                none[base + m] = True
            continue
        behind = ch[1]
        x0 = ch[2]
        y0 = ch[3]
        heading = ch[4]
        speed = ch[5]
        plan = ch[8]
        pos = ch[9]
        half = ch[11]
        radii = ch[13]
        k = pos.shape[0]
        for m in range(6):
            six[m] = 0.0
        if k == 0:  # `neighbours`: NONE for both
            six[0] = GAP_CAP
            six[3] = GAP_CAP
        else:
            ext = half  # `_half_extents`: boxes read in place, a polygon as its circle
            if radii.shape[0] == k:
                ext = half.copy()
                for r in range(k):
                    if math.isnan(half[r, 0]):
                        ext[r, 0] = radii[r]
                        ext[r, 1] = radii[r]
            hl = ext[:, 0]
            hw = ext[:, 1]
            ds = d_start[i]
            de = d_end[i] - 1
            if not behind:
                de = ds
            _neighbours_into(
                six,
                x0,
                y0,
                heading,
                plan[:, 1],
                plan[:, 2],
                driven[i, ds:de, 1],
                driven[i, ds:de, 2],
                behind,
                pos,
                ch[10],
                hl,
                hw,
                ch[12],
                half_width,
                ch[6],
                ch[7],
                lookahead,
            )
        lead_gap = six[0]
        lead_speed = six[1]
        vals[base] = lead_gap
        vals[base + 8] = speed
        if six[2] != 0.0:
            vals[base + 3] = lead_speed
            vals[base + 1] = _headway(lead_gap, speed)
            vals[base + 2] = _ttc(lead_gap, speed - lead_speed)
        else:
            vals[base + 3] = 0.0
            vals[base + 1] = TIME_CAP
            vals[base + 2] = TIME_CAP
        if behind:
            gap = six[3]
            towards = -six[4]
            if towards < 0.0:  # Python's max(towards, 0.0), -0.0 kept
                towards = 0.0
            vals[base + 4] = gap
            vals[base + 7] = towards
            if six[5] != 0.0:
                vals[base + 5] = _headway(gap, towards)
                vals[base + 6] = _ttc(gap, towards - speed)
            else:
                vals[base + 5] = TIME_CAP
                vals[base + 6] = TIME_CAP
        else:
            for m in range(_FOLLOW_FIRST, _FOLLOW_LAST + 1):
                none[base + m] = True
        n = push_row(speeds, s_start, s_end, i, t, speed, 0.0, 1.0, max_gap)
        if n > live:
            live = n
        s0 = s_start[i]
        s1 = s_end[i]
        accel = _slope(speeds[i, s0:s1, 0], speeds[i, s0:s1, 1], 1.0)
        vals[base + 9] = accel
        if math.isnan(accel):
            none[base + 9] = True
    # the worst over the channels (`family.worst`): no value when any has none
    top = _ROWS * nc
    for m in range(_ROWS):
        behind_only = not all_seeing and _FOLLOW_FIRST <= m <= _FOLLOW_LAST
        use_max = m == _MAX_ROWS[0] or m == _MAX_ROWS[1]
        seen = 0
        missing = False
        best = 0.0
        for i in range(nc):
            if behind_only and not chans[i][1]:
                continue
            if none[_ROWS * i + m]:
                missing = True
                break
            v = vals[_ROWS * i + m]
            if seen == 0 or (v > best if use_max else v < best):
                best = v
            seen += 1
        if missing or seen == 0:
            none[top + m] = True
        else:
            vals[top + m] = best
    count = 0
    mask = 0
    for r in range(rows):
        if none[r]:
            vals[r] = math.nan
            nones[count] = r
            count += 1
            if rows <= 62:
                mask |= 1 << r
    return (mask if rows <= 62 else -1), count, live
