"""The base of a metric family, and the small histories families keep.

A family computes a group of built-in signals that share inputs and history (the similarity
metrics share the object pairing, the comfort scores the ego's recent path). The engine
(`casewatch.monitor.engine.MetricEngine`) resamples each frame once and calls every registered
family in order (`casewatch.monitor.registry`); a family writes its signals into the tick's
output dict under the names `casewatch.safety_case.signals.builtin_signals` gives them.

Where a new metric goes (docs/architecture.md): its name in the signal catalogue
(`casewatch/safety_case/signals.py`), its arithmetic as a vectorised kernel in a monitor module,
and a `MetricFamily` subclass (a new one, or a method of the family whose inputs it shares)
registered once in `casewatch.monitor.registry.FAMILIES`.
"""

from __future__ import annotations

from typing import ClassVar, Protocol, TypeVar

import numpy as np

from casewatch.monitor.frames import ChannelState, Coverage
from casewatch.safety_case.model import MetricParams

F = TypeVar("F", bound="MetricFamily")


class Engine(Protocol):
    """What a family sees of the engine that steps it (`MetricEngine`)."""

    params: MetricParams
    channels: list[str]
    pairs: list[tuple[str, str]]
    coverage: dict[str, Coverage]
    last_arbitration: str | None

    def family(self, kind: type[F]) -> F: ...


def worst(values: list[float | None], use_max: bool) -> float | None:
    """The unsuffixed signal. Decision: when any component has no value, the worst is unknown,
    so the unsuffixed signal has no value either (missing data is never hidden by a min)."""
    if not values or None in values:  # `in` tests identity first: no float == None
        return None
    return max(values) if use_max else min(values)  # type: ignore[type-var]


class PoseWindows:
    """The windows of several channels in one array (each what a `PoseWindow` held: the
    per-channel form the families kept before issue 36, now the tests' reference in
    tests/monitor/reference_windows.py), for kernels that push and read every channel's window
    in one call (issue 36): window i is the rows `buf[i, start[i]:end[i]]`,
    (t, a, b) oldest first. The kernels push with the rule of `PoseWindow.push` (each
    kernel module has its own copy: `monitor.jit`'s rule) and the caller calls `make_room`
    after each push, so that the next push always finds a free row."""

    __slots__ = ("buf", "end", "max_gap", "span", "start")

    def __init__(self, channels: int, span: float, max_gap: float, capacity: int = 64):
        self.buf = np.zeros((channels, capacity, 3))
        self.start = np.zeros(channels, dtype=np.int64)
        self.end = np.zeros(channels, dtype=np.int64)
        self.span = span
        self.max_gap = max_gap

    def make_room(self, rows: int) -> None:
        """After a push that left a window with `rows` rows: twice the capacity when that
        filled it (a push moves live rows to the front, but needs one free row)."""
        if rows < self.buf.shape[1]:
            return
        old = self.buf
        self.buf = np.zeros((old.shape[0], 2 * old.shape[1], 3))
        for i in range(old.shape[0]):
            live = old[i, self.start[i] : self.end[i]]
            self.buf[i, : len(live)] = live
            self.start[i] = 0
            self.end[i] = len(live)

    def window(self, i: int) -> np.ndarray:
        """Window i's rows [t, a, b], oldest first (a view, as `PoseWindow.window`)."""
        return self.buf[i, self.start[i] : self.end[i]]


class KernelOutputs:
    """A family's signals as one kernel writes them: `vals[j]` is the value of `names[j]`,
    NaN where the signal has no value and then listed by the kernel (its rows, and a bit mask
    of them when there are at most 62). `write` copies them into the tick's dict in one
    `dict.update` and sets the listed ones to None: a NaN the kernel does not list stays a
    value, as it was."""

    __slots__ = ("_nones", "names", "nones", "vals")

    def __init__(self, names: list[str]):
        self.names = names
        self.vals = np.zeros(len(names))
        self.nones = np.zeros(len(names), dtype=np.int64)
        #: bit mask -> {name: None} of its rows (the same few patterns come every tick)
        self._nones: dict[int, dict[str, None]] = {}

    def write(self, out: dict[str, float | None], mask: int, count: int) -> None:
        """`out[names[j]] = vals[j]`, None for the `count` rows the kernel listed."""
        out.update(zip(self.names, self.vals.tolist(), strict=True))
        if count:
            nones = self._nones.get(mask) if mask >= 0 else None
            if nones is None:
                names = self.names
                nones = dict.fromkeys(names[j] for j in self.nones[:count].tolist())
                if mask >= 0:
                    self._nones[mask] = nones
            out.update(nones)


class MetricFamily:
    """One family of signals and the history it needs, stepped once per tick.

    `name` is what the benchmark reports (`MetricEngine.timings`). A family reads another's
    state through `self.engine.family(OtherFamily)` (the registry orders them so that what it
    reads is already computed this tick)."""

    name: ClassVar[str]

    def __init__(self, engine: Engine):
        self.engine = engine
        self.params = engine.params
        self.channels = engine.channels
        self.pairs = engine.pairs

    @property
    def coverage(self) -> dict[str, Coverage]:
        """What each channel can see, read from the engine at every use: a run learns it from
        the stream's header after the engine is built (`evaluator.session`)."""
        return self.engine.coverage

    def step(self, t: float, states: dict[str, ChannelState], out: dict[str, float | None]) -> None:
        """Write this family's signals for the tick at `t` into `out` (None: no value)."""
        raise NotImplementedError
