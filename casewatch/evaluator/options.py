"""The options of a run: what shapes a result, declared once.

`RunOptions` is built once from the command line (or by an API caller) and handed unchanged to
`evaluate_stream`, to every `--jobs` worker and to every Dask task: a new option is one field
here, not a parameter in five signatures. It is frozen and plain (paths, numbers, text), so it
pickles to a worker and compares by value (`--resume` reuses a log's result only when the
options recorded in it equal this run's, `recorded()`).

`RunSinks` is the other half: where one run's side outputs go (the event log, the signals
file, callbacks). Those differ per log and never change a result, so they are not options.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from casewatch.errors import CasewatchError
from casewatch.evaluator.policy import FAIL_ON

#: Default of `--max-no-data`: the bundled drives' root goal is `no-data` on 2-3 % of ticks
#: (warm-up), a drive with a channel missing throughout on all of them.
DEFAULT_MAX_NO_DATA = 0.5

#: The STL engines (evaluator.stl_engines.ENGINES, restated so this module stays import-light),
#: and `auto`: the whole-log path (numpy) for a log, rtamt tick by tick for a live stream
#: (evaluator.offline.resolve_engine).
STL_ENGINES = ("auto", "rtamt", "numpy", "both")

#: `labels` value meaning "NAME.labels.jsonl beside each stream, when there is one".
AUTO_LABELS = "auto"


class OptionsError(CasewatchError, ValueError):
    """Run options that no run can use (an unknown engine or policy, a share outside 0-1)."""


@dataclass(frozen=True)
class RunOptions:
    """Every option that shapes a run's result.

    `labels` is a labels file, None, or `"auto"` (a fleet's: resolved per stream by the front
    door before a log is judged, `with_labels`); `topics` is a bag's topic mapping (None: the
    case's `monitor.topics`)."""

    labels: str | None = None
    strict: bool = False
    # the largest share of ticks the root goal may be `no-data` before the run is unusable input
    max_no_data: float = DEFAULT_MAX_NO_DATA
    fail_on: str = "any"  # which episodes fail the run (evaluator.policy), recorded in the result
    topics: str | None = None
    stl_engine: str = "auto"  # auto, rtamt, numpy or both (evaluator.stl_engines)
    series_points: int = 1000  # points per plot series in result.json
    # judge a log both ways too (whole-log and live) and fail unless every field agrees
    # (evaluator.offline.OnlineMismatch); not recorded: it never changes a result
    check_online: bool = False

    def __post_init__(self) -> None:
        # paths arrive as Path from argparse and API callers; kept as text so the value
        # pickles, prints and compares the same everywhere
        for name in ("labels", "topics"):
            value = getattr(self, name)
            if isinstance(value, Path):
                object.__setattr__(self, name, str(value))
        if self.stl_engine not in STL_ENGINES:
            raise OptionsError(
                f"unknown STL engine {self.stl_engine!r} (one of {', '.join(STL_ENGINES)})"
            )
        if self.fail_on not in FAIL_ON:
            raise OptionsError(f"unknown --fail-on {self.fail_on!r} (one of {', '.join(FAIL_ON)})")
        if not 0.0 <= self.max_no_data <= 1.0:  # NaN fails this too
            raise OptionsError(f"--max-no-data {self.max_no_data!r}: expected a share from 0 to 1")

    @property
    def labels_path(self) -> Path | None:
        """The labels file to read (None without labels); `auto` must be resolved first."""
        if self.labels is None:
            return None
        if self.labels == AUTO_LABELS:
            raise OptionsError(
                "--labels auto names the labels beside each stream; resolve it per stream "
                "(RunOptions.with_labels) before judging one"
            )
        return Path(self.labels)

    @property
    def topics_path(self) -> Path | None:
        return None if self.topics is None else Path(self.topics)

    def with_labels(self, labels: str | Path | None) -> RunOptions:
        """The same options with this log's labels file (what `auto` resolved to)."""
        from dataclasses import replace

        return replace(self, labels=None if labels is None else str(labels))

    def recorded(self) -> dict[str, Any]:
        """What result.json records of these options (`RunResult.options`): every field, with
        the labels as the path judged. `--resume` compares it with the new run's."""
        return {
            "labels": self.labels,
            "strict": self.strict,
            "max_no_data": self.max_no_data,
            "fail_on": self.fail_on,
            "topics": self.topics,
            "stl_engine": self.stl_engine,
            "series_points": self.series_points,
        }


@dataclass
class RunSinks:
    """Where one run's side outputs go; none of them changes the result."""

    events_path: Path | None = None  # events.jsonl, appended and flushed as events close
    signals_path: Path | None = None  # every per-tick signal value (`signals.npz`); None: not
    on_event: Callable[[Any], None] | None = None  # each event as it closes (live output)
    progress: Callable[[int, float], None] | None = None  # (frames, stream time) every ~1 s
    # after each frame judged tick by tick: (frame, every node's status, evaluator, reader);
    # how live views (casewatch.live) follow a run without reaching into its loop
    on_tick: Callable[[Any, Any, Any, Any], None] | None = None
