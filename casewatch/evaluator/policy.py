"""Which episodes fail a run: the `--fail-on` policy of `casewatch run` and `casewatch diff`.

`any` (the default): every SPI episode and hazard event; `hazard`: hazard events only (SPI
episodes are reported, a CI job passes); `spi`: SPI episodes only; `never`: nothing fails on
episodes (input that cannot be used still exits 2). JUnit marks only the gated formulas as
failures, so a CI system shows what the exit code counted.

A damaged log (any stream defect: a truncated file, a refused frame, an undecodable message)
is a finding of its own kind, `damage`, under every policy: the frames it lost were never
judged, so its verdict cannot pass a gate (exit 1 at least; JUnit fails its `stream` test).
"""

from __future__ import annotations

from typing import Literal

FailOn = Literal["any", "hazard", "spi", "never"]
FAIL_ON: tuple[str, ...] = ("any", "hazard", "spi", "never")


def gated(kind: str, policy: str) -> bool:
    """True when an episode of `kind` ("spi" or "hazard") fails a run under `policy`."""
    return policy == "any" or policy == kind


def damaged(defect_count: int) -> bool:
    """True when a log's stream defects make it a `damage` finding (under every policy)."""
    return defect_count > 0
