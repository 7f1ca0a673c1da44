"""Injected-fault labels: which SPI-relevant fault happened where, and which SPIs must see it.

A fault-labels file (`NAME.fault-labels.jsonl`, beside a stream `NAME.jsonl.gz`) holds one JSON
object a line:

    {"fault": "object_drop", "start": 41.2, "end": 44.7, "channel": "tfuse", ...}

`fault` is one of `FAMILY_SIGNALS`; `start` and `end` are the first and last tick of the fault
(seconds, closed interval); `channel` the channel it was injected into; any other key is
information (the object, the offset). Ground-truth hazard labels stay in `NAME.labels.jsonl`:
a fault is not a hazard, it is a defect of one channel that an SPI exists to reveal.

Each family names the signals whose SPIs claim to reveal it (docs/spi-reference.md, "Fault
injection"). An SPI detects a fault when one of its episodes overlaps the fault interval
extended by `DETECTION_SLACK` seconds (persistence `for:` and the comfort fits' lag report a
fault after it began, never before), and the same drive without the fault has no episode of
that SPI there (`detected`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from casewatch.errors import CasewatchError
from casewatch.evaluator.ground_truth import label_interval, label_lines

#: Fault family -> the built-in signals whose SPIs must reveal it.
FAMILY_SIGNALS: dict[str, tuple[str, ...]] = {
    # a real object one channel does not report for 2-5 s, inside both coverages
    "object_drop": ("lone_age",),
    # an object one channel reports where nothing is, for 2 s, inside both coverages
    "phantom": ("lone_age",),
    # one channel's plan shifted sideways by 1-2 m
    "plan_lateral": ("plan_lat", "ets"),
    # one channel's predictions point the wrong way (a sign error in its prediction module)
    "prediction_reversed": ("ots", "ompv"),
    # one channel's ego estimate drifts away from the truth
    "localisation_drift": ("els", "ego_dist"),
    # one channel repeats its last frame (ego, objects, plan) for 2-3 s (relative to its own
    # frozen ego its plan is unchanged: ets with ets_relative and chpps cannot see it)
    "frozen_channel": ("els",),
}

#: Seconds after a fault's end in which an SPI episode still counts as its detection.
DETECTION_SLACK = 2.0


class FaultLabelsError(CasewatchError, ValueError):
    """A fault-labels file that cannot be used; the message names the file, line and key."""


@dataclass(frozen=True)
class FaultLabel:
    """One injected fault: its family, closed interval [start, end] (s) and channel."""

    fault: str
    start: float
    end: float
    channel: str
    line: int

    @property
    def signals(self) -> tuple[str, ...]:
        """The signals whose SPIs must reveal this fault."""
        return FAMILY_SIGNALS[self.fault]


def fault_labels_path(stream_or_labels: Path) -> Path:
    """`NAME.fault-labels.jsonl` beside `NAME.jsonl.gz` or `NAME.labels.jsonl`."""
    name = stream_or_labels.name
    for suffix in (".labels.jsonl", ".jsonl.gz", ".jsonl"):
        if name.endswith(suffix):
            return stream_or_labels.with_name(name[: -len(suffix)] + ".fault-labels.jsonl")
    return stream_or_labels.with_name(name + ".fault-labels.jsonl")


def read_fault_labels(path: str | Path) -> list[FaultLabel]:
    """Every fault of a fault-labels file, in file order."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise FaultLabelsError(f"{path}: cannot read fault labels: {exc.strerror}") from None
    out: list[FaultLabel] = []
    example = '{"fault": "object_drop", "start": 4.0, "end": 7.0, "channel": "lav"}'
    for number, where, item in label_lines(path, data, FaultLabelsError, example):
        fault = item.get("fault")
        if fault not in FAMILY_SIGNALS:
            raise FaultLabelsError(
                f"{where}: 'fault' must be one of {', '.join(FAMILY_SIGNALS)}, got {fault!r}"
            )
        start, end = label_interval(item, where, FaultLabelsError)
        channel = item.get("channel")
        if not isinstance(channel, str) or not channel:
            raise FaultLabelsError(f"{where}: 'channel' must name the faulty channel")
        out.append(FaultLabel(fault, start, end, channel, number))
    return out


def overlaps(
    episodes: list[tuple[float, float]], fault: FaultLabel, slack: float = DETECTION_SLACK
) -> bool:
    """Whether an episode (closed [start, end]) overlaps [fault.start, fault.end + slack]."""
    return any(s <= fault.end + slack and fault.start <= e for s, e in episodes)


def detected(
    with_fault: list[tuple[float, float]],
    without_fault: list[tuple[float, float]] | None,
    fault: FaultLabel,
    slack: float = DETECTION_SLACK,
) -> bool:
    """The detection rule of docs/spi-reference.md: an episode of the faulty drive overlaps the
    fault (plus `slack`) and, when the same drive without the fault is known, it had no episode
    there (an alarm that was there anyway is not a detection of the fault)."""
    if not overlaps(with_fault, fault, slack):
        return False
    return without_fault is None or not overlaps(without_fault, fault, slack)
