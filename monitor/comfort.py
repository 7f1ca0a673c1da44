"""Comfort scores: hcs (driven ego history) and ppcs (current plan).

spi-reference Decision (documented in docs/spi-reference.md): velocity and acceleration are
differentiated in the world frame and the *acceleration* is rotated into the vehicle frame.
Rotating the velocity first and differentiating its components, the literal reading, loses the
centripetal term: for a plan (heading = path tangent) the lateral velocity is zero by
construction, so a_lat would always be 0.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from monitor.jit import kernel

#: Minimum samples: positions -> velocity -> acceleration -> jerk needs four.
MIN_POINTS = 4


def nv(s: np.ndarray | float, steepness: float) -> np.ndarray | float:
    """spi-reference Decision: symmetric NV(s) = 2 / (1 + exp(-w |s|)) - 1, in [0, 1)."""
    return 2.0 / (1.0 + np.exp(-steepness * np.abs(s))) - 1.0


@kernel
def _peak_abs_update(peak: float, v: float) -> float:
    """max(peak, |v|) with NaN sticking, as in `np.max`."""
    if math.isnan(peak) or math.isnan(v):
        return math.nan
    return max(peak, abs(v))


@kernel
def _comfort_kernel(
    times: np.ndarray, xy: np.ndarray, yaw: np.ndarray, has_yaw: bool, steepness: float
) -> float:
    """The comfort score of one series of n >= 4 samples (see `comfort_score`).

    Velocities at the midpoints, accelerations centred on samples 1 .. n-2 (differentiated in
    the world frame, then rotated onto the heading), jerk between those; peaks of |.|.
    """
    n = times.shape[0]
    pa_lon = 0.0
    pa_lat = 0.0
    pj_lon = 0.0
    prev_lon = 0.0
    for i in range(n - 2):
        # acceleration centred on sample c = i + 1
        dt0 = times[i + 1] - times[i]
        dt1 = times[i + 2] - times[i + 1]
        v0x = (xy[i + 1, 0] - xy[i, 0]) / dt0
        v0y = (xy[i + 1, 1] - xy[i, 1]) / dt0
        v1x = (xy[i + 2, 0] - xy[i + 1, 0]) / dt1
        v1y = (xy[i + 2, 1] - xy[i + 1, 1]) / dt1
        dtm = 0.5 * (times[i + 2] + times[i + 1]) - 0.5 * (times[i + 1] + times[i])
        ax = (v1x - v0x) / dtm
        ay = (v1y - v0y) / dtm
        if has_yaw:
            ux = math.cos(yaw[i + 1])
            uy = math.sin(yaw[i + 1])
            a_lon = ax * ux + ay * uy
            a_lat = -ax * uy + ay * ux
        else:
            # Path tangent at the sample: the chord from the previous to the next sample.
            cx = xy[i + 2, 0] - xy[i, 0]
            cy = xy[i + 2, 1] - xy[i, 1]
            norm = math.hypot(cx, cy)
            if norm > 1e-12:
                ux = cx / norm
                uy = cy / norm
                a_lon = ax * ux + ay * uy
                a_lat = -ax * uy + ay * ux
            else:
                # Decision: where the tangent is undefined (no motion), the whole acceleration
                # counts as longitudinal; this keeps the score invariant under rotations.
                a_lon = math.hypot(ax, ay)
                a_lat = 0.0
        pa_lon = _peak_abs_update(pa_lon, a_lon)
        pa_lat = _peak_abs_update(pa_lat, a_lat)
        if i > 0:
            # jerk between the accelerations at samples i and i + 1
            pj_lon = _peak_abs_update(pj_lon, (a_lon - prev_lon) / dt0)
        prev_lon = a_lon
    v_lon = 2.0 / (1.0 + math.exp(-steepness * abs(pa_lon))) - 1.0
    v_lat = 2.0 / (1.0 + math.exp(-steepness * abs(pa_lat))) - 1.0
    v_jerk = 2.0 / (1.0 + math.exp(-steepness * abs(pj_lon))) - 1.0
    return 1.0 - ((v_lon + v_lat) / 2 + v_jerk) / 2


def comfort_score(
    times: np.ndarray, xy: np.ndarray, yaw: np.ndarray | None, steepness: float
) -> float | None:
    """1 - ((NV(a_lon) + NV(a_lat)) / 2 + NV(j_lon)) / 2 from positions (n, 2) at `times` (n,).

    `yaw` (n,) gives the vehicle heading at each sample; None takes the path tangent (plans).
    None when fewer than four samples.
    """
    if len(times) < MIN_POINTS:
        return None
    # without a heading, `times` stands in for the (unread) yaw argument
    return _comfort_kernel(
        times, xy, times if yaw is None else yaw, yaw is not None, float(steepness)
    )


def comfort_scores(
    series: Sequence[tuple[np.ndarray, np.ndarray, np.ndarray | None]], steepness: float
) -> list[float | None]:
    """`comfort_score` of many (times, xy, yaw-or-None) series (hcs and ppcs of every channel).

    One kernel call per series: a call costs about a microsecond, less than packing the
    series into one padded array would.
    """
    w = float(steepness)
    return [
        None
        if len(t) < MIN_POINTS
        else _comfort_kernel(t, xy, t if yaw is None else yaw, yaw is not None, w)
        for t, xy, yaw in series
    ]


def hcs(
    times: np.ndarray, xy: np.ndarray, yaw: np.ndarray, window: int, steepness: float
) -> float | None:
    """History Comfort Score over the last `window` ego samples; None until the window is full."""
    if len(times) < window:
        return None
    return comfort_score(times[-window:], xy[-window:], yaw[-window:], steepness)


def ppcs(plan: np.ndarray, steepness: float) -> float | None:
    """Planned Path Comfort Score of a (N, 3) plan; None below four points."""
    if len(plan) < MIN_POINTS:
        return None
    return comfort_score(plan[:, 0], plan[:, 1:3], None, steepness)
