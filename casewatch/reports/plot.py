"""Geometry of the report's SVG charts: one time-series plot per SPI and status strips.

The templates draw; this module computes coordinates and path strings (numbers only, so no
user text ever passes through here unescaped). Everything is vectorised with numpy and bounded
in size: a series is re-bucketed to at most `MAX_BUCKETS` (min of the minima, max of the maxima,
so no excursion disappears), and shaded spans narrower than a pixel are merged.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from casewatch.evaluator.result import STATUS_SEVERITY, DataGap, Episode, Series, StatusInterval

PLOT_W = 880.0
PLOT_H = 200.0
LEFT = 56.0  # room for y tick labels
RIGHT = 12.0
TOP = 10.0
BOTTOM = 34.0  # room for x tick labels and the axis title
#: No more buckets than the plot has pixel columns: finer detail would only add bytes.
MAX_BUCKETS = int(PLOT_W - LEFT - RIGHT)


@dataclass(frozen=True)
class Tick:
    pos: float  # pixel coordinate along the axis
    label: str


@dataclass(frozen=True)
class Span:
    x: float
    w: float


@dataclass(frozen=True)
class PlotFrame:
    """A small SVG chart's box (the tuning and calibration pages): its size in pixels and the
    inner area the unit square maps to, y upwards."""

    width: int
    height: int
    left: int
    top: int
    inner_w: int
    inner_h: int

    def x(self, u: float) -> float:
        """Pixel column of `u` in [0, 1] along the x axis."""
        return self.left + u * self.inner_w

    def y(self, v: float) -> float:
        """Pixel row of `v` in [0, 1] up the y axis."""
        return self.top + (1 - v) * self.inner_h


@dataclass(frozen=True)
class PlotView:
    width: float
    height: float
    left: float
    top: float
    inner_w: float
    inner_h: float
    band_path: str  # min/max band (a filled and stroked path)
    reference_y: float | None
    reference_label: str
    episodes: list[Span]
    gaps: list[Span]
    x_ticks: list[Tick]
    y_ticks: list[Tick]
    x_title: str
    y_title: str
    buckets: int
    bucket: float  # seconds per plotted bucket (after any re-bucketing)
    labels: list[Span] = field(default_factory=list)  # labelled intervals (hazard plots)
    clipped_above: str = ""  # a robustness plot's axis top, when higher values are drawn at it


#: A robustness axis reaches this many times the worst excursion below zero (or the closest
#: approach to zero from above), and at least the lower quartile of the values; higher values
#: are drawn at the top. A hazard's robustness is
#: often saturated far above its margin (no lead vehicle: a time headway of 60 s), and an axis
#: scaled to that flattens the dips near zero that matter.
ROBUSTNESS_REACH = 3.0


def robustness_top(lo: np.ndarray, hi: np.ndarray) -> float | None:
    """The top of a robustness plot's axis when the data reach far above the interesting band
    (`ROBUSTNESS_REACH`); None when the whole range fits anyway. `lo`, `hi`: finite values."""
    if not len(lo):
        return None
    low, high = float(lo.min()), float(hi.max())
    top = max(ROBUSTNESS_REACH * abs(low), float(np.quantile(lo, 0.25)))  # typical lows too
    if top <= 0 or high <= 1.5 * top:
        return None
    return top


def nice_ticks(lo: float, hi: float, target: int = 6) -> list[float]:
    """Round tick values (1, 2, 2.5, 5 x 10^k) covering [lo, hi]."""
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return []
    if hi <= lo:
        hi = lo + 1.0
    raw = (hi - lo) / max(1, target)
    magnitude = 10 ** math.floor(math.log10(raw))
    step = next(m * magnitude for m in (1, 2, 2.5, 5, 10) if m * magnitude >= raw)
    first = math.ceil(lo / step - 1e-9) * step
    count = math.floor((hi - first) / step + 1e-9) + 1
    return [round(first + i * step, 10) for i in range(max(0, count))]


def _time_label(t: float, span: float) -> str:
    if span < 120:
        return f"{t:g}"
    minutes, seconds = divmod(t, 60)
    if span < 7200:
        return f"{int(minutes)}:{round(seconds):02d}"
    hours, minutes = divmod(minutes, 60)
    return f"{int(hours)}:{int(minutes):02d}"


def _rebucket(series: Series) -> tuple[np.ndarray, float, np.ndarray, np.ndarray]:
    t = np.asarray(series.t, dtype=float)
    lo = np.array([np.nan if v is None else v for v in series.lo], dtype=float)
    hi = np.array([np.nan if v is None else v for v in series.hi], dtype=float)
    bucket = float(series.bucket)
    if len(t) <= MAX_BUCKETS:
        return t, bucket, lo, hi
    per = math.ceil(len(t) / MAX_BUCKETS)
    pad = (-len(t)) % per
    lo_p = np.concatenate((lo, np.full(pad, np.nan))).reshape(-1, per)
    hi_p = np.concatenate((hi, np.full(pad, np.nan))).reshape(-1, per)
    empty = np.all(np.isnan(lo_p), axis=1)
    with np.errstate(all="ignore"):
        lo_n = np.where(empty, np.nan, np.nanmin(np.where(np.isnan(lo_p), np.inf, lo_p), axis=1))
        hi_n = np.where(empty, np.nan, np.nanmax(np.where(np.isnan(hi_p), -np.inf, hi_p), axis=1))
    return t[::per], bucket * per, lo_n, hi_n


def _merge_spans(starts: np.ndarray, ends: np.ndarray, min_gap: float) -> list[Span]:
    """Pixel spans, merging neighbours closer than `min_gap` pixels (display only)."""
    if len(starts) == 0:
        return []
    order = np.argsort(starts)
    spans: list[list[float]] = []
    for a, b in zip(starts[order], ends[order], strict=True):
        if spans and a - spans[-1][1] < min_gap:
            spans[-1][1] = max(spans[-1][1], b)
        else:
            spans.append([float(a), float(b)])
    return [Span(round(a, 1), round(max(b - a, 1.0), 1)) for a, b in spans]


def plot_series(
    series: Series,
    episodes: Sequence[Episode],
    gaps: Sequence[DataGap],
    period: float,
    t_range: tuple[float, float] | None = None,
    labels: Sequence[tuple[float, float]] = (),
) -> PlotView:
    """Coordinates of one SPI (or hazard robustness) plot; `labels` are ground-truth intervals
    drawn as a strip along the top."""
    t, bucket, lo, hi = _rebucket(series)
    inner_w, inner_h = PLOT_W - LEFT - RIGHT, PLOT_H - TOP - BOTTOM
    if t_range is not None:
        t0, t1 = t_range
    else:
        t0 = float(t[0]) if len(t) else 0.0
        t1 = float(t[-1] + bucket) if len(t) else 1.0
    if t1 <= t0:
        t1 = t0 + max(bucket, period, 1.0)
    finite = np.isfinite(lo) & np.isfinite(hi)
    top = robustness_top(lo[finite], hi[finite]) if series.quantity == "robustness" else None
    if top is not None:  # saturated far above the margin: clip, and say so on the plot
        lo, hi = np.minimum(lo, top), np.minimum(hi, top)
    values = np.concatenate((lo[finite], hi[finite]))
    if series.reference is not None:
        values = np.append(values, series.reference)
    v0, v1 = (float(values.min()), float(values.max())) if len(values) else (0.0, 1.0)
    pad = (v1 - v0) * 0.08 or 0.5
    v0, v1 = v0 - pad, v1 + pad

    def sx(tt: np.ndarray | float) -> np.ndarray:
        return LEFT + (np.asarray(tt) - t0) / (t1 - t0) * inner_w

    def sy(vv: np.ndarray | float) -> np.ndarray:
        return TOP + (v1 - np.asarray(vv)) / (v1 - v0) * inner_h

    # Band: one closed polygon per run of buckets with values, through the bucket centres (max
    # forwards, min backwards); a lone bucket is a zero-width polygon that its stroke still shows.
    parts: list[str] = []
    if finite.any():
        padded = np.concatenate(([False], finite, [False])).astype(np.int8)
        edges = np.flatnonzero(np.diff(padded))
        for a, b in zip(edges[::2], edges[1::2], strict=True):
            xs = sx(t[a:b] + bucket / 2)
            upper = " ".join(f"{x:.1f},{y:.1f}" for x, y in zip(xs, sy(hi[a:b]), strict=True))
            lower = " ".join(
                f"{x:.1f},{y:.1f}" for x, y in zip(xs[::-1], sy(lo[a:b])[::-1], strict=True)
            )
            parts.append(f"M{upper} L{lower}Z")
    band_path = " ".join(parts)

    def spans(starts: list[float], ends: list[float]) -> list[Span]:
        if not starts:
            return []
        a = np.clip(sx(np.asarray(starts)), LEFT, LEFT + inner_w)
        b = np.clip(sx(np.asarray(ends) + period), LEFT, LEFT + inner_w)
        return _merge_spans(a, b, 1.0)

    reference_y = None
    if series.reference is not None:
        reference_y = round(float(sy(series.reference)), 1)
    span = t1 - t0
    x_ticks = [
        Tick(round(float(sx(v)), 1), _time_label(v, span))
        for v in nice_ticks(t0, t1, 8)
        if t0 <= v <= t1
    ]
    y_ticks = [
        Tick(round(float(sy(v)), 1), f"{v:g}") for v in nice_ticks(v0, v1, 5) if v0 <= v <= v1
    ]
    x_title = "time [s]" if span < 120 else ("time [m:ss]" if span < 7200 else "time [h:mm]")
    return PlotView(
        width=PLOT_W,
        height=PLOT_H,
        left=LEFT,
        top=TOP,
        inner_w=inner_w,
        inner_h=inner_h,
        band_path=band_path,
        reference_y=reference_y,
        reference_label=f"{series.reference:g}" if series.reference is not None else "",
        episodes=spans([e.start for e in episodes], [e.end for e in episodes]),
        gaps=spans([g.start for g in gaps], [g.end for g in gaps]),
        x_ticks=x_ticks,
        y_ticks=y_ticks,
        x_title=x_title,
        y_title=series.name,
        buckets=len(t),
        bucket=bucket,
        labels=spans([a for a, _ in labels], [b for _, b in labels]),
        clipped_above="" if top is None else f"{top:.3g}",
    )


@dataclass(frozen=True)
class StripRect:
    x: float
    w: float
    status: str


def status_strip(
    timeline: Sequence[StatusInterval], t0: float, t1: float, period: float, width: float
) -> list[StripRect]:
    """A node's status over the run as coloured rectangles, at most one per pixel column.

    Intervals narrower than a pixel are folded into their column by taking the worst status
    in it, so a short violation stays visible however long the run.
    """
    # a damaged result (NaN or infinite times) has no place on the axis: its intervals are
    # left out rather than cast to arbitrary columns
    timeline = [iv for iv in timeline if math.isfinite(iv.start) and math.isfinite(iv.end)]
    if not timeline or width <= 0 or not all(map(math.isfinite, (t0, t1, period))):
        return []
    if t1 <= t0:
        t1 = t0 + period
    names = sorted(STATUS_SEVERITY, key=STATUS_SEVERITY.__getitem__)
    code = {name: i for i, name in enumerate(names)}
    columns = int(width)
    worst = np.full(columns, -1, dtype=int)
    starts = np.array([iv.start for iv in timeline], dtype=float)
    ends = np.array([iv.end for iv in timeline], dtype=float) + period
    codes = np.array([code.get(iv.status, 0) for iv in timeline], dtype=int)
    scale = columns / (t1 - t0)
    first = np.clip(np.floor((starts - t0) * scale).astype(int), 0, columns - 1)
    last = np.clip(np.ceil((ends - t0) * scale).astype(int) - 1, 0, columns - 1)
    last = np.maximum(last, first)
    # Each interval raises the columns it touches to its status (vectorised over intervals,
    # looping only over the few distinct statuses, worst last).
    for c in np.unique(codes):
        mask = codes == c
        cover = np.zeros(columns + 1, dtype=int)
        np.add.at(cover, first[mask], 1)
        np.add.at(cover, last[mask] + 1, -1)
        touched = np.cumsum(cover[:-1]) > 0
        worst[touched] = np.maximum(worst[touched], c)
    rects: list[StripRect] = []
    change = np.flatnonzero(np.diff(worst)) + 1
    bounds = np.concatenate(([0], change, [columns]))
    for a, b in itertools.pairwise(bounds):
        if worst[a] >= 0:
            rects.append(StripRect(float(a), float(b - a), names[worst[a]]))
    return rects
