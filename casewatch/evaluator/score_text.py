"""Precision and recall as a reader sees them, shared by `casewatch tune`'s table and the tuning
page, in a module of its own so that a report imports the wording without the tuning sweeps
(numpy kernels) behind it."""

from __future__ import annotations


def pr_text(row: dict | None, counts: bool = False) -> str:
    """`P 83% R 100%` of a scores row (`n/a` where undefined), with `(tp/fp/fn)` if asked."""
    if row is None:
        return "n/a"
    p = "n/a" if row["precision"] is None else f"{row['precision']:.0%}"
    r = "n/a" if row["recall"] is None else f"{row['recall']:.0%}"
    tail = f" ({row['tp']}/{row['fp']}/{row['fn']})" if counts else ""
    return f"P {p} R {r}{tail}"
