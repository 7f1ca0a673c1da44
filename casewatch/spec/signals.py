"""Resolving the signal names of a formula against what the case can observe.

The catalogue is `safety_case.signals.available_signals`: the built-in metrics of
`docs/spi-reference.md` (unsuffixed, per pair `els__lav__tfuse`, per channel `ppcs__lav`) for the
declared channels, plus the scalar signals declared under `monitor.signals`.
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass

from casewatch.safety_case.signals import SignalInfo, available_signals
from casewatch.spec.ast import Node, signals_of


@dataclass(frozen=True)
class UnknownSignal:
    """A name the catalogue does not know, where it is, and what it probably meant."""

    name: str
    col: int  # 1-based column in the formula text
    suggestion: str | None
    families: tuple[str, ...]  # the unsuffixed metric names plus declared signals, for the hint

    def message(self, node_id: str | None = None) -> str:
        where = f" of node {node_id}" if node_id else ""
        text = f"unknown signal {self.name!r} in formula{where}"
        if self.suggestion:
            text += f"; did you mean {self.suggestion!r}?"
        return text

    def hint(self, channels: list[str]) -> str:
        chans = ", ".join(channels)
        return (
            f"(signals available for channels {chans}: {', '.join(self.families)}; "
            f"per pair 'NAME__A__B', per channel 'NAME__C')"
        )


def signal_families(catalogue: dict[str, SignalInfo]) -> tuple[str, ...]:
    """The names without channel suffixes, in catalogue order: what a user chooses from."""
    return tuple(name for name, info in catalogue.items() if name == info.metric)


def resolve_signals(
    formula: Node, channels: list[str], declared: dict[str, str] | None = None
) -> tuple[list[str], list[UnknownSignal]]:
    """Sorted known signal names used by `formula`, and every unknown occurrence."""
    catalogue = available_signals(channels, declared)
    families = signal_families(catalogue)
    known: set[str] = set()
    unknown: list[UnknownSignal] = []
    for sig in signals_of(formula):
        if sig.name in catalogue:
            known.add(sig.name)
            continue
        close = difflib.get_close_matches(sig.name, list(catalogue), n=1, cutoff=0.6)
        unknown.append(UnknownSignal(sig.name, sig.col, close[0] if close else None, families))
    return sorted(known), unknown
