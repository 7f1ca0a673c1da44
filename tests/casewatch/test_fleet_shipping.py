"""The pieces of a fleet task that need no cluster: shipped logs judged from their bytes, the
workers' path check, a finished task not judged twice, resumed logs kept out of progress."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

from casewatch.batch import Outputs, plan_jobs, run_job
from casewatch.dask_engine import EngineError, check_workers, unreadable
from casewatch.evaluator.options import RunOptions
from casewatch.progress import FleetProgress
from casewatch.shipping import TASK_FILE, receive, run_task, ship
from tests.evaluator.streams import write_case, write_stream


def _fleet(tmp_path: Path, names: list[str]) -> tuple[Path, list[Path]]:
    case = write_case(tmp_path / "case.yaml")
    logs = tmp_path / "logs"
    logs.mkdir()
    streams = []
    for name in names:
        streams.append(write_stream(logs / f"{name}.jsonl"))
        (logs / f"{name}.labels.jsonl").write_text(
            json.dumps({"hazard": "CSn1", "start": 1.0, "end": 2.0}) + "\n"
        )
    return case, streams


def _comparable(folder: Path) -> dict:
    result = json.loads((folder / "result.json").read_text())
    for key in ("created", "timings", "content_digest"):
        result.pop(key)
    return result


def test_a_shipped_log_is_judged_from_its_bytes_with_the_same_result(tmp_path):
    case, streams = _fleet(tmp_path, ["a"])
    options = RunOptions(labels="auto")
    (here,) = plan_jobs(str(case), streams, tmp_path / "here", options, Outputs(("md",)))
    (there,) = plan_jobs(str(case), streams, tmp_path / "there", options, Outputs(("md",)))
    run_job(here)
    shipped = ship(there, 1 << 20)
    assert [Path(p).name for p, _ in shipped.shipped] == ["a.jsonl", "a.labels.jsonl"]
    streams[0].rename(tmp_path / "elsewhere.jsonl")  # the worker cannot read it any more
    (tmp_path / "logs" / "a.labels.jsonl").unlink()
    value = run_task(shipped)
    assert {name for name, _ in value.files} >= {"result.json", "events.jsonl", "report.md"}
    summary = receive(there, value)
    assert summary.ok and summary.out_dir == there.out_dir
    assert summary.stream == str(tmp_path / "logs" / "a.jsonl")  # the client's path
    assert _comparable(tmp_path / "there" / "a") == _comparable(tmp_path / "here" / "a")
    assert not (tmp_path / "there" / "a" / "result.json.partial").exists()


def test_only_logs_up_to_the_limit_are_shipped(tmp_path):
    case, streams = _fleet(tmp_path, ["a"])
    (job,) = plan_jobs(str(case), streams, tmp_path / "out", RunOptions(), Outputs())
    size = streams[0].stat().st_size
    assert ship(job, size).shipped and not ship(job, size - 1).shipped
    assert not ship(job, 0).shipped


def test_a_task_run_again_for_the_same_fleet_returns_its_written_summary(tmp_path):
    case, streams = _fleet(tmp_path, ["a"])
    (job,) = plan_jobs(str(case), streams, tmp_path / "out", RunOptions(), Outputs())
    first = run_task(job, fleet="f1").summary
    stamp = (Path(job.out_dir) / "result.json").stat().st_mtime_ns
    assert json.loads((Path(job.out_dir) / TASK_FILE).read_text())["fleet"] == "f1"
    assert run_task(job, fleet="f1").summary == first  # a lost worker's finished task
    assert (Path(job.out_dir) / "result.json").stat().st_mtime_ns == stamp
    assert run_task(job, fleet="f2").summary.seconds > 0  # another fleet judges it again
    assert (Path(job.out_dir) / "result.json").stat().st_mtime_ns != stamp


class _Workers:
    """A client whose workers run `unreadable` here, as `client.run` would on each."""

    def run(self, function, *args):
        return {"tcp://10.0.0.7:4242": function(*args), "tcp://10.0.0.8:4242": []}


def test_a_path_a_worker_cannot_read_is_named_with_the_worker(tmp_path):
    case, streams = _fleet(tmp_path, ["a", "b"])
    jobs = plan_jobs(str(case), streams, tmp_path / "out", RunOptions(), Outputs())
    check_workers(_Workers(), jobs)  # everything readable: no error
    streams[1].unlink()
    try:
        check_workers(_Workers(), jobs)
    except EngineError as exc:
        message = str(exc)
    else:
        raise AssertionError("no error for an unreadable log")
    assert message.startswith(
        f"Dask worker tcp://10.0.0.7:4242 cannot read {streams[1]} (No such file or directory)"
    )
    assert "--ship-logs" in message
    # a shipped log is not looked for on the workers
    check_workers(_Workers(), [jobs[0], replace(jobs[1], shipped=((jobs[1].stream, b""),))])


def test_unreadable_names_missing_files_and_unwritable_folders(tmp_path):
    there = write_stream(tmp_path / "a.jsonl")
    blocked = tmp_path / "file"
    blocked.write_text("x")
    problems = unreadable(
        [str(there), str(tmp_path / "gone.jsonl")],
        [str(tmp_path / "new" / "out"), str(blocked / "out")],
    )
    assert problems == [
        f"cannot read {tmp_path / 'gone.jsonl'} (No such file or directory)",
        f"cannot write {blocked / 'out'} ({blocked} is not writable)",
    ]


def test_resumed_logs_are_neither_judged_hours_nor_work_left():
    bar = FleetProgress(5, enabled=False)
    bar.resumed()
    bar.resumed()
    bar.advance(0.5)
    assert (bar.bar.total, bar.hours) == (3, 0.5)
