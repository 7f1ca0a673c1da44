"""False alarms of the SPIs on nominal driving: the share of evaluated ticks each SPI reads as
violated outside every labelled hazard.

An SPI that turns red on nominal driving measures the sampling grid, the horizon or the sensor
noise, not the driving; an assessor who sees that stops reading. This is the figure behind the
"every SPI violated on at most 1 % of nominal ticks" target of the bundled drives
(`make demo` prints it per SPI and drive).

**Nominal tick**: a tick farther than `margin` seconds (default 3 s, the comfort fit span, so
the lag of the history metrics does not leak a hazard into its surroundings) from every
labelled interval, of any hazard. Only ticks at which the SPI was evaluated count (no-data
ticks are neither passes nor violations). The tick statuses come from the run's own node
status timelines, so the figure is exactly the verdict the report shows.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from casewatch.evaluator.ground_truth import Label
from casewatch.evaluator.result import RunResult

#: Seconds around every label that do not count as nominal (see module docstring).
DEFAULT_MARGIN = 3.0


@dataclass(frozen=True)
class NominalShare:
    """One SPI on one run: evaluated nominal ticks and how many of them were violated."""

    node_id: str
    signal: str
    evaluated: int
    violated: int

    @property
    def share(self) -> float | None:
        """Violated / evaluated, None when no nominal tick was evaluated."""
        return self.violated / self.evaluated if self.evaluated else None


def nominal_mask(times: np.ndarray, labels: list[Label], margin: float) -> np.ndarray:
    """(n,) True where a tick time lies farther than `margin` from every label interval."""
    keep = np.ones(len(times), dtype=bool)
    for label in labels:
        keep &= (times < label.start - margin - 1e-9) | (times > label.end + margin + 1e-9)
    return keep


def nominal_shares(
    result: RunResult, labels: list[Label], margin: float = DEFAULT_MARGIN
) -> list[NominalShare]:
    """Per SPI formula of `result` (in case order), its violated share of nominal ticks."""
    timelines = {s.node_id: s.timeline for s in result.status}
    out = []
    for formula in result.formulas:
        if formula.kind != "spi":
            continue
        evaluated = violated = 0
        for interval in timelines.get(formula.node_id, []):
            if interval.status not in ("satisfied", "violated"):
                continue
            times = np.linspace(interval.start, interval.end, interval.ticks)
            n = int(nominal_mask(times, labels, margin).sum())
            evaluated += n
            if interval.status == "violated":
                violated += n
        out.append(
            NominalShare(formula.node_id, formula.signal or formula.source, evaluated, violated)
        )
    return out
