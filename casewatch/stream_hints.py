"""Why a stream was refused, in a few terminal lines (`casewatch run`).

When no frame could be read, or the root goal had no data on most ticks, the cause is in
`result.json` (`stream.defects`, `stream.dropouts`), which nobody reads at that moment. These
lines bring it to the terminal: the first defects of each kind with their line numbers, and
for channels the names the case declares against the names the stream uses, with a
did-you-mean (`channels: [lav, tfuze]` against a stream of lav and tfuse).
"""

from __future__ import annotations

import difflib
import re
from pathlib import Path

from casewatch.evaluator.result import RunResult
from casewatch.reports.render import ResultError, load_result

#: Defects quoted per kind; the rest is counted.
QUOTED = 2

_UNDECLARED = (
    re.compile(r"header lists channel\(s\) (.+?) not declared"),
    re.compile(r"channels\.([^:\s]+): channel not declared"),
)


def _undeclared(result: RunResult) -> list[str]:
    """Channel names the stream uses and the case does not declare, in order of appearance."""
    names: list[str] = []
    for defect in result.stream.defects:
        if defect.kind != "unknown-channel":
            continue
        for pattern in _UNDECLARED:
            found = pattern.search(defect.message)
            if found:
                for name in found.group(1).split(", "):
                    if name not in names:
                        names.append(name)
    return names


def channel_hint(result: RunResult) -> list[str]:
    """Declared vs found channel names with a did-you-mean, or nothing when they agree."""
    declared = list(result.case.channels)
    stream = result.stream
    undeclared = _undeclared(result)
    absent = [
        c
        for c in declared
        if stream.frames_read and stream.dropouts.get(c, 0) >= stream.frames_read
    ]
    if not undeclared and not absent:
        return []
    lines = [
        f"the case declares channels {', '.join(declared)}"
        + (
            f"; the stream names {', '.join(undeclared)}, which the case does not declare"
            if undeclared
            else ""
        )
        + (f"; {', '.join(absent)} absent from every frame" if absent else "")
    ]
    for name in undeclared:
        close = difflib.get_close_matches(name, declared, n=1, cutoff=0.6)
        if close:
            lines.append(
                f"did you mean '{name}' where the case says '{close[0]}'? "
                f"(monitor.channels in {result.case.path})"
            )
    return lines


def refusal_lines(result: RunResult) -> list[str]:
    """The first defects of each kind (line and message), a count of the rest, then the channel
    hint; empty for a stream without defects or channel mismatches."""
    stream = result.stream
    by_kind: dict[str, list] = {}
    for defect in stream.defects:
        by_kind.setdefault(defect.kind, []).append(defect)
    lines = []
    for kind, defects in by_kind.items():
        for defect in defects[:QUOTED]:
            lines.append(f"line {defect.line}: {kind}: {defect.message}")
    quoted = sum(min(len(d), QUOTED) for d in by_kind.values())
    rest = max(stream.defect_count, len(stream.defects)) - quoted
    if rest > 0:
        kinds = ", ".join(f"{len(d)} {kind}" for kind, d in by_kind.items())
        listed = (
            "all"
            if len(stream.defects) >= stream.defect_count
            else f"the first {len(stream.defects)}"
        )
        lines.append(f"... and {rest} more defects (result.json lists {listed}: {kinds})")
    return lines + channel_hint(result)


class RefusalHints:
    """`refusal_lines` for the logs of a fleet that read no frame, each line said once: twenty
    logs refused for the same misspelt channel give its cause once, then `same cause as
    above`."""

    def __init__(self) -> None:
        self.said: set[str] = set()

    def new(self, run_folder: Path) -> list[str]:
        try:
            lines = refusal_lines(load_result(run_folder / "result.json"))
        except ResultError:
            return []
        fresh = [line for line in lines if line not in self.said]
        self.said.update(lines)
        if lines and all(line.startswith("... and ") for line in fresh):  # only the counts differ
            return ["(the same cause as above)"]
        return fresh
