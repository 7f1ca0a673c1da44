"""Saved signals: every per-tick signal value of a run, in one compressed numpy file.

`casewatch run --save-signals` writes `signals.npz` next to `result.json`, so that threshold
tuning (`casewatch tune`, `casewatch calibrate`) never recomputes the metrics. Decision: numpy's
own `.npz` (zip of `.npy` arrays, deflate-compressed) rather than Parquet: numpy is already a
dependency, the file is one dense float matrix with a column per signal, and reading it back is
one call with no schema to map. The arrays:

- `t` (n,): tick times [s], increasing;
- `names` (m,): signal names (unicode);
- `values` (n, m) float64: the value of signal j at tick i, NaN where it had no value (None);
- `period` (): the case's period [s]; `max_gap` (): the case's `max_gap` [s];
- `version` (): the format version (1).

float64 keeps every value bit for bit, so a threshold swept on the saved file splits the ticks
exactly as the evaluator did.
"""

from __future__ import annotations

import dataclasses
import math
import os
import zipfile
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from itertools import chain
from operator import itemgetter
from pathlib import Path
from typing import Any

import numpy as np

from casewatch.errors import CasewatchError

FORMAT_VERSION = 1
FILE_NAME = "signals.npz"


class SignalsError(CasewatchError, ValueError):
    """A saved-signals file that cannot be used (says which file and what is wrong)."""


@dataclass(frozen=True)
class SavedSignals:
    """One run's per-tick signal values (see the module docstring)."""

    path: str
    t: np.ndarray
    names: list[str]
    values: np.ndarray
    period: float
    max_gap: float
    nominal_ticks: int | None = None  # set by `nominal_only`: the ticks that count

    def column(self, name: str) -> np.ndarray:
        """The (n,) values of one signal (NaN: no value)."""
        try:
            return self.values[:, self.names.index(name)]
        except ValueError:
            raise SignalsError(
                f"{self.path}: signal {name!r} was not saved (saved: "
                f"{', '.join(self.names[:8])}{', ...' if len(self.names) > 8 else ''}); "
                "run the log again with this case and --save-signals"
            ) from None

    @property
    def hours(self) -> float:
        """Hours of driving the file holds (its nominal part after `nominal_only`)."""
        ticks = len(self.t) if self.nominal_ticks is None else self.nominal_ticks
        return ticks * self.period / 3600.0


def float_rows(rows: list[tuple[Any, ...]], width: int) -> np.ndarray:
    """(len(rows), width) floats of rows of `width` values, converted in one `np.fromiter` as
    a row assignment converts them: None as NaN, every other value as float()."""
    flat = np.fromiter(chain.from_iterable(rows), np.float64, count=len(rows) * width)
    return flat.reshape(len(rows), width)


def room_for(array: np.ndarray, rows: int) -> np.ndarray:
    """`array`, or a copy doubled as often as needed to hold `rows` rows."""
    while rows > len(array):
        array = np.concatenate([array, np.empty_like(array)])
    return array


class Columns:
    """Per-tick values of some signals, appended tick by tick (NaN: no value); memory grows
    by 8 bytes per signal and tick.

    Why rows wait as tuples: storing a tick's values into a numpy row costs about a
    microsecond and a half whatever its length (numpy converts the list first), more than
    picking them; `add` keeps the tick's values as one tuple (one C call, `operator.itemgetter`)
    and every `BLOCK` ticks they go into the float arrays in one `np.fromiter`, which converts
    each value exactly as a row assignment does (None as NaN, every other value as float()).
    Every reader flushes first, so nothing outside sees the waiting rows."""

    #: Ticks that wait as tuples before one conversion: large enough to spread its fixed cost
    #: (64 saves no more), small enough that the tick that converts them (on the live path
    #: too: the recorder, `DriveLog`) pays only about 20 microseconds once, of a 1 ms budget.
    BLOCK = 32

    def __init__(self, names: list[str]):
        self.names = list(names)
        self._index = {n: j for j, n in enumerate(self.names)}
        self._t = np.empty(1024)
        self._values = np.empty((1024, len(self.names)))
        #: ticks added; `_stored` of them are in the arrays, the rest wait in `_rows`
        self.n = 0
        self._stored = 0
        self._rows: list[tuple[Any, ...]] = []
        self._times: list[float] = []
        #: the tick's values as a tuple in `names` order (`itemgetter` of one name gives no
        #: tuple: then, and once a tick lacked a name, `values.get` picks them, None for a
        #: missing one)
        self._pick: Callable[[Mapping[str, float | None]], tuple[Any, ...]] | None = (
            itemgetter(*self.names) if len(self.names) > 1 else None
        )

    def add(self, t: float, values: Mapping[str, float | None]) -> None:
        pick = self._pick
        if pick is None:
            row = tuple(map(values.get, self.names))
        else:
            try:
                row = pick(values)
            except KeyError:
                self._pick = None
                row = tuple(map(values.get, self.names))
        rows = self._rows
        rows.append(row)
        self._times.append(t)
        self.n += 1
        if len(rows) >= self.BLOCK:
            self._flush()

    def _flush(self) -> None:
        """The waiting rows into the arrays (doubled when full), in one conversion each."""
        rows = self._rows
        if not rows:
            return
        k = len(rows)
        start = self._stored
        stop = start + k
        self._t = room_for(self._t, stop)
        self._values = room_for(self._values, stop)
        self._values[start:stop] = float_rows(rows, len(self.names))
        self._t[start:stop] = np.fromiter(self._times, np.float64, count=k)
        self._stored = stop
        self._rows = []
        self._times = []

    @property
    def t(self) -> np.ndarray:
        self._flush()
        return self._t[: self.n]

    def column(self, name: str) -> np.ndarray:
        self._flush()
        return self._values[: self.n, self._index[name]]

    @property
    def values(self) -> np.ndarray:
        """(n, m): tick i, signal j (NaN: no value)."""
        self._flush()
        return self._values[: self.n]

    def row(self, i: int) -> RowView:
        self._flush()
        return RowView(self, i)


class RowView(Mapping[str, float | None]):
    """One tick of `Columns` as the evaluator reads its values (`get`; NaN reads as None)."""

    __slots__ = ("_columns", "_i")

    def __init__(self, columns: Columns, i: int):
        self._columns = columns
        self._i = i

    def __getitem__(self, name: str) -> float | None:
        columns = self._columns
        if columns._rows:  # a tick added since this view was made
            columns._flush()
        j = columns._index[name]
        v = float(columns._values[self._i, j])
        return None if math.isnan(v) else v

    def get(self, name: str, default: Any = None) -> Any:  # type: ignore[override]
        if name not in self._columns._index:
            return default
        return self[name]

    def __iter__(self):
        return iter(self._columns.names)

    def __len__(self) -> int:
        return len(self._columns.names)


class SignalRecorder:
    """Collects the values of `names` tick by tick; `save` writes them (atomically)."""

    def __init__(self, names: list[str], period: float, max_gap: float):
        self.names = list(names)
        self.period = period
        self.max_gap = max_gap
        self._columns = Columns(self.names)

    def add(self, t: float, values: Mapping[str, float | None]) -> None:
        self._columns.add(t, values)

    def save(self, path: Path) -> Path:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        values = self._columns.values
        tmp = path.with_name(path.name + ".tmp")
        with open(tmp, "wb") as fh:
            np.savez_compressed(
                fh,
                t=self._columns.t,
                names=np.array(self.names, dtype=str),
                values=values,
                period=np.float64(self.period),
                max_gap=np.float64(self.max_gap),
                version=np.int64(FORMAT_VERSION),
            )
        os.replace(tmp, path)
        return path


def load_signals(path: str | Path) -> SavedSignals:
    """Read a `signals.npz`; SignalsError names the file and the problem."""
    path = Path(path)
    if path.is_dir():
        path = path / FILE_NAME
    where = str(path)
    if not path.is_file():
        raise SignalsError(f"{where}: no saved signals; run the log with --save-signals")
    try:
        with np.load(path, allow_pickle=False) as data:
            arrays = {k: data[k] for k in data.files}
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as exc:
        raise SignalsError(f"{where}: not a saved-signals file ({exc})") from None
    missing = [
        k for k in ("t", "names", "values", "period", "max_gap", "version") if k not in arrays
    ]
    if missing:
        raise SignalsError(f"{where}: not a saved-signals file (missing {', '.join(missing)})")
    read = {k: _scalar(arrays[k]) for k in ("version", "period", "max_gap")}
    bad = [k for k, v in read.items() if v is None or not math.isfinite(v) or v <= 0]
    if bad:  # a NaN or array period would fail far from here (tune, calibrate)
        raise SignalsError(
            f"{where}: {', '.join(bad)} must be a finite number above 0, got "
            + ", ".join(repr(arrays[k].tolist())[:40] for k in bad)
        )
    scalars = {k: float(v) for k, v in read.items() if v is not None}
    if int(scalars["version"]) != FORMAT_VERSION:
        raise SignalsError(
            f"{where}: format version {scalars['version']:g}, this casewatch "
            f"reads {FORMAT_VERSION}; run the log again with --save-signals"
        )
    if arrays["t"].ndim != 1 or arrays["names"].ndim != 1 or arrays["t"].dtype.kind not in "fiu":
        raise SignalsError(f"{where}: t and names must be lists (1-D arrays), t of numbers")
    t = arrays["t"].astype(np.float64)
    if not np.isfinite(t).all():
        raise SignalsError(f"{where}: a tick time is not a finite number")
    names = [str(n) for n in arrays["names"].tolist()]
    values = arrays["values"]
    if values.dtype.kind not in "fiub":
        raise SignalsError(f"{where}: values must be numbers, found {values.dtype}")
    if values.ndim != 2 or values.shape != (len(t), len(names)):
        raise SignalsError(
            f"{where}: values are {values.shape}, expected ({len(t)}, "
            f"{len(names)}) (ticks x signals)"
        )
    if len(t) and not np.all(np.diff(t) > 0):
        raise SignalsError(f"{where}: tick times do not increase")
    return SavedSignals(
        where, t, names, values.astype(np.float64), scalars["period"], scalars["max_gap"]
    )


def _scalar(array: np.ndarray) -> float | None:
    """The number a 0-d numeric array holds, else None."""
    if array.ndim != 0 or array.dtype.kind not in "fiu":
        return None
    return float(array)


def nominal_only(log: SavedSignals, labels: list, margin: float) -> SavedSignals:
    """`log` with every tick within `margin` seconds of a label turned into a data gap (NaN),
    so only its nominal stretches count (`evaluator.nominal.nominal_mask`); `hours` then counts
    the nominal ticks only."""
    if not labels:
        return log
    from casewatch.evaluator.nominal import nominal_mask

    keep = nominal_mask(log.t, labels, margin)
    values = log.values.copy()
    values[~keep] = np.nan
    return dataclasses.replace(log, values=values, nominal_ticks=int(keep.sum()))
