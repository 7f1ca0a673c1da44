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
import os
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

FORMAT_VERSION = 1
FILE_NAME = "signals.npz"


class SignalsError(ValueError):
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


class SignalRecorder:
    """Collects the values of `names` tick by tick; `save` writes them (atomically)."""

    def __init__(self, names: list[str], period: float, max_gap: float):
        self.names = list(names)
        self.period = period
        self.max_gap = max_gap
        self._t: list[float] = []
        self._rows: list[list[float]] = []

    def add(self, t: float, values: dict[str, float | None]) -> None:
        nan = float("nan")
        self._t.append(t)
        self._rows.append([nan if (v := values.get(n)) is None else float(v) for n in self.names])

    def save(self, path: Path) -> Path:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        values = np.array(self._rows, dtype=np.float64).reshape(len(self._rows), len(self.names))
        tmp = path.with_name(path.name + ".tmp")
        with open(tmp, "wb") as fh:
            np.savez_compressed(
                fh, t=np.array(self._t, dtype=np.float64), names=np.array(self.names, dtype=str),
                values=values, period=np.float64(self.period), max_gap=np.float64(self.max_gap),
                version=np.int64(FORMAT_VERSION),
            )  # fmt: skip
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
    missing = [k for k in ("t", "names", "values", "period", "max_gap", "version")
               if k not in arrays]  # fmt: skip
    if missing:
        raise SignalsError(f"{where}: not a saved-signals file (missing {', '.join(missing)})")
    if int(arrays["version"]) != FORMAT_VERSION:
        raise SignalsError(f"{where}: format version {int(arrays['version'])}, this casewatch "
                           f"reads {FORMAT_VERSION}; run the log again with --save-signals")
    t = arrays["t"].astype(np.float64)
    names = [str(n) for n in arrays["names"].tolist()]
    values = arrays["values"]
    if values.ndim != 2 or values.shape != (len(t), len(names)):
        raise SignalsError(f"{where}: values are {values.shape}, expected ({len(t)}, "
                           f"{len(names)}) (ticks x signals)")
    if len(t) and not np.all(np.diff(t) > 0):
        raise SignalsError(f"{where}: tick times do not increase")
    return SavedSignals(where, t, names, values.astype(np.float64), float(arrays["period"]),
                        float(arrays["max_gap"]))  # fmt: skip


def nominal_only(log: SavedSignals, labels: list, margin: float) -> SavedSignals:
    """`log` with every tick within `margin` seconds of a label turned into a data gap (NaN),
    so only its nominal stretches count (`evaluator.nominal.nominal_mask`); `hours` then counts
    the nominal ticks only."""
    if not labels:
        return log
    from evaluator.nominal import nominal_mask

    keep = nominal_mask(log.t, labels, margin)
    values = log.values.copy()
    values[~keep] = np.nan
    return dataclasses.replace(log, values=values, nominal_ticks=int(keep.sum()))
