"""Channel frames: the typed, array-backed value the reader yields and the metrics consume.

Objects are stored as arrays (one row per object) rather than one Python object per detection,
because every metric is vectorised over objects and points; building the arrays once per frame
is cheaper than gathering them again in each metric. `docs/streams.md` describes the JSON form.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

FORMAT_NAME = "casewatch-frames"
FORMAT_VERSION = 1


def box_footprint(length: float, width: float) -> np.ndarray:
    """Body-frame corners (counter-clockwise, x forward, y left) of a box centred on the origin."""
    hl, hw = 0.5 * length, 0.5 * width
    return np.array([[hl, hw], [-hl, hw], [-hl, -hw], [hl, -hw]], dtype=float)


def unpadded(poly: np.ndarray) -> np.ndarray:
    """A (V, 2) footprint without its padding (its last vertex repeated; see `Objects`)."""
    n = len(poly)
    while n > 3 and np.array_equal(poly[n - 1], poly[n - 2]):
        n -= 1
    return poly[:n]


def place(body: np.ndarray, pos: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """World coordinates of body-frame polygons.

    `body` (..., V, 2), `pos` (..., 2), `yaw` (...) broadcast together; returns (..., V, 2).
    """
    c = np.cos(yaw)[..., None]
    s = np.sin(yaw)[..., None]
    bx = body[..., 0]
    by = body[..., 1]
    out = np.empty((*np.broadcast_shapes(bx.shape, c.shape), 2))
    out[..., 0] = c * bx - s * by + pos[..., None, 0]
    out[..., 1] = s * bx + c * by + pos[..., None, 1]
    return out


def polygon_area(body: np.ndarray) -> np.ndarray:
    """Absolute shoelace area of (..., V, 2) polygons (repeated padding vertices add nothing)."""
    x = body[..., 0]
    y = body[..., 1]
    return 0.5 * np.abs(np.sum(x * np.roll(y, -1, axis=-1) - np.roll(x, -1, axis=-1) * y, axis=-1))


def is_convex(body: np.ndarray) -> bool:
    """True when a (V, 2) polygon (possibly with repeated vertices) is convex."""
    edges = np.roll(body, -1, axis=0) - body
    keep = np.hypot(edges[:, 0], edges[:, 1]) > 0
    edges = edges[keep]
    if len(edges) < 3:
        return True
    nxt = np.roll(edges, -1, axis=0)
    cross = edges[:, 0] * nxt[:, 1] - edges[:, 1] * nxt[:, 0]
    return bool(np.all(cross >= -1e-12) or np.all(cross <= 1e-12))


@dataclass(slots=True)
class Ego:
    """The ego vehicle as one channel sees it. `footprint` is (V, 2) in the body frame."""

    x: float
    y: float
    yaw: float
    vx: float
    vy: float
    footprint: np.ndarray
    convex: bool = True
    #: (half length, half width) when the footprint is a length/width box, else None; boxes
    #: take a closed-form separating-axis test in the safety score.
    half: tuple[float, float] | None = None

    @property
    def pos(self) -> np.ndarray:
        return np.array([self.x, self.y])

    @property
    def radius(self) -> float:
        """Radius of the bounding circle around the centre (safety-score prefilter)."""
        return float(np.max(np.hypot(self.footprint[:, 0], self.footprint[:, 1])))


@dataclass(slots=True)
class Objects:
    """Detected objects of one channel, one row per object.

    - `footprints` (K, V, 2): body-frame polygons, padded to a common V by repeating the last
      vertex (padding changes neither area nor shape).
    - `pred` (K, P, 3): predictions `[dt, x, y]`, padded by repeating the last point;
      `pred_len` (K,) holds the real lengths (0 = no prediction: the object stays where it is).
    """

    ids: list[str]
    cls: list[str]
    pos: np.ndarray
    yaw: np.ndarray
    vel: np.ndarray
    footprints: np.ndarray
    pred: np.ndarray
    pred_len: np.ndarray
    convex: np.ndarray
    #: (K, 2) half length and half width of box footprints; NaN rows for polygon footprints.
    half: np.ndarray
    _areas: np.ndarray | None = field(default=None, repr=False)
    _radii: np.ndarray | None = field(default=None, repr=False)

    def __len__(self) -> int:
        return len(self.ids)

    @property
    def areas(self) -> np.ndarray:
        """Footprint areas (K,), cached: the frame is immutable once read."""
        if self._areas is None:
            half = self.half
            box = ~np.isnan(half[:, 0])
            if box.all():
                self._areas = 4.0 * half[:, 0] * half[:, 1]
            else:
                self._areas = np.where(
                    box, 4.0 * half[:, 0] * half[:, 1], polygon_area(self.footprints)
                )
        return self._areas

    @property
    def radii(self) -> np.ndarray:
        """Bounding-circle radii (K,) of the footprints around their centres."""
        if self._radii is None:
            half = self.half
            if len(half) and not np.isnan(half[:, 0]).any():
                self._radii = np.hypot(half[:, 0], half[:, 1])
            else:
                fp = self.footprints
                self._radii = (
                    np.max(np.hypot(fp[..., 0], fp[..., 1]), axis=1) if len(fp) else np.zeros(0)
                )
        return self._radii

    def prediction_xy(self) -> tuple[np.ndarray, np.ndarray]:
        """Predictions as (K, P', 2) points and (K,) lengths, an empty prediction replaced by
        the single current position (the frame format: "the object stays where it is")."""
        k = len(self.ids)
        if k == 0:
            return np.zeros((0, 1, 2)), np.zeros(0, dtype=int)
        if self.pred.shape[1] == 0:
            return self.pos[:, None, :].copy(), np.ones(k, dtype=int)
        xy = self.pred[:, :, 1:3]
        n = self.pred_len
        empty = n == 0
        if empty.any():
            xy = xy.copy()
            xy[empty] = self.pos[empty][:, None, :]
            n = np.where(empty, 1, n)
        return xy, n

    def subset(self, keep: np.ndarray) -> Objects:
        """The objects where the boolean mask `keep` (K,) is True, in their order."""
        idx = np.flatnonzero(keep)
        rows = idx.tolist()  # Python ints: list indexing without numpy scalars
        return Objects(
            ids=[self.ids[i] for i in rows],
            cls=[self.cls[i] for i in rows],
            pos=self.pos[idx],
            yaw=self.yaw[idx],
            vel=self.vel[idx],
            footprints=self.footprints[idx],
            pred=self.pred[idx],
            pred_len=self.pred_len[idx],
            convex=self.convex[idx],
            half=self.half[idx],
        )

    @staticmethod
    def empty() -> Objects:
        return Objects(
            ids=[],
            cls=[],
            pos=np.zeros((0, 2)),
            yaw=np.zeros(0),
            vel=np.zeros((0, 2)),
            footprints=np.zeros((0, 4, 2)),
            pred=np.zeros((0, 0, 3)),
            pred_len=np.zeros(0, dtype=int),
            convex=np.zeros(0, dtype=bool),
            half=np.zeros((0, 2)),
        )


@dataclass(slots=True)
class ChannelState:
    """What one channel reports at one tick: ego, plan (N, 3) `[dt, x, y]`, objects."""

    ego: Ego
    plan: np.ndarray
    objects: Objects


@dataclass(slots=True)
class Frame:
    """One tick: time, the channels present (an absent channel is a dropout), scalar signals."""

    t: float
    channels: dict[str, ChannelState]
    signals: dict[str, float | None] = field(default_factory=dict)
    line: int = 0  # 1-based line of the stream it came from (0 = built in memory)
    #: conditions that change at this tick (flattened `odd`: `environment.weather` -> "fog"),
    #: kept until a later frame changes them again; None: no change (docs/odd.md)
    odd: dict[str, str | float | bool] | None = None
    #: the world inputs as signal values (monitor.world); None: the frame reports no world
    world: dict[str, float | None] | None = None


@dataclass(frozen=True, slots=True)
class Coverage:
    """What a channel can see: a field of view of `fov_deg` degrees centred on its ego heading,
    out to `range_m` metres. The default sees everything (a channel that declares nothing)."""

    fov_deg: float = 360.0
    range_m: float = float("inf")

    @property
    def all_round(self) -> bool:
        return self.fov_deg >= 360.0 and self.range_m == float("inf")


@dataclass(slots=True)
class Header:
    """The optional first line of a stream."""

    format: str = FORMAT_NAME
    version: int = FORMAT_VERSION
    channels: list[str] = field(default_factory=list)
    period: float = 0.1
    meta: dict[str, Any] = field(default_factory=dict)
    #: channel -> declared coverage (`"coverage"` in the header; channels not named: all-round)
    coverage: dict[str, Coverage] = field(default_factory=dict)
    #: the stream's conditions at its start (`meta.odd`, flattened: `environment.weather`)
    conditions: dict[str, str | float | bool] = field(default_factory=dict)
    #: why `meta.odd` could not be read (a `bad-header` defect; the rest of the header stands
    #: and no condition is reported), None when it could
    conditions_problem: str | None = None
