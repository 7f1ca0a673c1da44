"""What the live page shows, kept up to date by the judging thread and read by the server's.

The judge calls `on_tick` after every frame and `on_event` for every event (session's
observer hooks); both only store references and append to bounded deques under a lock, a few
microseconds a frame, whatever the number of pages open. The server thread asks for a `delta`
(what changed since its last one) every broadcast interval, and for a `snapshot` (everything
a page needs, the last minute included) when a page connects or falls behind.

Sparklines show each formula's plotted quantity, as the report's plots do: the SPI's signal
against its threshold when it has one, else its robustness against 0. They read the
evaluator's own plot series (the current bucket: one tick wide for the first 2000 ticks, then
the bucket's least value, or greatest for a `<` threshold, as the report plots it).
"""

from __future__ import annotations

import math
import threading
import time
from collections import deque
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from casewatch.evaluator.result import (
    DataGap,
    Episode,
    EpisodeOpen,
    NearMiss,
    OddChange,
    RunResult,
)
from casewatch.spec.model import CompiledSpec

#: How much history the sparklines keep, s.
WINDOW_S = 60.0
#: Closed episodes, near misses, data gaps and defects listed (the counts stay exact).
RECENT = 20


@dataclass(frozen=True)
class FormulaView:
    """What a sparkline needs of one formula, fixed for the run."""

    id: str
    node_id: str
    kind: str
    quantity: str  # the signal's name, or "robustness"
    reference: float  # the threshold value, or 0 for robustness
    threshold: str  # "< 1.0", ">= 0.6"; "" for robustness (violated below 0)
    upper: bool  # violated above the reference (a `<` threshold): plot bucket maxima

    @staticmethod
    def of(spec: CompiledSpec) -> list[FormulaView]:
        out = []
        for f in spec.formulas:
            if f.signal and f.threshold:
                out.append(
                    FormulaView(
                        f.id,
                        f.node_id,
                        f.kind,
                        f.signal,
                        float(f.threshold.split()[-1]),
                        f.threshold,
                        f.threshold.lstrip().startswith("<"),
                    )
                )
            else:
                out.append(FormulaView(f.id, f.node_id, f.kind, "robustness", 0.0, "", False))
        return out


def _finite(value: float | None) -> float | None:
    return None if value is None or not math.isfinite(value) else round(float(value), 4)


def _episode(event: Episode | EpisodeOpen) -> dict[str, Any]:
    out: dict[str, Any] = {
        "formula": event.formula_id,
        "node": event.node_id,
        "kind": event.kind,
        "start": event.start,
        "trace": [[step.id for step in path] for path in event.trace],
    }
    if isinstance(event, Episode):
        out.update(end=event.end, worst=_finite(event.worst_robustness), t_worst=event.t_worst)
    else:
        out["announced"] = event.t
    return out


class LiveState:
    """The run so far, as the page shows it. Thread-safe: the judge writes, the server reads."""

    def __init__(
        self,
        spec: CompiledSpec,
        period: float,
        window_s: float = WINDOW_S,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.formulas = FormulaView.of(spec)
        self.root = spec.root_id
        self.period = period
        self._clock = clock
        self._lock = threading.Lock()
        self._points = max(2, round(window_s / period))
        # one row per tick: (sequence, t, value per formula); the last minute only
        self._ticks: deque[tuple[int, float, tuple[float | None, ...]]] = deque(maxlen=self._points)
        self._seq = 0
        self._statuses: Mapping[str, str] = {}
        self._status_seq = 0  # the tick at which the statuses last changed
        self._open: dict[str, dict[str, Any]] = {}
        self._closed: deque[dict[str, Any]] = deque(maxlen=RECENT)
        self._near: deque[dict[str, Any]] = deque(maxlen=RECENT)
        self._gaps: deque[dict[str, Any]] = deque(maxlen=RECENT)
        self._counts = {"episodes": 0, "hazards": 0, "near_misses": 0, "data_gaps": 0}
        self._odd: dict[str, dict[str, Any]] = {}
        self._event_seq = 0  # bumped by every event, so a delta knows to send the lists
        self._reader: Any = None
        self._first: tuple[float, float] | None = None  # (stream t, clock) of the first tick
        self._last: tuple[float, float] | None = None
        self._anchor = math.inf  # the least (clock - stream t) of any tick: the on-time mark
        self._frames = 0
        self._final: dict[str, Any] | None = None

    # -- the judging thread -----------------------------------------------------------------

    def on_tick(self, frame: Any, statuses: Mapping[str, str], evaluator: Any, reader: Any) -> None:
        """After each judged frame (RunSinks.on_tick): statuses, plotted values, timing."""
        now = self._clock()
        values = []
        for view, state in zip(self.formulas, evaluator.states, strict=True):
            buckets = state.series.hi if view.upper else state.series.lo
            values.append(_finite(buckets[-1]) if buckets else None)
        with self._lock:
            self._seq += 1
            self._ticks.append((self._seq, frame.t, tuple(values)))
            if statuses is not self._statuses and statuses != self._statuses:
                self._status_seq = self._seq
            self._statuses = statuses  # never mutated by the evaluator (a memoised mapping)
            self._reader = reader
            self._frames = reader.frames_read
            if self._first is None:
                self._first = (frame.t, now)
            self._last = (frame.t, now)
            self._anchor = min(self._anchor, now - frame.t)

    def on_event(self, event: Any) -> None:
        """Every event as it happens (RunSinks.on_event)."""
        with self._lock:
            self._event_seq += 1
            if isinstance(event, EpisodeOpen):
                self._open[event.formula_id] = _episode(event)
            elif isinstance(event, Episode):
                self._open.pop(event.formula_id, None)
                self._closed.appendleft(_episode(event))
                self._counts["hazards" if event.kind == "hazard" else "episodes"] += 1
            elif isinstance(event, NearMiss):
                self._counts["near_misses"] += 1
                self._near.appendleft(
                    {
                        "node": event.node_id,
                        "start": event.start,
                        "end": event.end,
                        "least": _finite(event.least_robustness),
                    }
                )
            elif isinstance(event, OddChange):
                self._odd[event.node_id] = {
                    "state": event.state,
                    "because": event.because,
                    "t": event.t,
                }
            elif isinstance(event, DataGap):
                self._counts["data_gaps"] += 1
                self._gaps.appendleft(
                    {
                        "node": event.node_id,
                        "start": event.start,
                        "end": event.end,
                        "missing": list(event.missing),
                    }
                )

    def finish(self, result: RunResult | None, message: str = "") -> None:
        """The stream ended: the final verdict (or why there is none) stays on every page."""
        final: dict[str, Any] = {"message": message}
        if result is not None:
            final.update(
                verdict=result.verdict,
                frames=result.stream.frames_read,
                duration=result.stream.duration,
                episodes=sum(1 for e in result.episodes if e.kind == "spi"),
                hazards=sum(1 for e in result.episodes if e.kind == "hazard"),
                defects=result.stream.defect_count,
                complete=result.complete,
            )
        with self._lock:
            self._event_seq += 1
            self._open.clear()
            self._final = final

    # -- the server thread ------------------------------------------------------------------

    def _behind(self) -> float | None:
        """Seconds the judging lags real time: how much later than its most punctual frame
        (least clock - stream t) the latest judged stream time is, now. 0 while frames are
        judged as they are due; it grows while the stream stalls or the judge falls behind.
        Frozen once the stream ended."""
        if self._last is None:
            return None
        now = self._last[1] if self._final is not None else self._clock()
        return round(max(0.0, now - self._anchor - self._last[0]), 3)

    def _rate(self) -> float | None:
        """Stream seconds judged per wall-clock second so far (1 live, more for a replay)."""
        if self._first is None or self._last is None or self._last[1] - self._first[1] < 1.0:
            return None
        return round((self._last[0] - self._first[0]) / (self._last[1] - self._first[1]), 2)

    def _stream(self) -> dict[str, Any]:
        reader = self._reader
        defects = list(reader.defects) if reader is not None else []
        return {
            "frames": self._frames,
            "t": None if self._last is None else self._last[0],
            "behind": self._behind(),
            "rate": self._rate(),
            "defect_count": len(defects),
            "defects": [
                {"line": d.line, "kind": d.kind, "message": d.message} for d in defects[-5:]
            ],
            "dropouts": dict(reader.dropouts) if reader is not None else {},
        }

    def _lists(self) -> dict[str, Any]:
        return {
            "open": list(self._open.values()),
            "closed": list(self._closed),
            "near": list(self._near),
            "gaps": list(self._gaps),
            "counts": dict(self._counts),
            "odd": dict(self._odd),
            "final": self._final,
        }

    def snapshot(self) -> tuple[dict[str, Any], Cursor]:
        """Everything a page needs, and the cursor to take deltas from."""
        with self._lock:
            body = {
                "kind": "snapshot",
                "root": self.root,
                "period": self.period,
                "formulas": [
                    {
                        "id": f.id,
                        "node": f.node_id,
                        "kind": f.kind,
                        "quantity": f.quantity,
                        "reference": f.reference,
                        "threshold": f.threshold,
                    }
                    for f in self.formulas
                ],
                "ticks": [[t, list(v)] for _, t, v in self._ticks],
                "status": dict(self._statuses),
                "stream": self._stream(),
                **self._lists(),
            }
            return body, Cursor(self._seq, self._status_seq, self._event_seq)

    def delta(self, cursor: Cursor) -> tuple[dict[str, Any] | None, Cursor]:
        """What changed since `cursor` (None when nothing did), and the new cursor."""
        with self._lock:
            if (self._seq, self._event_seq) == (cursor.tick, cursor.event) and self._final:
                return None, cursor
            body: dict[str, Any] = {"kind": "update", "stream": self._stream()}
            if self._seq != cursor.tick:
                body["ticks"] = [[t, list(v)] for s, t, v in self._ticks if s > cursor.tick]
            if self._status_seq > cursor.status:
                body["status"] = dict(self._statuses)
            if self._event_seq != cursor.event:
                body.update(self._lists())
            return body, Cursor(self._seq, self._status_seq, self._event_seq)


@dataclass(frozen=True)
class Cursor:
    """Where a delta starts: the last tick, status change and event already sent."""

    tick: int = 0
    status: int = 0
    event: int = 0
