"""`events.jsonl`: every episode and hazard event at its onset and when it closes, and every data
gap when it closes, each written the moment it happens.

Each event is one complete line written with a single `write` and flushed at once, so a run
killed at any moment (even `kill -9`) leaves every event that closed before it, and no
truncated line: the operating system keeps what was flushed when the process dies.
"""

from __future__ import annotations

import json
from pathlib import Path

from casewatch.evaluator.result import DataGap, Episode, EpisodeOpen, NearMiss, OddChange

Event = Episode | EpisodeOpen | NearMiss | DataGap | OddChange


def event_record(event: Event) -> dict[str, object]:
    if isinstance(event, Episode):
        kind = "hazard_event" if event.kind == "hazard" else "spi_episode"
    elif isinstance(event, EpisodeOpen):
        kind = "episode_open"
    elif isinstance(event, NearMiss):
        kind = "near_miss"
    elif isinstance(event, OddChange):
        kind = "odd_change"
    else:
        kind = "data_gap"
    # through the model's JSON: an infinite robustness becomes "-Infinity", as in result.json
    return {"event": kind, **json.loads(event.model_dump_json())}


class EventLog:
    def __init__(self, path: Path):
        path.parent.mkdir(parents=True, exist_ok=True)
        # A run starts a fresh log; each event is then appended as one flushed line.
        self._fh = open(path, "w", encoding="utf-8")  # noqa: SIM115

    def write(self, event: Event) -> None:
        line = json.dumps(event_record(event), separators=(",", ":"), allow_nan=False) + "\n"
        self._fh.write(line)
        self._fh.flush()

    def close(self) -> None:
        self._fh.close()
