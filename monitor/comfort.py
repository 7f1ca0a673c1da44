"""Comfort scores: hcs (driven ego history) and ppcs (current plan).

spi-reference Decision (documented in docs/spi-reference.md): velocity and acceleration are
differentiated in the world frame and the *acceleration* is rotated into the vehicle frame.
Rotating the velocity first and differentiating its components, the literal reading, loses the
centripetal term: for a plan (heading = path tangent) the lateral velocity is zero by
construction, so a_lat would always be 0.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

#: Minimum samples: positions -> velocity -> acceleration -> jerk needs four.
MIN_POINTS = 4


def nv(s: np.ndarray | float, steepness: float) -> np.ndarray | float:
    """spi-reference Decision: symmetric NV(s) = 2 / (1 + exp(-w |s|)) - 1, in [0, 1)."""
    return 2.0 / (1.0 + np.exp(-steepness * np.abs(s))) - 1.0


def comfort_score(
    times: np.ndarray, xy: np.ndarray, yaw: np.ndarray | None, steepness: float
) -> float | None:
    """1 - ((NV(a_lon) + NV(a_lat)) / 2 + NV(j_lon)) / 2 from positions (n, 2) at `times` (n,).

    `yaw` (n,) gives the vehicle heading at each sample; None takes the path tangent (plans).
    None when fewer than four samples.
    """
    n = len(times)
    if n < MIN_POINTS:
        return None
    dt = times[1:] - times[:-1]
    vel = (xy[1:] - xy[:-1]) / dt[:, None]  # at the midpoints tm
    tm = 0.5 * (times[1:] + times[:-1])
    acc = (vel[1:] - vel[:-1]) / (tm[1:] - tm[:-1])[:, None]  # centred on samples 1..n-2
    if yaw is not None:
        head = yaw[1:-1]
        ux, uy = np.cos(head), np.sin(head)
        a_lon = acc[:, 0] * ux + acc[:, 1] * uy
        a_lat = -acc[:, 0] * uy + acc[:, 1] * ux
    else:
        # Path tangent at sample i: the chord from i-1 to i+1 (the sum of the two segments).
        chord = xy[2:] - xy[:-2]
        norm = np.hypot(chord[:, 0], chord[:, 1])
        ok = norm > 1e-12
        safe = np.where(ok, norm, 1.0)
        ux, uy = chord[:, 0] / safe, chord[:, 1] / safe
        # Decision: where the tangent is undefined (no motion), the whole acceleration counts as
        # longitudinal; this keeps the score invariant under rotations of the world.
        a_lon = np.where(ok, acc[:, 0] * ux + acc[:, 1] * uy, np.hypot(acc[:, 0], acc[:, 1]))
        a_lat = np.where(ok, -acc[:, 0] * uy + acc[:, 1] * ux, 0.0)
    ta = times[1:-1]
    j_lon = (a_lon[1:] - a_lon[:-1]) / (ta[1:] - ta[:-1])
    pa_lon = float(np.max(np.abs(a_lon)))
    pa_lat = float(np.max(np.abs(a_lat)))
    pj_lon = float(np.max(np.abs(j_lon)))
    return float(
        1.0 - ((nv(pa_lon, steepness) + nv(pa_lat, steepness)) / 2 + nv(pj_lon, steepness)) / 2
    )


def comfort_scores(
    series: Sequence[tuple[np.ndarray, np.ndarray, np.ndarray | None]], steepness: float
) -> list[float | None]:
    """`comfort_score` of many (times, xy, yaw-or-None) series in one vectorised pass.

    A frame has four short series (hcs and ppcs of two channels); per-call numpy overhead, not
    arithmetic, dominates at that size. The series are concatenated; differences that straddle
    two series are computed on safe placeholders and masked out, and each series' peaks come
    from one `maximum.reduceat`. Each value is computed by the same arithmetic as
    `comfort_score`, element by element.
    """
    out: list[float | None] = [None] * len(series)
    use = [s for s, (t, _, _) in enumerate(series) if len(t) >= MIN_POINTS]
    if not use:
        return out
    if len(use) == 1:
        times, xy, yaw = series[use[0]]
        out[use[0]] = comfort_score(times, xy, yaw, steepness)
        return out
    lengths = np.array([len(series[s][0]) for s in use])
    starts = np.zeros(len(use), dtype=np.intp)
    np.cumsum(lengths[:-1], out=starts[1:])
    ends = starts + lengths  # one past each series
    times = np.concatenate([series[s][0] for s in use])
    xy = np.concatenate([series[s][1] for s in use])
    # the vehicle heading where given (hcs), else a placeholder the path tangent replaces
    has_yaw = np.repeat([series[s][2] is not None for s in use], lengths)
    zeros = np.zeros(int(lengths.max()))
    yaw = np.concatenate([zeros[: len(series[s][0])] if series[s][2] is None else series[s][2]
                          for s in use])  # fmt: skip
    # Differences ending at index e of the next series straddle a boundary: index e - 1 for
    # first differences, e - 2 and e - 1 for second ones. Their denominators become 1.
    bound = ends[:-1]
    dt = times[1:] - times[:-1]
    dt[bound - 1] = 1.0
    vel = (xy[1:] - xy[:-1]) / dt[:, None]
    tm = 0.5 * (times[1:] + times[:-1])
    dtm = tm[1:] - tm[:-1]
    dtm[np.concatenate([bound - 2, bound - 1])] = 1.0
    acc = (vel[1:] - vel[:-1]) / dtm[:, None]  # acc[i] is centred on sample i + 1
    chord = xy[2:] - xy[:-2]
    norm = np.hypot(chord[:, 0], chord[:, 1])
    tangent = ~has_yaw[1:-1]
    moving = norm > 1e-12
    ok = moving | has_yaw[1:-1]
    safe = np.where(moving, norm, 1.0)
    head = yaw[1:-1]
    ux = np.where(tangent, chord[:, 0] / safe, np.cos(head))
    uy = np.where(tangent, chord[:, 1] / safe, np.sin(head))
    # Decision (see comfort_score): no tangent, the whole acceleration is longitudinal.
    a_lon = np.where(ok, acc[:, 0] * ux + acc[:, 1] * uy, np.hypot(acc[:, 0], acc[:, 1]))
    a_lat = np.where(ok, -acc[:, 0] * uy + acc[:, 1] * ux, 0.0)
    ta = times[1:-1]
    dta = ta[1:] - ta[:-1]
    dta[np.concatenate([bound - 3, bound - 2, bound - 1])] = 1.0
    j_lon = (a_lon[1:] - a_lon[:-1]) / dta
    # Peaks of |.| per series; straddling entries count as 0, which cannot raise a peak.
    peaks = np.empty((3, len(use)))
    a_abs = np.abs(np.stack([a_lon, a_lat]))
    a_abs[:, np.concatenate([bound - 2, bound - 1])] = 0.0
    peaks[:2] = np.maximum.reduceat(a_abs, starts, axis=1)
    j_abs = np.abs(j_lon)
    j_abs[np.concatenate([bound - 3, bound - 2, bound - 1])] = 0.0
    peaks[2] = np.maximum.reduceat(j_abs, starts)
    v = nv(peaks, steepness)
    score = 1.0 - ((v[0] + v[1]) / 2 + v[2]) / 2
    for s, value in zip(use, score.tolist(), strict=True):
        out[s] = value
    return out


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
