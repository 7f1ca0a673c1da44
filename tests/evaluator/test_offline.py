"""The whole-log path gives the live path's result (issue 36): every bundled drive and a
generated one with gaps and defects judged both ways, result.json compared field by field."""

from __future__ import annotations

import gzip
import json
from pathlib import Path

import pytest

from bench.metrics import reference_load_dicts
from casewatch import api
from casewatch.errors import EXIT_ENGINES_DISAGREE
from casewatch.evaluator.offline import (
    AUTO_ENGINE,
    OnlineMismatch,
    check_online,
    resolve_engine,
    result_differences,
)
from casewatch.evaluator.options import RunOptions, RunSinks
from casewatch.evaluator.session import InputError, evaluate_stream

REPO = Path(__file__).resolve().parents[2]
DATA = REPO / "examples" / "data"
REFERENCE = REPO / "examples" / "reference-case.yaml"

#: Each folder of bundled drives and the case they are judged with.
FOLDERS = {
    DATA: REFERENCE,
    DATA / "odd-grid": REPO / "examples" / "odd" / "contracts-case.yaml",
    DATA / "rules": REPO / "examples" / "rules" / "rules-case.yaml",
}
DRIVES = [(path, case) for folder, case in FOLDERS.items() for path in sorted(folder.glob("*.gz"))]

_PREPARED: dict[Path, tuple] = {}


def _prepared(case: Path) -> tuple:
    if case not in _PREPARED:
        _PREPARED[case] = api.prepare(case)
    return _PREPARED[case]


def _both(case_path: Path, stream: Path, labels: Path | None = None) -> tuple:
    case, spec = _prepared(case_path)
    offline = evaluate_stream(case, spec, stream, RunOptions(stl_engine="numpy", labels=labels))
    online = evaluate_stream(case, spec, stream, RunOptions(stl_engine="rtamt", labels=labels))
    return offline, online


def test_every_bundled_folder_has_drives():
    for folder in FOLDERS:
        assert any(p.parent == folder for p, _ in DRIVES), folder


@pytest.mark.parametrize(
    ("stream", "case_path"), DRIVES, ids=[f"{p.parent.name}/{p.name}" for p, _ in DRIVES]
)
def test_bundled_drive_whole_log_equals_live(stream, case_path):
    labels = stream.with_name(stream.name.replace(".jsonl.gz", ".labels.jsonl"))
    offline, online = _both(case_path, stream, labels if labels.exists() else None)
    assert result_differences(offline, online) == []
    assert offline.stream.frames_read > 100  # a real drive was judged
    check_online(stream, offline, online)  # raises on any difference


def _generated(path: Path) -> Path:
    """300 reference-load frames (2 channels, 40 objects) with what a real log has: a gap
    longer than max_gap, a line that is not JSON, a frame with a non-finite value, a channel
    missing for a while and a frame out of order."""
    lines = []
    for i, frame in enumerate(reference_load_dicts(300, seed=3)):
        if 100 <= i < 130:
            continue  # 3 s without frames: a data gap, every history restarts
        if 200 <= i < 220:
            del frame["channels"]["tfuse"]  # one channel absent: pair metrics have no value
        if i == 50:
            frame["channels"]["lav"]["ego"]["x"] = "NaN"  # a defect: the frame is skipped
        lines.append(json.dumps(frame))
        if i == 70:
            lines.append("{not json")
        if i == 80:
            lines.append(lines[-2])  # a repeated (out of order) frame
    with gzip.open(path, "wt", encoding="utf-8") as fh:
        fh.write("\n".join(lines) + "\n")
    return path


def test_generated_drive_with_gaps_and_defects_whole_log_equals_live(tmp_path):
    stream = _generated(tmp_path / "generated.jsonl.gz")
    offline, online = _both(REFERENCE, stream)
    assert offline.stream.defect_count == 3  # the bad value, the bad line, the repeat
    assert [d.line for d in offline.stream.defects] == [d.line for d in online.stream.defects]
    assert offline.data_gaps  # the gap and the missing channel were seen
    assert result_differences(offline, online) == []


def test_a_changed_field_is_found_and_named(tmp_path):
    stream = DATA / "highway-tailgating.jsonl.gz"
    case, spec = _prepared(REFERENCE)
    offline = evaluate_stream(case, spec, stream, RunOptions(stl_engine="numpy"))
    assert offline.episodes, "the drive has episodes to alter"
    altered = offline.model_copy(deep=True)
    altered.episodes[0].end += 0.1
    altered.verdict = "ok" if offline.verdict != "ok" else "violated"
    altered.timings.total_s += 5.0  # bookkeeping: never a difference
    found = result_differences(altered, offline)
    assert found == [
        f"verdict: {altered.verdict!r} offline != {offline.verdict!r} online",
        f"episodes[0].end: {altered.episodes[0].end!r} offline != "
        f"{offline.episodes[0].end!r} online",
    ]
    with pytest.raises(OnlineMismatch) as raised:
        check_online(stream, altered, offline)
    assert raised.value.exit_code == EXIT_ENGINES_DISAGREE
    assert "disagree in 2 field(s)" in str(raised.value)
    assert raised.value.source == str(stream)


def test_a_list_of_another_length_is_a_difference():
    stream = DATA / "highway-tailgating.jsonl.gz"
    case, spec = _prepared(REFERENCE)
    result = evaluate_stream(case, spec, stream, RunOptions(stl_engine="numpy"))
    shorter = result.model_copy(deep=True)
    shorter.episodes.pop()
    n = len(result.episodes)
    assert f"episodes: {n - 1} items offline, {n} online" in result_differences(shorter, result)


@pytest.mark.parametrize(
    ("requested", "source", "live", "engine"),
    [
        (AUTO_ENGINE, "drive.jsonl.gz", False, "numpy"),
        (AUTO_ENGINE, Path("bag.mcap"), False, "numpy"),
        (AUTO_ENGINE, "-", False, "rtamt"),
        (AUTO_ENGINE, "drive.jsonl.gz", True, "rtamt"),
        ("rtamt", "drive.jsonl.gz", False, "rtamt"),
        ("both", "drive.jsonl.gz", False, "both"),
    ],
)
def test_resolve_engine(requested, source, live, engine):
    assert resolve_engine(requested, source, live) == engine


def test_a_log_is_judged_whole_by_default_and_checked_against_the_live_path():
    stream = DATA / "highway-tailgated.jsonl.gz"
    case, spec = _prepared(REFERENCE)
    checked = evaluate_stream(case, spec, stream, RunOptions(check_online=True))
    live = evaluate_stream(case, spec, stream, RunOptions(stl_engine="rtamt"))
    assert checked.options["stl_engine"] == AUTO_ENGINE  # recorded as given, for --resume
    assert result_differences(checked, live) == []


def test_check_online_refuses_standard_input():
    case, spec = _prepared(REFERENCE)
    with pytest.raises(InputError, match="standard input can be read once"):
        evaluate_stream(case, spec, "-", RunOptions(check_online=True))


def test_a_tick_observer_gets_the_live_path():
    """A live view follows ticks as they are judged: with `auto` it gets them on a file too."""
    stream = DATA / "highway-tailgated.jsonl.gz"
    case, spec = _prepared(REFERENCE)
    seen: list[float] = []
    sinks = RunSinks(on_tick=lambda frame, statuses, evaluator, reader: seen.append(frame.t))
    result = evaluate_stream(case, spec, stream, RunOptions(), sinks)
    assert len(seen) == result.stream.frames_read
