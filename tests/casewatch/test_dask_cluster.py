"""`casewatch run --engine dask --scheduler` on a real cluster: a `dask scheduler` and `dask
worker` processes on loopback (issue 35). A killed scheduler, a log that kills its worker every
time, `--resume` with changed options and relative paths run against real processes; the logs
are small (100 frames) so each test takes seconds."""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytest.importorskip("distributed", reason="needs Dask's distributed: pip install -e .[fleet]")

from bench.dask_cluster import LoopbackCluster
from casewatch.cli import main
from casewatch.shipping import TASK_FILE
from tests.evaluator.streams import write_case, write_stream

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    """Two workers; a log named `poison*` kills its worker (`poison_worker.py`, preloaded into
    each worker), and the scheduler gives a task up after its worker died twice."""
    started = LoopbackCluster(
        tmp_path_factory.mktemp("cluster"),
        workers=2,
        env={
            "DASK_DISTRIBUTED__SCHEDULER__ALLOWED_FAILURES": "1",
            # a worker holds only the task it runs: a healthy log never dies with the poison
            # (docs/fleet.md, "A log that kills its worker")
            "DASK_DISTRIBUTED__SCHEDULER__WORKER_SATURATION": "1.0",
        },
        preload=[Path(__file__).with_name("poison_worker.py")],
    )
    yield started
    started.close()


def fleet(folder: Path, names: list[str], frames: int = 100) -> tuple[Path, Path]:
    """A case and a folder of small logs (each with labels) under `folder`."""
    case = write_case(folder / "case.yaml")
    logs = folder / "logs"
    logs.mkdir()
    for name in names:
        write_stream(logs / f"{name}.jsonl", frames)
        (logs / f"{name}.labels.jsonl").write_text(
            json.dumps({"hazard": "CSn1", "start": 1.0, "end": 2.0}) + "\n"
        )
    return case, logs


def test_relative_paths_and_resume_with_changed_options(tmp_path, monkeypatch, cluster):
    fleet(tmp_path, ["a", "b"])
    monkeypatch.chdir(tmp_path)  # the workers run in another folder: paths must be absolute
    base = ["run", "case.yaml", "logs", "--engine", "dask", "--scheduler", cluster.address]
    base += ["--format", "none", "--quiet", "-o", "out"]
    assert main([*base, "--labels", "auto"]) == 1
    first = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert [log["ok"] for log in first["per_log"]] == [True, True]
    assert first["per_log"][0]["stream"] == str(tmp_path / "logs" / "a.jsonl")
    result = json.loads((tmp_path / "out" / "a" / "result.json").read_text())
    assert result["options"]["labels"] == str(tmp_path / "logs" / "a.labels.jsonl")
    assert result["ground_truth"]["labels_path"] == result["options"]["labels"]
    stamp = (tmp_path / "out" / "a" / "result.json").stat().st_mtime_ns

    # the same options: nothing is judged again
    assert main([*base, "--labels", "auto", "--resume"]) == 1
    again = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert [log["seconds"] for log in again["per_log"]] == [0.0, 0.0]
    assert (tmp_path / "out" / "a" / "result.json").stat().st_mtime_ns == stamp

    # other options: every log judged again, and the exit code is a fresh run's (the
    # tiny logs' root goal has no data on more than 1 % of their ticks: exit 2)
    changed = ["--max-no-data", "0.01", "--fail-on", "never"]
    assert main([*base, *changed, "--resume"]) == 2
    resumed = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert all(log["seconds"] > 0 for log in resumed["per_log"])
    result = json.loads((tmp_path / "out" / "a" / "result.json").read_text())
    assert (result["options"]["labels"], result["ground_truth"]) == (None, None)
    assert (result["fail_on"], result["root_no_data"]["limit"]) == ("never", 0.01)
    assert main([*base, *changed, "-o", "fresh"]) == 2


def test_a_log_that_kills_its_worker_fails_alone(tmp_path, cluster):
    case, logs = fleet(tmp_path, ["a", "poison", "b"])
    out = tmp_path / "out"
    args = ["run", str(case), str(logs), "--engine", "dask", "--scheduler", cluster.address]
    assert main([*args, "--format", "none", "--quiet", "-o", str(out)]) == 2
    summary = json.loads((out / "summary.json").read_text())
    by_name = {Path(log["stream"]).stem: log for log in summary["per_log"]}
    assert by_name["a"]["ok"] and by_name["b"]["ok"]
    assert not by_name["poison"]["ok"]
    assert by_name["poison"]["error"].startswith("failed after 2 tries: the worker")
    assert (summary["logs"], summary["logs_failed"], summary["logs_crashed"]) == (3, 1, 0)


def test_a_killed_scheduler_lists_the_unfinished_logs_and_resume_finishes_them(tmp_path):
    names = [f"log{i:02d}" for i in range(12)]
    case, logs = fleet(tmp_path, names, frames=300)
    first = LoopbackCluster(tmp_path / "first", workers=1)
    out = tmp_path / "out"
    command = [sys.executable, "-m", "casewatch", "run", str(case), str(logs), "--engine"]
    command += ["dask", "--format", "none", "-o", str(out), "--labels", "auto"]
    try:
        proc = subprocess.Popen(
            [*command, "--scheduler", first.address],
            cwd=REPO,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        deadline = time.monotonic() + 120
        # once the first log's task has finished (its results and task file written)
        while not (out / "log00" / TASK_FILE).is_file() and time.monotonic() < deadline:
            time.sleep(0.05)
        first.kill_scheduler()
        _, stderr = proc.communicate(timeout=120)
    finally:
        first.close()
    assert proc.returncode == 2, stderr
    assert "Traceback" not in stderr and "this is a bug" not in stderr
    (message,) = [line for line in stderr.splitlines() if line.startswith("casewatch run:")]
    assert f"the Dask scheduler ({first.address}) was lost" in message
    assert "run the same command with --resume" in message
    summary = json.loads((out / "summary.json").read_text())
    lost = [log for log in summary["per_log"] if not log["ok"]]
    assert lost and all(log["error"].startswith("not judged: the Dask") for log in lost)
    assert summary["logs_failed"] == len(lost) < 12 and summary["logs"] == 12
    judged = {Path(log["stream"]).stem for log in summary["per_log"] if log["ok"]}
    assert "log00" in judged

    second = LoopbackCluster(tmp_path / "second", workers=1)
    try:
        done = subprocess.run(
            [*command, "--scheduler", second.address, "--resume", "--quiet"],
            cwd=REPO,
            capture_output=True,
            text=True,
            timeout=300,
        )
    finally:
        second.close()
    summary = json.loads((out / "summary.json").read_text())
    assert done.returncode == 1, done.stderr  # every log judged; the tiny logs have episodes
    assert summary["logs_failed"] == 0 and summary["logs"] == 12
    reused = {Path(log["stream"]).stem for log in summary["per_log"] if log["seconds"] == 0.0}
    # what was judged stays; only logs listed as lost are judged again (a worker may still
    # have finished one after its scheduler died: that complete result is reused too)
    assert judged <= reused and set(names) - reused <= {Path(log["stream"]).stem for log in lost}


def test_shipped_logs_come_back_as_the_same_results(tmp_path, cluster):
    case, logs = fleet(tmp_path, ["a", "b"])
    args = ["run", str(case), str(logs), "--engine", "dask", "--scheduler", cluster.address]
    args += ["--labels", "auto", "--format", "md", "--quiet"]
    assert main([*args, "-o", str(tmp_path / "here")]) == 1
    assert main([*args, "--ship-logs", "1", "-o", str(tmp_path / "shipped")]) == 1
    for name in ("a", "b"):
        here, shipped = tmp_path / "here" / name, tmp_path / "shipped" / name
        assert (here / TASK_FILE).is_file()  # judged in place by the worker
        assert not (shipped / TASK_FILE).exists()  # judged from a copy, written here
        assert (shipped / "report.md").is_file() and (shipped / "events.jsonl").is_file()
        a, b = (json.loads((d / "result.json").read_text()) for d in (here, shipped))
        for result in (a, b):
            for key in ("created", "timings", "content_digest"):
                result.pop(key)
        assert a == b  # the client's paths in both: stream, labels, options
