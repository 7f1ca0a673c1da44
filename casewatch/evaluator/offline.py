"""The whole-log (offline) path: which judging a source gets, and the proof that it is exact.

A log on disk is judged whole: every formula's robustness over the complete signal arrays by
the numpy STL engine (`stl_engines.evaluate_whole_log`), the episodes and statuses replayed
from those values. A live stream (standard input, `--live`) cannot wait for its end and is
judged tick by tick by rtamt. Both paths read the same frames and compute the metrics with the
same kernels, so their `result.json` must be equal in every field but the run's own
bookkeeping (`created`, `timings`, `content_digest`): `result_differences` lists where two
results differ, `OnlineMismatch` is the error of `--check-online`, which judges a log both
ways and fails loudly on the first difference.

What is *not* whole-log yet (issue 36): decoding and the metrics still go frame by frame
through the live path's reader and `MetricEngine`; see docs/performance.md, "Where the time
goes".
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from casewatch.errors import CasewatchError
from casewatch.evaluator.result import RunResult
from casewatch.evaluator.stl_engines import EngineMismatch
from casewatch.monitor.source import source_kind

#: The STL engine of the live path (tick by tick) and of the whole-log path.
LIVE_ENGINE = "rtamt"
WHOLE_LOG_ENGINE = "numpy"
#: `--stl-engine auto` (the default): whole-log for a file or a bag, live for standard input.
AUTO_ENGINE = "auto"

#: A result's fields that say how the run went, not what it found: never compared.
BOOKKEEPING = frozenset({"created", "timings", "content_digest"})

#: How many differences `OnlineMismatch` lists (the count is always exact).
MAX_LISTED = 20


def is_live_source(source: str | Path) -> bool:
    """True for standard input (`-`), which is judged as it arrives."""
    return source_kind(source) == "stdin"


def resolve_engine(requested: str, source: str | Path, live: bool = False) -> str:
    """The STL engine a run of `source` uses: `requested` unless it is `auto`, then rtamt for
    a live stream (standard input, or `live`) and numpy, over the whole log, for a file."""
    if requested != AUTO_ENGINE:
        return requested
    return LIVE_ENGINE if live or is_live_source(source) else WHOLE_LOG_ENGINE


def _walk(a: Any, b: Any, path: str) -> Iterator[str]:
    """Where the JSON values `a` and `b` differ, as `path: a != b` lines, in document order.
    Floats compare exactly (NaN equals NaN: both paths write the same JSON)."""
    if isinstance(a, dict) and isinstance(b, dict):
        for key in [*a, *(k for k in b if k not in a)]:
            where = f"{path}.{key}" if path else str(key)
            if key not in a or key not in b:
                side = "offline" if key not in a else "online"
                yield f"{where}: missing from the {side} result"
            else:
                yield from _walk(a[key], b[key], where)
    elif isinstance(a, list) and isinstance(b, list):
        for i, (x, y) in enumerate(zip(a, b, strict=False)):
            yield from _walk(x, y, f"{path}[{i}]")
        if len(a) != len(b):
            yield f"{path}: {len(a)} items offline, {len(b)} online"
    elif type(a) is not type(b) or (
        a != b and not (isinstance(a, float) and math.isnan(a) and math.isnan(b))
    ):
        yield f"{path}: {a!r:.80} offline != {b!r:.80} online"


def result_differences(offline: RunResult, online: RunResult) -> list[str]:
    """Every field where two results of the same log differ, bookkeeping aside (the whole
    record, field by field: verdict, episodes with their traces, gaps, statuses, series,
    scores, ...)."""
    a = offline.model_dump(mode="json", exclude=set(BOOKKEEPING))
    b = online.model_dump(mode="json", exclude=set(BOOKKEEPING))
    for side in (a, b):
        # the option that picks the path, and so the one that must change nothing else
        (side.get("options") or {}).pop("stl_engine", None)
    return list(_walk(a, b, ""))


class OnlineMismatch(EngineMismatch):
    """The whole-log path and the live path judged one log differently (a bug in one of
    them, never a verdict): an engine disagreement, handled and exited (4) as one by the
    single run and by `--jobs`, whose messages name the log."""

    def __init__(self, source: str, differences: list[str]):
        shown = "\n".join(f"  {d}" for d in differences[:MAX_LISTED])
        CasewatchError.__init__(
            self,
            f"the whole-log and the live path disagree in {len(differences)} field(s), "
            f"first {min(len(differences), MAX_LISTED)}:\n{shown}",
        )
        self.source = source
        self.differences = differences
        self.mismatches = []  # EngineMismatch's per-value list: these are per field
        self.total = len(differences)


def check_online(source: str | Path, offline: RunResult, online: RunResult) -> None:
    """Raise `OnlineMismatch` unless the two results of `source` are equal field by field."""
    differences = result_differences(offline, online)
    if differences:
        raise OnlineMismatch(str(source), differences)
