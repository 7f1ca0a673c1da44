"""kill -9 at several moments of a live run: every event that had closed is in events.jsonl,
each line complete, in the order the evaluator closed them (issue 23)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from casewatch import api
from casewatch.evaluator.core import Evaluator
from casewatch.evaluator.eventlog import event_record
from casewatch.monitor.engine import MetricEngine
from casewatch.monitor.parse import parse_frame
from tests.evaluator.streams import ego, write_case

REPO = Path(__file__).resolve().parents[2]
FRAMES = 110
OFF = ((1.0, 1.4), (3.0, 3.4), (5.0, 5.2), (8.0, 8.3))  # tfuse's ego 2 m off: els episodes
GONE = (6.5, 6.9)  # tfuse missing: a data gap


def frame(i: int) -> dict[str, object]:
    t = round(i * 0.1, 6)
    channels = {"lav": {"ego": ego(10.0 * t, 0.0), "plan": [], "objects": []}}
    if not GONE[0] <= t <= GONE[1]:
        offset = 2.0 if any(a <= t <= b for a, b in OFF) else 0.0
        channels["tfuse"] = {"ego": ego(10.0 * t, offset), "plan": [], "objects": []}
    return {"t": t, "channels": channels, "signals": {"speed": 10.0}}


def closed_after_each_frame(case_path: Path) -> list[list[dict]]:
    """closed[i]: the events (as events.jsonl records) that closed while frame i was judged."""
    case, spec = api.prepare(case_path)
    closed: list[list[dict]] = [[] for _ in range(FRAMES)]
    current = [0]
    evaluator = Evaluator(
        case,
        spec,
        on_event=lambda e: closed[current[0]].append(json.loads(json.dumps(event_record(e)))),
    )
    engine = MetricEngine(case.monitor.metrics, list(case.monitor.channels))
    for i in range(FRAMES):
        current[0] = i
        parsed = parse_frame(frame(i), list(case.monitor.channels), i + 1)
        evaluator.step(parsed.t, engine.step(parsed))
    return closed


@pytest.fixture(scope="module")
def setup(tmp_path_factory) -> tuple[Path, list[list[dict]]]:
    case = write_case(tmp_path_factory.mktemp("kill") / "case.yaml")
    closed = closed_after_each_frame(case)
    assert sum(map(len, closed)) >= 5  # four episodes and a gap close before the input ends
    return case, closed


def _moments(closed: list[list[dict]]) -> list[int]:
    """Frame counts right after the first, third and last event closed mid-stream."""
    ends = [i + 1 for i, events in enumerate(closed) for _ in events]
    return sorted({ends[0], ends[2], ends[-1]})


@pytest.mark.parametrize("which", [0, 1, 2])
def test_kill_9_after_events_closed_keeps_every_one(setup, tmp_path, which: int) -> None:
    case, closed = setup
    fed = _moments(closed)[which]
    expected = [e for events in closed[:fed] for e in events]
    everything = [e for events in closed for e in events]
    out = tmp_path / "out"
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "casewatch",
            "run",
            str(case),
            "-",
            "-o",
            str(out),
            "--format",
            "none",
            "--quiet",
        ],
        stdin=subprocess.PIPE,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        cwd=REPO,
        env=dict(os.environ, PYTHONUNBUFFERED="1"),
        text=True,
    )
    events_path = out / "events.jsonl"
    try:
        assert proc.stdin is not None
        for i in range(fed):
            proc.stdin.write(json.dumps(frame(i)) + "\n")
        proc.stdin.flush()
        deadline = time.monotonic() + 60
        while _lines(events_path) < len(expected) and time.monotonic() < deadline:
            assert proc.poll() is None, proc.stderr.read() if proc.stderr else ""
            time.sleep(0.02)
        # keep feeding and kill in the middle of it: a moment the process does not choose
        for i in range(fed, min(fed + 7, FRAMES)):
            proc.stdin.write(json.dumps(frame(i)) + "\n")
        proc.stdin.flush()
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)
    finally:
        proc.kill()
    assert proc.returncode == -signal.SIGKILL
    raw = events_path.read_text()
    assert raw.endswith("\n")
    written = [json.loads(line) for line in raw.splitlines()]  # every line complete JSON
    # episodes carry the ego's position at their start, which the bare evaluator of the
    # oracle cannot know: compared apart
    assert all(w["x"] is not None for w in written if w["event"] == "spi_episode")
    written = [{k: v for k, v in w.items() if k not in ("x", "y")} for w in written]
    expected, everything = (
        [{k: v for k, v in e.items() if k not in ("x", "y")} for e in events]
        for events in (expected, everything)
    )
    assert written[: len(expected)] == expected  # every event closed before the kill
    assert written == everything[: len(written)]  # and nothing else, in closing order
    assert not (out / "result.json").exists()


def _lines(path: Path) -> int:
    try:
        return path.read_text().count("\n")
    except FileNotFoundError:
        return 0
