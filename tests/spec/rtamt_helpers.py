"""Small helpers to drive rtamt 0.4.10 directly in tests (naive text vs. our emitted text)."""

from __future__ import annotations

import warnings
from typing import Any

from casewatch.spec.emit import new_rtamt_spec


def online(text: str, trace: dict[str, list[float]], period: float = 0.1) -> list[float]:
    """rtamt online robustness of `text` at every sample of `trace`."""
    monitor = new_rtamt_spec(text, list(trace), period)
    n = len(next(iter(trace.values())))
    return [
        monitor.update(i * period, [(name, float(v[i])) for name, v in trace.items()])
        for i in range(n)
    ]


def offline(text: str, trace: dict[str, list[float]], period: float = 0.1) -> list[float]:
    """rtamt offline (whole-trace) robustness of `text`, which may use future operators."""
    spec: Any = new_rtamt_spec(text, list(trace), period)
    n = len(next(iter(trace.values())))
    data: dict[str, list[float]] = {"time": [i * period for i in range(n)]}
    data.update({name: [float(x) for x in v] for name, v in trace.items()})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return [v for _t, v in spec.evaluate(data)]
