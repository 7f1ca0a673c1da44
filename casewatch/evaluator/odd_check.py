"""Checking each tick against an ODD specification (`odd:` on a context node, docs/odd.md).

A tick is **inside** when every attribute of the ODD is reported with an accepted value (and,
when the ODD lists combinations, the conditions match one of them), **outside** when an
attribute has a value the ODD does not accept, and **unknown** when an attribute is not
reported at all: missing conditions are not a pass. Layered attributes come from the stream's
conditions (`meta.odd`, frame `odd`); other attributes are signals, read at the tick.

The conditions change rarely (the session hands the same mapping until a frame changes it),
so the layered part of the verdict is memoised on that mapping's identity.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Literal

from casewatch.safety_case.model import OddRange, OddSpec, OddValue

Verdict = Literal["inside", "outside", "unknown"]


def _accepts(accepted: list[OddValue] | OddRange, value: OddValue) -> bool:
    if isinstance(accepted, OddRange):
        if isinstance(value, bool) or not isinstance(value, int | float):
            return False
        return (accepted.min is None or value >= accepted.min) and (
            accepted.max is None or value <= accepted.max
        )
    # by type too: True is not the number 1 here (numbers are floats on both sides)
    return any(type(a) is type(value) and a == value for a in accepted)


class OddCheck:
    """Judges ticks against one ODD; keeps what put ticks outside or unknown, per attribute."""

    def __init__(self, node_id: str, spec: OddSpec):
        self.node_id = node_id
        self.spec = spec
        self.layered = [a for a in spec.attributes if "." in a]
        self.signals = [a for a in spec.attributes if "." not in a]
        self.counts = {"inside": 0, "outside": 0, "unknown": 0}
        self.last: tuple[Verdict, str | None] = ("inside", None)  # what the latest tick was
        self.outside_by: dict[str, int] = {}
        self.unknown_by: dict[str, int] = {}
        self._memo_key: int | None = None
        self._memo: tuple[Verdict, str | None] = ("inside", None)

    def _layered(self, conditions: Mapping[str, OddValue]) -> tuple[Verdict, str | None]:
        for name in self.layered:
            if name not in conditions:
                return "unknown", name
        for name in self.layered:
            if not _accepts(self.spec.attributes[name], conditions[name]):
                return "outside", name
        if self.spec.combinations and not any(
            all(_accepts([v], conditions[k]) for k, v in combo.items())
            for combo in self.spec.combinations
        ):
            return "outside", "combinations"
        return "inside", None

    def judge(
        self, conditions: Mapping[str, OddValue], values: Mapping[str, float | None]
    ) -> Verdict:
        """The verdict at one tick, counted."""
        if id(conditions) != self._memo_key:
            self._memo_key, self._memo = id(conditions), self._layered(conditions)
        verdict, why = self._memo
        if verdict == "inside":
            for name in self.signals:
                value = values.get(name)
                if value is None or not math.isfinite(value):
                    verdict, why = "unknown", name
                    break
                if not _accepts(self.spec.attributes[name], float(value)):
                    verdict, why = "outside", name
                    break
        self.counts[verdict] += 1
        self.last = (verdict, why)
        if verdict == "outside" and why is not None:
            self.outside_by[why] = self.outside_by.get(why, 0) + 1
        elif verdict == "unknown" and why is not None:
            self.unknown_by[why] = self.unknown_by.get(why, 0) + 1
        return verdict
