"""The per-tick bookkeeping of a run written a row at a time into preallocated arrays
(`Columns.add`, `DriveLog`) holds what the per-value loops and plain lists it replaced held,
value for value, on random ticks (missing values, None, ints, bools, infinities, NaN)."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from casewatch.evaluator.drive_log import TRACK_POINTS, DriveLog
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
)
row = st.dictionaries(st.sampled_from([*NAMES, "other"]), value)


def _old_columns(ticks: list[tuple[float, dict]], names: list[str]) -> tuple[list, list]:
    """`Columns.add` before: one assignment per value, None as NaN."""
    t = np.empty(len(ticks))
    values = np.empty((len(ticks), len(names)))
    for i, (ti, row_) in enumerate(ticks):
        t[i] = ti
        for j, name in enumerate(names):
            v = row_.get(name)
            values[i, j] = math.nan if v is None else v
    return t.tolist(), [[repr(x) for x in r] for r in values.tolist()]


@given(rows=st.lists(row, max_size=60))
@settings(max_examples=200, deadline=None)
def test_columns_hold_what_the_loop_held(rows):
    ticks = [(i * 0.1, r) for i, r in enumerate(rows)]
    columns = Columns(NAMES)
    for t, r in ticks:
        columns.add(t, r)
    t, values = _old_columns(ticks, NAMES)
    assert columns.t.tolist() == t
    assert [[repr(x) for x in r] for r in columns.values.tolist()] == values  # -0.0, NaN


def test_columns_grow_past_their_first_block():
    columns = Columns(["a"])
    for i in range(3000):
        columns.add(i * 0.1, {"a": None if i % 3 == 0 else float(i)})
    assert columns.n == 3000
    assert math.isnan(columns.column("a")[2997]) and columns.column("a")[2998] == 2998.0
    assert columns.row(2997).get("a") is None and columns.row(1)["a"] == 1.0


class _ListDriveLog:
    """`DriveLog` before: plain lists."""

    def __init__(self) -> None:
        self.t: list = []
        self.x: list = []
        self.y: list = []
        self.values: dict = {name: [] for name in TICK_SIGNALS}

    def add(self, frame, trusted, values) -> None:
        state = frame.channels.get(trusted) if trusted else None
        if state is None and frame.channels:
            state = next(iter(frame.channels.values()))
        self.t.append(frame.t)
        self.x.append(state.ego.x if state is not None else math.nan)
        self.y.append(state.ego.y if state is not None else math.nan)
        for name, column in self.values.items():
            v = values.get(name)
            column.append(math.nan if v is None else float(v))

    def place(self, episodes) -> None:
        if not self.t:
            return
        t = np.asarray(self.t, dtype=float)
        for e in episodes:
            k = min(int(np.searchsorted(t, e.start - 1e-9)), len(t) - 1)
            if math.isfinite(self.x[k]):
                e.x, e.y = round(self.x[k], 3), round(self.y[k], 3)

    def track(self) -> list:
        keep = [k for k in range(len(self.t)) if math.isfinite(self.x[k])]
        step = max(1, math.ceil(len(keep) / TRACK_POINTS))
        picked = keep[::step]
        if keep and picked[-1] != keep[-1]:
            picked.append(keep[-1])
        return [[round(self.t[k], 6), round(self.x[k], 3), round(self.y[k], 3)] for k in picked]


coordinate = st.one_of(st.floats(-1e4, 1e4), st.just(math.nan), st.just(math.inf))
channel = st.builds(
    lambda x, y: SimpleNamespace(ego=SimpleNamespace(x=x, y=y)), coordinate, coordinate
)
frame_channels = st.dictionaries(st.sampled_from(["lav", "tfuse"]), channel, max_size=2)
tick_values = st.dictionaries(
    st.sampled_from([*TICK_SIGNALS, "els"]),
    value.filter(lambda v: not isinstance(v, int) or abs(v) < 2**53),
)


@given(
    ticks=st.lists(
        st.tuples(frame_channels, st.sampled_from([None, "lav", "tfuse", "gone"]), tick_values),
        max_size=80,
    ),
    starts=st.lists(st.floats(-1.0, 10.0), max_size=5),
)
@settings(max_examples=200, deadline=None)
def test_drive_log_holds_what_the_lists_held(ticks, starts):
    new, old = DriveLog(), _ListDriveLog()
    for i, (channels, trusted, values) in enumerate(ticks):
        frame = SimpleNamespace(t=round(i * 0.1, 6), channels=channels)
        new.add(frame, trusted, values)  # type: ignore[arg-type]
        old.add(frame, trusted, values)
    assert new.times().tolist() == old.t
    assert {k: [repr(x) for x in v.tolist()] for k, v in new.columns().items()} == {
        k: [repr(x) for x in v] for k, v in old.values.items()
    }
    assert repr(new.track()) == repr(old.track())
    episodes = [
        Episode(
            formula_id="Sn1",
            node_id="Sn1",
            kind="spi",
            start=s,
            end=s,
            ticks=1,
            worst_robustness=-1.0,
            t_worst=s,
            trace=[],
        )
        for s in starts
    ]
    placed = [e.model_copy() for e in episodes]
    new.place(episodes)
    old.place(placed)
    assert repr([(e.x, e.y) for e in episodes]) == repr([(e.x, e.y) for e in placed])


def test_drive_log_grows_and_decimates_its_track():
    log = DriveLog()
    lav = SimpleNamespace(ego=SimpleNamespace(x=1.23456, y=-2.0))
    for i in range(2 * TRACK_POINTS):
        log.add(SimpleNamespace(t=i * 0.1, channels={"lav": lav}), "lav", {"ego_speed": 3})  # type: ignore[arg-type]
    track = log.track()
    assert len(track) == TRACK_POINTS + 1  # every other point and the last
    assert track[0] == [0.0, 1.235, -2.0] and track[-1][0] == round((2 * TRACK_POINTS - 1) * 0.1, 6)
    assert log.columns()["ego_speed"].tolist() == [3.0] * (2 * TRACK_POINTS)
