"""How casewatch writes a number into text a person or a parser reads back.

It sits in the lowest layer because both the YAML side (contract parameters, `tune`'s rewritten
thresholds) and the formula side (`casewatch.spec.emit`) write numbers, and they must write the
same number the same way: a threshold copied from a report into the YAML reads back equal.
"""

from __future__ import annotations

import math


def number_text(value: float) -> str:
    """Shortest text that reads back as the same float (`repr`), refusing inf and nan."""
    if not math.isfinite(value):
        raise ValueError(f"not a finite number: {value}")
    return repr(float(value))
