"""The discrete Fréchet distance as its source defines it, for many pairs of polylines at once.

Definition (spi-reference "Discrete Fréchet distance"; the two-channel SPI study, source 000,
section 4.1 "Discrete Fréchet Distance", after Eiter and Mannila 1994): with `d(i, j)` the
distance between point i of P and point j of Q, the coupling cost is

    c(0, 0) = d(0, 0)
    c(i, j) = max(d(i, j), min(c(i-1, j), c(i, j-1), c(i-1, j-1)))   (out-of-range terms: inf)

and `fd(P, Q) = c(n-1, m-1)`: "the least-cost path through this matrix, which connects the
beginning of both curves to their ends while minimising the maximum distance".

Why not `shapely.frechet_distance`, which spi-reference names: GEOS 3.14 (shapely 2.2) does not
always return that minimum: 17 of 3 000 pairs of random walks of 2-6 points, and 175 of 2 000
of 2-39 points, get a larger value (6 x 3 points: 3.0504 where the best coupling costs 2.2308;
a test keeps that case), so
the library would make crpps and chpps differ from the source they cite. This kernel is the
recurrence above, one row at a time. Every value it returns is one of the `d(i, j)`, computed
as GEOS computes a point distance (`sqrt(dx * dx + dy * dy)`), so wherever GEOS finds the
minimum the two agree bit for bit: they did on all 168 502 distances the six bundled drives
need. It is also faster: 0.07 ms per frame at the reference load (21 pairs of 50-point
plans) where GEOS took about 0.30 with its linestrings, and 0.085 ms against 6.1 ms on 21
pairs of 50-point random walks.

Most cells need not be visited, and which ones can be skipped is decided exactly (`_bounds`,
`_banded_cost`), never by approximation. Any coupling's cost is an upper bound U of the
distance, and every coupling pairs the first points and the last points, so
L = max(d(0, 0), d(n-1, m-1)) is a lower bound. The engine's pairs are paths resampled to the
same number of points, for which the diagonal coupling (i with i) is the natural one: on the
six bundled drives its cost equals L in 91 % of the pairs, and then the distance is U with no
programme at all (n point distances instead of n x m). Otherwise the programme runs only over
the cells whose cost can be at most U (a cell of larger cost lies on no optimal coupling, so
treating it as out of range, inf, changes no cell on one; the proof is at `_banded_cost`):
about 17 % of the cells on those drives. Both shortcuts rest on comparisons being an order,
which NaN breaks: a pair with a coordinate that is not finite takes the full programme
(`_coupling_cost`), so it too gets the value the full programme gives. The full programme
stays the reference the tests hold the shortcuts to, value for value.
"""

from __future__ import annotations

import numpy as np

from casewatch.monitor.jit import kernel


@kernel
def _coupling_cost(coords, start_p, n_p, start_q, n_q, row):  # pragma: no cover - compiled
    """c(n_p - 1, n_q - 1) of P = coords[start_p:start_p + n_p], Q likewise, with `row` (at
    least n_q long) as the dynamic programme's one row of memory.

    The programme runs on squared distances and takes one square root at the end: max and min
    commute with any non-decreasing function, so sqrt(c over d^2) is c over sqrt(d^2), the same
    double (each d is `sqrt(dx * dx + dy * dy)` either way), without a root per cell."""
    # row 0: P's first point against Q's prefix
    px = coords[start_p, 0]
    py = coords[start_p, 1]
    left = 0.0
    for j in range(n_q):
        dx = px - coords[start_q + j, 0]
        dy = py - coords[start_q + j, 1]
        d = dx * dx + dy * dy
        left = d if j == 0 else max(left, d)
        row[j] = left
    for i in range(1, n_p):
        px = coords[start_p + i, 0]
        py = coords[start_p + i, 1]
        dx = px - coords[start_q, 0]
        dy = py - coords[start_q, 1]
        diag = row[0]  # c(i-1, 0)
        left = max(diag, dx * dx + dy * dy)  # c(i, 0)
        row[0] = left
        for j in range(1, n_q):
            dx = px - coords[start_q + j, 0]
            dy = py - coords[start_q + j, 1]
            up = row[j]  # c(i-1, j), still in the row
            left = max(min(up, left, diag), dx * dx + dy * dy)
            diag = up
            row[j] = left
    return np.sqrt(row[n_q - 1])


@kernel
def _bounds(coords, start_p, start_q, n):  # pragma: no cover - compiled
    """(U, L, finite) of two lines of n points each, on squared distances: U the cost of the
    diagonal coupling (point i with point i), L = max(d(0, 0), d(n-1, n-1)), finite: every
    coordinate of both lines is a finite number (each d computed as `_coupling_cost` does)."""
    finite = True
    top = 0.0
    for i in range(n):
        px = coords[start_p + i, 0]
        py = coords[start_p + i, 1]
        qx = coords[start_q + i, 0]
        qy = coords[start_q + i, 1]
        # x - x is 0.0 exactly for a finite x and NaN for inf or NaN
        if not (px - px == 0.0 and py - py == 0.0 and qx - qx == 0.0 and qy - qy == 0.0):
            finite = False
        dx = px - qx
        dy = py - qy
        d = dx * dx + dy * dy
        if d > top:
            top = d
    dx = coords[start_p, 0] - coords[start_q, 0]
    dy = coords[start_p, 1] - coords[start_q, 1]
    first = dx * dx + dy * dy
    dx = coords[start_p + n - 1, 0] - coords[start_q + n - 1, 0]
    dy = coords[start_p + n - 1, 1] - coords[start_q + n - 1, 1]
    last = dx * dx + dy * dy
    return top, max(first, last), finite


@kernel
def _greedy_bound(coords, start_p, n_p, start_q, n_q):  # pragma: no cover - compiled
    """(U, finite) for lines of different lengths: U the cost (squared) of the coupling that
    steps each time to the nearest of its three successors, finite as in `_bounds`."""
    finite = True
    for k in range(n_p):
        x = coords[start_p + k, 0]
        y = coords[start_p + k, 1]
        if not (x - x == 0.0 and y - y == 0.0):
            finite = False
    for k in range(n_q):
        x = coords[start_q + k, 0]
        y = coords[start_q + k, 1]
        if not (x - x == 0.0 and y - y == 0.0):
            finite = False
    i = 0
    j = 0
    dx = coords[start_p, 0] - coords[start_q, 0]
    dy = coords[start_p, 1] - coords[start_q, 1]
    top = dx * dx + dy * dy
    while i < n_p - 1 or j < n_q - 1:
        if i == n_p - 1:
            j += 1
        elif j == n_q - 1:
            i += 1
        else:
            dx = coords[start_p + i + 1, 0] - coords[start_q + j + 1, 0]
            dy = coords[start_p + i + 1, 1] - coords[start_q + j + 1, 1]
            both = dx * dx + dy * dy
            dx = coords[start_p + i + 1, 0] - coords[start_q + j, 0]
            dy = coords[start_p + i + 1, 1] - coords[start_q + j, 1]
            along_p = dx * dx + dy * dy
            dx = coords[start_p + i, 0] - coords[start_q + j + 1, 0]
            dy = coords[start_p + i, 1] - coords[start_q + j + 1, 1]
            along_q = dx * dx + dy * dy
            if both <= along_p and both <= along_q:
                i += 1
                j += 1
            elif along_p <= along_q:
                i += 1
            else:
                j += 1
        dx = coords[start_p + i, 0] - coords[start_q + j, 0]
        dy = coords[start_p + i, 1] - coords[start_q + j, 1]
        d = dx * dx + dy * dy
        if d > top:
            top = d
    return top, finite


@kernel
def _banded_cost(coords, start_p, n_p, start_q, n_q, bound, row):  # pragma: no cover
    """c(n_p - 1, n_q - 1) squared, as `_coupling_cost` computes it before its root, visiting
    only the cells whose cost can be at most `bound` (U: the cost of some coupling, so at least
    the distance; finite coordinates).

    Why it is exact. Call a cell alive when its cost c <= U. Each row is computed over
    [lo, hi + 1] of the previous row's alive cells [lo, hi], then onwards while the cell to
    the left stays alive; a cell outside that range is read as inf. (1) Every alive cell is
    visited: it has an alive predecessor (its c is the max of its d and its cheapest
    predecessor's c), which is above it in [lo, hi] (then it lies in [lo, hi + 1]) or to its
    left in its own row. (2) A visited cell's computed value is never below its true c (inf
    stands only for cells whose c is above U, and max and min are monotone), and equals it
    when the cell is alive: its cheapest predecessor is alive, hence visited and exact, and the
    others read at least their true c, so the min picks the same value. The last cell is
    alive (c = the distance <= U), so its value is exact. max and min select one of their
    operands, so "the same value" is the same double."""
    inf = np.inf
    px = coords[start_p, 0]
    py = coords[start_p, 1]
    left = 0.0
    hi = -1
    for j in range(n_q):  # row 0: only the left neighbour, so its alive cells are a prefix
        dx = px - coords[start_q + j, 0]
        dy = py - coords[start_q + j, 1]
        d = dx * dx + dy * dy
        left = d if j == 0 else max(left, d)
        if left > bound:
            break
        row[j] = left
        hi = j
    lo = 0
    for i in range(1, n_p):
        px = coords[start_p + i, 0]
        py = coords[start_p + i, 1]
        new_lo = n_q
        new_hi = -1
        j = lo
        left = inf  # cells (i, lo - 1) and (i - 1, lo - 1) are not alive
        diag = inf
        if j == 0:
            dx = px - coords[start_q, 0]
            dy = py - coords[start_q, 1]
            diag = row[0]
            left = max(diag, dx * dx + dy * dy)
            row[0] = left
            if left <= bound:
                new_lo = 0
                new_hi = 0
            j = 1
        while j <= hi:  # above: the previous row's visited cells
            dx = px - coords[start_q + j, 0]
            dy = py - coords[start_q + j, 1]
            up = row[j]
            left = max(min(up, left, diag), dx * dx + dy * dy)
            diag = up
            row[j] = left
            if left <= bound:
                if new_lo > j:
                    new_lo = j
                new_hi = j
            j += 1
        while j < n_q:  # above: not alive; on while the left neighbour is
            dx = px - coords[start_q + j, 0]
            dy = py - coords[start_q + j, 1]
            left = max(min(inf, left, diag), dx * dx + dy * dy)
            diag = inf
            row[j] = left
            if left > bound:
                break
            if new_lo > j:
                new_lo = j
            new_hi = j
            j += 1
        if new_hi < 0:
            return inf  # no alive cell: `bound` was below the distance (not for a coupling's)
        lo = new_lo
        hi = new_hi
    return row[n_q - 1]


@kernel
def _pair_distance(coords, sp, n_p, sq, n_q, row):  # pragma: no cover - compiled
    """fd of coords[sp:sp + n_p] and coords[sq:sq + n_q] (see `_pair_distances`)."""
    if n_p == n_q:
        bound, low, finite = _bounds(coords, sp, sq, n_p)
        if finite and bound == low:
            return np.sqrt(bound)
    else:
        bound, finite = _greedy_bound(coords, sp, n_p, sq, n_q)
    if not finite:
        return _coupling_cost(coords, sp, n_p, sq, n_q, row)
    return np.sqrt(_banded_cost(coords, sp, n_p, sq, n_q, bound, row))


@kernel
def _line_starts(index, n_lines):  # pragma: no cover - compiled
    """Where each line starts in `coords` when point k belongs to line `index[k]` (`index`
    non-decreasing): starts[g] .. starts[g + 1] are line g's points, the layout
    `pair_distances_into` reads."""
    starts = np.zeros(n_lines + 1, dtype=np.int64)
    for k in range(len(index)):
        starts[index[k] + 1] += 1
    for k in range(n_lines):
        starts[k + 1] += starts[k]
    return starts


@kernel
def _pair_distances(coords, index, n_lines):  # pragma: no cover - compiled
    """fd of lines (0, 1), (2, 3), ...: line k is the points of `coords` whose `index` is k
    (`index` non-decreasing, every line non-empty). Each pair: the bounds first, the distance
    without a programme when they meet, else the programme over the cells they leave
    (`_banded_cost`), the full one for a coordinate that is not finite."""
    out = np.empty(n_lines // 2)
    pair_distances_into(coords, _line_starts(index, n_lines), n_lines // 2, out)
    return out


@kernel
def pair_distances_into(coords, starts, n_pairs, out):  # pragma: no cover - compiled
    """`_pair_distances` with the lines given by where they start: pair m is lines 2m and
    2m + 1, line g is coords[starts[g]:starts[g + 1]] (non-empty); fd of pair m into out[m].
    The layout `history._tick_cut` writes, so a tick's distances are one call with nothing
    built around it."""
    widest = 0
    for g in range(2 * n_pairs):
        widest = max(widest, starts[g + 1] - starts[g])
    row = np.empty(widest)
    for pair in range(n_pairs):
        sp = starts[2 * pair]
        sq = starts[2 * pair + 1]
        out[pair] = _pair_distance(coords, sp, sq - sp, sq, starts[2 * pair + 2] - sq, row)


@kernel
def _full_pair_distances(coords, index, n_lines):  # pragma: no cover - compiled
    """`_pair_distances` by the full programme for every pair (`_coupling_cost`): the
    reference the tests hold the shortcuts to."""
    starts = _line_starts(index, n_lines)
    widest = 0
    for k in range(n_lines):
        widest = max(widest, starts[k + 1] - starts[k])
    row = np.empty(widest)
    out = np.empty(n_lines // 2)
    for pair in range(n_lines // 2):
        p, q = 2 * pair, 2 * pair + 1
        out[pair] = _coupling_cost(
            coords, starts[p], starts[p + 1] - starts[p], starts[q], starts[q + 1] - starts[q], row
        )
    return out


def frechet_pairs(coords: np.ndarray, index: np.ndarray) -> np.ndarray:
    """The discrete Fréchet distance of each pair of polylines (line 2k against line 2k + 1).

    `coords` (N, 2) holds every line's points, line after line; `index` (N,) names the line of
    each point, non-decreasing from 0 (the layout `shapely.linestrings(coords, indices=index)`
    takes). Every line must have at least one point and the number of lines must be even."""
    if len(index) == 0:
        return np.zeros(0)
    n_lines = int(index[-1]) + 1
    if n_lines % 2 or len(coords) != len(index):
        raise ValueError(
            f"frechet_pairs needs pairs of lines and one index per point: {n_lines} lines, "
            f"{len(coords)} points, {len(index)} indices"
        )
    return _pair_distances(
        np.ascontiguousarray(coords, dtype=np.float64),
        np.ascontiguousarray(index, dtype=np.int64),
        n_lines,
    )


def frechet_distance(p: np.ndarray, q: np.ndarray) -> float:
    """The discrete Fréchet distance of two point sequences (k, 2+) (x, y in the first two
    columns), each of at least one point."""
    if len(p) == 0 or len(q) == 0:
        raise ValueError("the discrete Fréchet distance needs at least one point on each side")
    coords = np.concatenate([np.asarray(p, dtype=np.float64)[:, :2], np.asarray(q)[:, :2]])
    index = np.repeat(np.array([0, 1], dtype=np.int64), [len(p), len(q)])
    return float(frechet_pairs(coords, index)[0])
