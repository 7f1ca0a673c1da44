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


class _Layout:
    """Index arrays of a concatenation of series with the given (length, has yaw): each
    series' first index, and the differences that straddle two series. Differences ending at
    index e (the next series' start) straddle it: index e - 1 for first differences (`cut1`),
    e - 2 and e - 1 for second ones (`cut2`), e - 3 .. e - 1 for jerk (`cut3`); their
    denominators become 1 and their values are masked. Frames repeat the same layout."""

    __slots__ = ("cut1", "cut2", "cut3", "has_yaw", "starts", "zeros")

    def __init__(self, key: tuple[tuple[int, bool], ...]):
        lengths = np.array([n for n, _ in key])
        self.starts = np.zeros(len(key), dtype=np.intp)
        np.cumsum(lengths[:-1], out=self.starts[1:])
        bound = (self.starts + lengths)[:-1]
        self.cut1 = bound - 1
        self.cut2 = np.concatenate([bound - 2, bound - 1])
        self.cut3 = np.concatenate([bound - 3, bound - 2, bound - 1])
        # at the acceleration samples 1 .. N-2 of the concatenation
        self.has_yaw = np.repeat([y for _, y in key], lengths)[1:-1]
        self.zeros = np.zeros(int(lengths.max()))


_LAYOUTS: dict[tuple[tuple[int, bool], ...], _Layout] = {}


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
    key = tuple((len(series[s][0]), series[s][2] is not None) for s in use)
    lay = _LAYOUTS.get(key)
    if lay is None:
        lay = _LAYOUTS[key] = _Layout(key)
        if len(_LAYOUTS) > 64:
            _LAYOUTS.clear()
    times = np.concatenate([series[s][0] for s in use])
    xy = np.concatenate([series[s][1] for s in use])
    # the vehicle heading where given (hcs), else a placeholder the path tangent replaces
    yaw = np.concatenate([lay.zeros[: len(series[s][0])] if series[s][2] is None else series[s][2]
                          for s in use])  # fmt: skip
    dt = times[1:] - times[:-1]
    dt[lay.cut1] = 1.0
    vel = (xy[1:] - xy[:-1]) / dt[:, None]
    tm = 0.5 * (times[1:] + times[:-1])
    dtm = tm[1:] - tm[:-1]
    dtm[lay.cut2] = 1.0
    acc = (vel[1:] - vel[:-1]) / dtm[:, None]  # acc[i] is centred on sample i + 1
    chord = xy[2:] - xy[:-2]
    norm = np.hypot(chord[:, 0], chord[:, 1])
    moving = norm > 1e-12
    ok = moving | lay.has_yaw
    safe = np.where(moving, norm, 1.0)
    head = yaw[1:-1]
    ux = np.where(lay.has_yaw, np.cos(head), chord[:, 0] / safe)
    uy = np.where(lay.has_yaw, np.sin(head), chord[:, 1] / safe)
    # Decision (see comfort_score): no tangent, the whole acceleration is longitudinal.
    a_lon = np.where(ok, acc[:, 0] * ux + acc[:, 1] * uy, np.hypot(acc[:, 0], acc[:, 1]))
    a_lat = np.where(ok, -acc[:, 0] * uy + acc[:, 1] * ux, 0.0)
    ta = times[1:-1]
    dta = ta[1:] - ta[:-1]
    dta[lay.cut3] = 1.0
    j_lon = (a_lon[1:] - a_lon[:-1]) / dta
    # Peaks of |.| per series; straddling entries count as 0, which cannot raise a peak.
    peaks = np.empty((3, len(use)))
    a_abs = np.abs(np.stack([a_lon, a_lat]))
    a_abs[:, lay.cut2] = 0.0
    peaks[:2] = np.maximum.reduceat(a_abs, lay.starts, axis=1)
    j_abs = np.abs(j_lon)
    j_abs[lay.cut3] = 0.0
    peaks[2] = np.maximum.reduceat(j_abs, lay.starts)
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
