"""The local runner prepares a case once for all its logs, and the result is unchanged."""

from __future__ import annotations

import json
from pathlib import Path

from casewatch import api, batch
from casewatch.evaluator.offline import result_differences
from casewatch.evaluator.options import RunOptions
from casewatch.evaluator.result import RunResult
from tests.evaluator.streams import write_case, write_stream


def _jobs(tmp_path: Path, case: Path, names: list[str]) -> list[batch.Job]:
    logs = tmp_path / "logs"
    logs.mkdir()
    for k, name in enumerate(names):
        write_stream(logs / f"{name}.jsonl", frames=40 + 10 * k)
    streams = sorted(logs.glob("*.jsonl"))
    return batch.plan_jobs(str(case), streams, tmp_path / "out", RunOptions(), batch.Outputs())


def test_three_logs_prepare_the_case_once_and_judge_as_alone(tmp_path, monkeypatch) -> None:
    case = write_case(tmp_path / "case.yaml")
    work = _jobs(tmp_path, case, ["a", "b", "c"])
    calls: list[str] = []
    prepare = api.prepare

    def counted(path, *args, **kwargs):
        calls.append(str(path))
        return prepare(path, *args, **kwargs)

    monkeypatch.setattr(api, "prepare", counted)
    done: dict[int, batch.LogSummary] = {}
    batch.local_runner(1)(work, done.__setitem__)
    assert calls == [str(case.absolute())]  # once, not once per log
    assert batch._PREPARED == {}  # nothing kept past the run
    assert all(log.ok for log in done.values()) and len(done) == 3
    for job in work:
        alone = api.run(case, job.stream, options=RunOptions())
        kept = RunResult.model_validate(json.loads((Path(job.out_dir) / "result.json").read_text()))
        assert result_differences(kept, alone) == []


def test_a_broken_case_is_still_reported_for_every_log(tmp_path) -> None:
    case = tmp_path / "case.yaml"
    case.write_text("goals: [\n")
    work = _jobs(tmp_path, case, ["a", "b"])
    done: dict[int, batch.LogSummary] = {}
    batch.local_runner(1)(work, done.__setitem__)
    assert [log.ok for log in done.values()] == [False, False]
    assert all("case.yaml" in (log.error or "") for log in done.values())


def test_a_case_the_caller_prepared_is_not_prepared_again(tmp_path, monkeypatch) -> None:
    case = write_case(tmp_path / "case.yaml")
    work = _jobs(tmp_path, case, ["a", "b"])
    prepared = {str(case.absolute()): api.prepare(case)}
    calls: list[str] = []
    monkeypatch.setattr(api, "prepare", lambda path, *a, **k: calls.append(str(path)))
    done: dict[int, batch.LogSummary] = {}
    batch.local_runner(1, prepared)(work, done.__setitem__)
    assert calls == [] and [log.ok for log in done.values()] == [True, True]
