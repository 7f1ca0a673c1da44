"""`Columns` and `DriveLog` keep a tick as a tuple and convert them a block at a time (issue
36, per-frame glue): they hold what the row-at-a-time versions they replaced held, value for
value (missing values, None, ints, bools, numpy scalars, infinities, NaN, -0.0), whatever the
block size, with reads in between adds, and after a tick that lacks a name."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from casewatch.evaluator.drive_log import DriveLog
from casewatch.evaluator.result import Episode
from casewatch.evaluator.scoring import TICK_SIGNALS
from casewatch.evaluator.signal_store import Columns

NAMES = ["a", "b", "c", "ego_speed"]

value = st.one_of(
    st.none(),
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(-(2**60), 2**60),
    st.booleans(),
    st.floats(-1e3, 1e3).map(np.float32),
    st.floats(-1e3, 1e3).map(np.float64),
)
#: a tick's values: usually every name (the fast pick), sometimes one missing (the fallback)
full_row = st.fixed_dictionaries({n: value for n in NAMES}, optional={"other": value})
some_row = st.dictionaries(st.sampled_from([*NAMES, "other"]), value)
row = st.one_of(full_row, full_row, some_row)
blocks = st.sampled_from([1, 2, 3, 7, 64])


class _RowColumns:
    """`Columns` before issue 36's fourth round: one row assignment per tick."""

    def __init__(self, names: list[str]):
        self.names = names
        self._t = np.empty(1024)
        self._values = np.empty((1024, len(names)))
        self.n = 0

    def add(self, t, values) -> None:
        if self.n == len(self._t):
            self._t = np.concatenate([self._t, np.empty(len(self._t))])
            self._values = np.concatenate([self._values, np.empty_like(self._values)])
        self._t[self.n] = t
        self._values[self.n] = list(map(values.get, self.names))
        self.n += 1


def _bits(a: np.ndarray) -> list:
    return [repr(x) for x in np.asarray(a).ravel().tolist()]  # -0.0 and NaN compared too


@given(
    rows=st.lists(row, max_size=300),
    block=blocks,
    reads=st.sets(st.integers(0, 300), max_size=4),
    names=st.sampled_from([NAMES, ["b"], [], ["c", "a"]]),
)
@settings(max_examples=150, deadline=None)
def test_columns_hold_what_row_assignment_held(rows, block, reads, names):
    new, old = Columns(names), _RowColumns(names)
    new.BLOCK = block
    for i, r in enumerate(rows):
        t = i * 0.1 if i % 5 else float(i)  # some whole times
        new.add(t, r)
        old.add(t, r)
        assert new.n == old.n == i + 1
        if i in reads:  # a read in between flushes the waiting rows; adds go on after it
            assert _bits(new.values) == _bits(old._values[: old.n])
    assert _bits(new.t) == _bits(old._t[: old.n])
    assert _bits(new.values) == _bits(old._values[: old.n])
    for j, name in enumerate(names):
        assert _bits(new.column(name)) == _bits(old._values[: old.n, j])
    if rows and names:
        last = new.row(len(rows) - 1)
        want = old._values[old.n - 1].tolist()
        assert [last.get(n) for n in names] == [None if math.isnan(v) else v for v in want]


def test_a_row_view_sees_ticks_added_after_it():
    columns = Columns(["a", "b"])
    columns.add(0.0, {"a": 1.0, "b": None})
    view = columns.row(0)
    columns.add(0.1, {"a": 2.0, "b": 3.0})  # waits as a tuple
    later = columns.row(1)
    columns.add(0.2, {"a": 4.0})  # "b" missing: every later tick is picked by `get`
    assert (view.get("a"), view.get("b"), later["b"]) == (1.0, None, 3.0)
    assert columns._pick is None
    assert columns.row(2).get("b") is None and columns.row(2)["a"] == 4.0
    assert columns.t.tolist() == [0.0, 0.1, 0.2] and columns.n == 3


def test_columns_grow_in_blocks_past_their_first_arrays():
    columns = Columns(["a", "b"])
    for i in range(5000):
        columns.add(i * 0.1, {"a": None if i % 3 == 0 else float(i), "b": i})
    assert columns.n == 5000 and columns.values.shape == (5000, 2)
    assert columns.column("b").tolist() == [float(i) for i in range(5000)]
    assert math.isnan(columns.column("a")[4998]) and columns.column("a")[4999] == 4999.0


class _RowDriveLog:
    """`DriveLog` before issue 36's fourth round: one row assignment per array and tick."""

    def __init__(self) -> None:
        self.n = 0
        self._t = np.empty(1024)
        self._xy = np.empty((1024, 2))
        self._values = np.empty((1024, len(TICK_SIGNALS)))

    def add(self, frame, trusted, values) -> None:
        n = self.n
        if n == len(self._t):
            self._t = np.concatenate([self._t, np.empty(n)])
            self._xy = np.concatenate([self._xy, np.empty_like(self._xy)])
            self._values = np.concatenate([self._values, np.empty_like(self._values)])
        state = frame.channels.get(trusted) if trusted else None
        if state is None and frame.channels:
            state = next(iter(frame.channels.values()))
        self._t[n] = frame.t
        self._xy[n] = (state.ego.x, state.ego.y) if state is not None else (math.nan, math.nan)
        self._values[n] = list(map(values.get, TICK_SIGNALS))
        self.n = n + 1


coordinate = st.one_of(st.floats(-1e4, 1e4), st.just(math.nan), st.just(math.inf), st.just(-0.0))
channel = st.builds(
    lambda x, y: SimpleNamespace(ego=SimpleNamespace(x=x, y=y)), coordinate, coordinate
)
frame_channels = st.dictionaries(st.sampled_from(["lav", "tfuse"]), channel, max_size=2)
tick_values = st.dictionaries(st.sampled_from([*TICK_SIGNALS, "els"]), value)


def _episode(start: float) -> Episode:
    return Episode(
        formula_id="Sn1",
        node_id="Sn1",
        kind="spi",
        start=start,
        end=start,
        ticks=1,
        worst_robustness=-1.0,
        t_worst=start,
        trace=[],
    )


@given(
    ticks=st.lists(
        st.tuples(frame_channels, st.sampled_from([None, "lav", "tfuse", "gone"]), tick_values),
        max_size=200,
    ),
    block=blocks,
    places=st.dictionaries(st.integers(0, 200), st.floats(-1.0, 25.0), max_size=4),
)
@settings(max_examples=150, deadline=None)
def test_drive_log_holds_what_row_assignment_held(ticks, block, places):
    new, old = DriveLog(), _RowDriveLog()
    new.BLOCK = block
    for i, (channels, trusted, values) in enumerate(ticks):
        frame = SimpleNamespace(t=round(i * 0.1, 6), channels=channels)
        new.add(frame, trusted, values)  # type: ignore[arg-type]
        old.add(frame, trusted, values)
        if i in places:  # an episode closes mid-stream: its position from the ticks so far
            e = _episode(places[i])
            new.place([e])
            k = min(int(np.searchsorted(old._t[: old.n], e.start - 1e-9)), old.n - 1)
            x, y = old._xy[k].tolist()
            want = (round(x, 3), round(y, 3)) if math.isfinite(x) else (None, None)
            assert repr((e.x, e.y)) == repr(want)
    n = old.n
    assert new.n == n
    assert _bits(new.times()) == _bits(old._t[:n])
    assert new.t == old._t[:n].tolist()
    assert repr((new.x, new.y)) == repr((old._xy[:n, 0].tolist(), old._xy[:n, 1].tolist()))
    columns = new.columns()
    assert list(columns) == list(TICK_SIGNALS)
    for j, name in enumerate(TICK_SIGNALS):
        assert _bits(columns[name]) == _bits(old._values[:n, j])
