"""Comfort scores: hcs (driven ego history) and ppcs (current plan).

spi-reference Decision (documented in docs/spi-reference.md): velocity and acceleration are
differentiated in the world frame and the *acceleration* is rotated into the vehicle frame.
Rotating the velocity first and differentiating its components, the literal reading, loses the
centripetal term: for a plan (heading = path tangent) the lateral velocity is zero by
construction, so a_lat would always be 0.
"""

from __future__ import annotations

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
