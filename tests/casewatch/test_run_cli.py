"""`casewatch run`: exit codes, live mode from stdin, and crash safety of events.jsonl."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from casewatch.cli import main
from tests.evaluator.streams import frame, write_case, write_stream

REPO = Path(__file__).resolve().parents[2]


def casewatch_process(*args: str) -> subprocess.Popen:
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    return subprocess.Popen(
        [sys.executable, "-m", "casewatch", *args],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        cwd=REPO,
        env=env,
        text=True,
    )


def test_exit_1_with_violations_and_files_written(tmp_path, capsys):
    case = write_case(tmp_path / "case.yaml")
    stream = write_stream(tmp_path / "s.jsonl")
    code = main(["run", str(case), str(stream), "-o", str(tmp_path / "out"), "--format", "none"])
    assert code == 1
    result = json.loads((tmp_path / "out" / "result.json").read_text())
    assert result["verdict"] == "undermined" and result["stream"]["frames_read"] == 100
    assert "root goal G1: UNDERMINED" in capsys.readouterr().out


def test_exit_0_when_nothing_is_violated(tmp_path):
    case = write_case(tmp_path / "case.yaml")
    stream = tmp_path / "s.jsonl"
    # frames 30..49 of the test stream: channels agree, nobody drops out
    stream.write_text("".join(json.dumps(frame(i)) + "\n" for i in range(31, 50)))
    assert (
        main(
            [
                "run",
                str(case),
                str(stream),
                "-o",
                str(tmp_path / "o"),
                "--format",
                "none",
                "--quiet",
            ]
        )
        == 0
    )


def test_exit_2_on_bad_case_missing_stream_and_strict_defect(tmp_path, capsys):
    case = write_case(tmp_path / "case.yaml")
    bad_case = tmp_path / "bad.yaml"
    bad_case.write_text(case.read_text().replace("signal: els", "signal: elss"))
    stream = write_stream(tmp_path / "s.jsonl")
    out = str(tmp_path / "o")
    assert main(["run", str(bad_case), str(stream), "-o", out]) == 2
    assert "unknown signal 'elss'" in capsys.readouterr().err
    assert main(["run", str(case), str(tmp_path / "nope.jsonl"), "-o", out]) == 2
    assert "cannot read stream" in capsys.readouterr().err
    broken = tmp_path / "broken.jsonl"
    broken.write_text(json.dumps(frame(0)) + "\n{not json\n" + json.dumps(frame(1)) + "\n")
    assert main(["run", str(case), str(broken), "-o", out, "--strict", "--format", "none"]) == 2
    assert "broken.jsonl:2: malformed-json" in capsys.readouterr().err


def test_defects_are_kept_not_dropped_without_strict(tmp_path):
    case = write_case(tmp_path / "case.yaml")
    stream = tmp_path / "s.jsonl"
    stream.write_text(json.dumps(frame(0)) + "\n{not json\n" + json.dumps(frame(1)) + "\n")
    main(["run", str(case), str(stream), "-o", str(tmp_path / "o"), "--format", "none", "--quiet"])
    result = json.loads((tmp_path / "o" / "result.json").read_text())
    assert result["stream"]["defect_count"] == 1
    assert result["stream"]["defects"][0]["line"] == 2


def _feed(proc: subprocess.Popen, first: int, last: int) -> None:
    """Write frames `first`..`last` (inclusive) to the live process and flush."""
    assert proc.stdin is not None
    for i in range(first, last + 1):
        proc.stdin.write(json.dumps(frame(i)) + "\n")
    proc.stdin.flush()


def _await_line(proc: subprocess.Popen, marker: str, timeout: float = 60.0) -> str:
    """What the process prints until a line with `marker` appears. No frame is fed meanwhile,
    so a marker that appears was printed for the frames already given, before the input ended:
    liveness without a frame budget that a loaded machine would miss (the timeout only bounds
    a failure)."""
    assert proc.stdout is not None
    os.set_blocking(proc.stdout.fileno(), False)
    printed = ""
    deadline = time.monotonic() + timeout
    while marker not in printed and time.monotonic() < deadline:
        chunk = proc.stdout.readline()
        if chunk:
            printed += chunk
        else:
            time.sleep(0.01)
    return printed


def test_live_mode_prints_the_episode_before_the_input_ends(tmp_path):
    case = write_case(tmp_path / "case.yaml")
    proc = casewatch_process("run", str(case), "-", "-o", str(tmp_path / "out"), "--format", "none")
    try:
        # The onset is announced the tick the episode opens (t = 2.0 s, frame 20; the case's
        # min_duration is 0): frames 0-20 are enough...
        _feed(proc, 0, 20)
        printed = _await_line(proc, "VIOLATED")
        assert "VIOLATED Sn1  from 2.0 s (open at 2.0 s)  trace Sn1 -> G2 -> S1 -> G1" in printed
        # ...and the episode (2.0-3.0 s) when it closes, once merge_gap (1 s) of clean time has
        # passed, at t = 4.0 s, i.e. frame 40: well before the 100 frames end.
        _feed(proc, 21, 40)
        printed = _await_line(proc, "ENDED")
        assert "ENDED    Sn1  2.0-3.0 s" in printed and "trace Sn1 -> G2 -> S1 -> G1" in printed
        _feed(proc, 41, 99)
        proc.stdin.close()
        assert proc.wait(timeout=60) == 1
    finally:
        proc.kill()


def test_kill_9_keeps_every_closed_episode_and_no_truncated_line(tmp_path):
    case = write_case(tmp_path / "case.yaml")
    out = tmp_path / "out"
    proc = casewatch_process("run", str(case), "-", "-o", str(out), "--format", "none")
    try:
        _feed(proc, 0, 40)  # the episode closes at frame 40 (see the test above)
        assert "ENDED    Sn1" in _await_line(proc, "ENDED")
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)
    finally:
        proc.kill()
    assert proc.returncode == -signal.SIGKILL
    raw = (out / "events.jsonl").read_text()
    assert raw.endswith("\n")
    events = [json.loads(line) for line in raw.splitlines()]
    assert [(e["event"], e["node_id"], e["start"], e.get("end")) for e in events] == [
        ("episode_open", "Sn1", 2.0, None),
        ("spi_episode", "Sn1", 2.0, 3.0),
    ]
    assert events[0]["t"] == 2.0 and events[0]["trace"] == events[1]["trace"]
    assert not (out / "result.json").exists()


@pytest.mark.parametrize("jobs", [1, 2])
def test_many_logs_write_one_result_each_and_a_summary(tmp_path, jobs):
    case = write_case(tmp_path / "case.yaml")
    logs = tmp_path / "logs"
    logs.mkdir()
    write_stream(logs / "a.jsonl")
    write_stream(logs / "b.jsonl", frames=50)
    (logs / "a.labels.jsonl").write_text('{"hazard": "CSn1", "start": 1, "end": 2}\n')
    out = tmp_path / "out"
    code = main(
        [
            "run",
            str(case),
            str(logs),
            "-o",
            str(out),
            "--jobs",
            str(jobs),
            "--labels",
            "auto",
            "--format",
            "none",
            "--quiet",
        ]
    )
    assert code == 1
    summary = json.loads((out / "summary.json").read_text())
    assert summary["logs"] == 2 and summary["logs_failed"] == 0
    assert (out / "a" / "result.json").exists() and (out / "b" / "result.json").exists()
    # both logs hold the 2.0-3.0 s ELS episode; 10 s + 5 s of driving = 15 s
    sn1 = next(f for f in summary["formulas"] if f["node_id"] == "Sn1")
    assert sn1["episodes"] == 2
    assert sn1["episodes_per_hour"] == pytest.approx(2 / (15 / 3600), rel=1e-6)
    a = json.loads((out / "a" / "result.json").read_text())
    assert a["ground_truth"]["overall"]["false_negatives"] == 1
    # only log a has labels: its one label (1-2 s) is missed, nothing fired
    truth = summary["ground_truth"]
    assert truth["logs"] == 1
    assert truth["overall"] == {
        "hazard": "all",
        "true_positives": 0,
        "false_positives": 0,
        "false_negatives": 1,
        "precision": None,
        "recall": 0.0,
    }


def test_fail_on_policy_sets_the_exit_code_and_junit(tmp_path):
    """The hand-made stream has one SPI episode (Sn1, 2.0-3.0 s) and no hazard event."""
    case = write_case(tmp_path / "case.yaml")
    stream = write_stream(tmp_path / "s.jsonl")
    codes = {}
    for policy in ("any", "hazard", "spi", "never"):
        out = tmp_path / policy
        codes[policy] = main(
            [
                "run",
                str(case),
                str(stream),
                "-o",
                str(out),
                "--format",
                "junit",
                "--quiet",
                "--fail-on",
                policy,
            ]
        )
        result = json.loads((out / "result.json").read_text())
        assert result["fail_on"] == policy
        assert [e["kind"] for e in result["episodes"]] == ["spi"]
    assert codes == {"any": 1, "hazard": 0, "spi": 1, "never": 0}
    gated = (tmp_path / "any" / "junit.xml").read_text()
    waved = (tmp_path / "hazard" / "junit.xml").read_text()
    assert 'failures="1"' in gated and "<failure" in gated
    assert 'failures="0"' in waved and "<failure" not in waved
    assert "1 episode, not counted as failures (--fail-on hazard)" in waved
    # re-rendering with another policy follows it
    assert main(["report", str(tmp_path / "hazard"), "--format", "junit", "--fail-on", "any"]) == 0
    assert 'failures="1"' in (tmp_path / "hazard" / "junit.xml").read_text()
    # an unknown policy is a usage error
    assert (
        main(["run", str(case), str(stream), "-o", str(tmp_path / "x"), "--fail-on", "hazards"])
        == 2
    )
