"""Which engine computes robustness: rtamt tick by tick, numpy over the whole log, or both.

- `rtamt` (default): one online rtamt monitor per formula, fed every tick (`evaluator.core`).
  The only engine for a live stream.
- `numpy`: for logs. The metrics of every tick are computed first and kept as columns; each
  formula is then evaluated over the whole log at once (`evaluator.vector_eval`), and the
  episodes, gaps and statuses are formed from those arrays (`evaluator.whole_log`), as the
  evaluator would form them replaying the ticks with those values (`PrecomputedMonitor`; the
  replay stays for what the arrays cannot give, and tests hold the two to each other).
- `both`: rtamt runs, and each of its values is compared with the numpy engine's for the same
  tick; any difference over 1e-9 (or a differing infinity) is an `EngineMismatch` naming the
  formula and the tick. Two independent evaluators that must agree guard against either
  giving a wrong answer.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np

from casewatch.errors import EXIT_ENGINES_DISAGREE, CasewatchError
from casewatch.evaluator.signal_store import Columns
from casewatch.evaluator.vector_eval import Segments, evaluated_ticks, robustness
from casewatch.spec.ast import Formula
from casewatch.spec.model import CompiledFormula, CompiledSpec
from casewatch.spec.parser import parse_rtamt

ENGINES = ("rtamt", "numpy", "both")

#: Largest difference between the engines' robustness that still counts as agreement.
TOLERANCE = 1e-9


def input_names(spec: CompiledSpec) -> list[str]:
    """Every signal the formulas read or show."""
    names = {n for f in spec.formulas for g in f.monitored() for n in g.signals}
    names |= {f.signal for f in spec.formulas if f.signal}
    return sorted(names)


@dataclass(frozen=True)
class WholeLog:
    """Each formula's robustness at its evaluated ticks, in tick order, and those ticks."""

    values: dict[str, np.ndarray]
    ticks: dict[str, np.ndarray]
    t: np.ndarray


def evaluate_whole_log(spec: CompiledSpec, columns: Columns, max_gap: float) -> WholeLog:
    """Every formula over the whole log (ticks where an input has no value are gaps, and the
    monitor restarts there and at time jumps over `max_gap`, as `evaluator.core` does)."""
    t = columns.t
    values: dict[str, np.ndarray] = {}
    ticks: dict[str, np.ndarray] = {}
    for f in (g for formula in spec.formulas for g in formula.monitored()):
        ast = _parsed(f.rtamt, spec.period)
        cols = {name: columns.column(name) for name in f.signals}
        rho = robustness(ast, cols, t, spec.period, max_gap)
        index = Segments(t, evaluated_ticks(ast, cols), max_gap).index
        values[f.id] = rho[index]
        ticks[f.id] = index
    return WholeLog(values, ticks, t)


@lru_cache(maxsize=1024)
def _parsed(text: str, period: float) -> Formula:
    """A formula's rtamt text read back once per process, not once per log (the nodes are
    frozen values, so one tree serves every log)."""
    return parse_rtamt(text, period)


class PrecomputedMonitor:
    """rtamt's online interface over precomputed values: the k-th `update` returns the value
    at the formula's k-th evaluated tick (the evaluator updates exactly at those ticks)."""

    def __init__(self, values: np.ndarray):
        self._values = values.tolist()
        self._k = 0

    def reset(self) -> None:
        pass  # the restarts are already in the values

    def update(self, _i: int, _inputs: Any) -> float:
        value = self._values[self._k]
        self._k += 1
        return value


@dataclass(frozen=True)
class Mismatch:
    formula_id: str
    t: float
    rtamt: float
    numpy: float

    def format(self) -> str:
        return f"{self.formula_id} at t = {self.t:g} s: rtamt {self.rtamt!r}, numpy {self.numpy!r}"


class EngineMismatch(CasewatchError):
    """The two STL engines disagree (a bug in one of them, never a verdict)."""

    exit_code = EXIT_ENGINES_DISAGREE

    def __init__(self, mismatches: list[Mismatch], total: int):
        shown = "\n".join(f"  {m.format()}" for m in mismatches)
        super().__init__(
            f"the rtamt and numpy STL engines disagree on {total} value(s), "
            f"first {len(mismatches)}:\n{shown}"
        )
        self.mismatches = mismatches
        self.total = total


class CheckedMonitor:
    """rtamt's monitor, each of whose values is compared with the numpy engine's."""

    def __init__(
        self,
        rtamt: Any,
        formula: CompiledFormula,
        whole: WholeLog,
        found: list[Mismatch],
        counter: list[int],
    ):
        self._rtamt = rtamt
        self._id = formula.id
        self._warmup = formula.warmup_ticks
        self._values = whole.values[formula.id].tolist()
        self._ticks = whole.ticks[formula.id]
        self._t = whole.t
        self._k = 0
        self._found = found
        self._counter = counter

    def reset(self) -> None:
        self._rtamt.reset()

    def update(self, i: int, inputs: Any) -> float:
        theirs = float(self._rtamt.update(i, inputs))
        ours = self._values[self._k]
        # a `sum` window still filling has no verdict (evaluator.core): inf - inf is NaN there,
        # and rtamt's min/max and numpy's treat NaN differently
        if i >= self._warmup and not _agree(theirs, ours):
            self._counter[0] += 1
            if len(self._found) < 20:
                self._found.append(
                    Mismatch(self._id, float(self._t[self._ticks[self._k]]), theirs, ours)
                )
        self._k += 1
        return theirs


def _agree(a: float, b: float) -> bool:
    if math.isinf(a) or math.isinf(b) or math.isnan(a) or math.isnan(b):
        return a == b or (math.isnan(a) and math.isnan(b))
    return abs(a - b) <= TOLERANCE
