"""`run --scenarios` and `export-scenarios` on the command line: one folder per log and an index
for a fleet, an event whose file cannot be written recorded while the others are written, and
exit codes that follow the run's policy (a refusal of the whole export is 2, before judging)."""

from __future__ import annotations

import gzip
import json
from pathlib import Path

import pytest

from casewatch.cli import main

REPO = Path(__file__).resolve().parents[2]
CASE = str(REPO / "examples" / "reference-case.yaml")
TAILGATING = REPO / "examples" / "data" / "highway-tailgating.jsonl.gz"


@pytest.fixture(scope="module")
def logs(tmp_path_factory) -> Path:
    """Two logs cut from highway-tailgating: `drive` (0-60 s: hazard events CSn2 at 18.6 s
    and at 46.8 s) and `short` (0-10 s: none)."""
    folder = tmp_path_factory.mktemp("logs")
    with gzip.open(TAILGATING, "rt") as fh:
        lines = fh.read().splitlines()
    for name, until in (("drive", 60.0), ("short", 10.0)):
        kept = [line for line in lines if "header" in line[:12] or json.loads(line)["t"] <= until]
        (folder / f"{name}.jsonl").write_text("\n".join(kept) + "\n")
    return folder


def test_a_fleet_gets_one_folder_per_log_and_an_index(logs: Path, tmp_path: Path, capsys) -> None:
    out = tmp_path / "out"
    args = ["run", CASE, str(logs), "-o", str(out), "--format", "none", "--quiet", "--scenarios"]
    assert main(args) == 1  # the run's hazards, as without --scenarios
    printed = capsys.readouterr().out
    assert f"2 scenario(s) from 2 logs; index {out / 'scenarios' / 'index.json'}" in printed
    index = json.loads((out / "scenarios" / "index.json").read_text())
    assert index["format"] == "casewatch-scenario-fleet"
    assert (index["scenarios"], index["failed"], index["logs_refused"]) == (2, 0, 0)
    assert index["logs"] == [
        {
            "stream": str(logs / "drive.jsonl"),
            "folder": "drive",
            "scenarios": 2,
            "failed": 0,
            "catalogue": "drive/scenarios.json",
        },
        {"stream": str(logs / "short.jsonl"), "folder": None, "scenarios": 0, "failed": 0},
    ]
    catalogue = json.loads((out / "scenarios" / "drive" / "scenarios.json").read_text())
    entries = catalogue["scenarios"]
    assert [(e["node"], e["start"], e["window"]) for e in entries] == [
        ("CSn2", 18.6, [15.6, 37.9]),
        ("CSn2", 46.8, [43.8, 53.0]),
    ]
    assert all((out / "scenarios" / "drive" / e["file"]).is_file() for e in entries)
    assert not (out / "scenarios" / "short").exists()


def test_an_event_that_cannot_be_written_is_recorded_and_the_exit_code_stays_the_runs(
    logs: Path, tmp_path: Path, capsys
) -> None:
    out = tmp_path / "run"
    blocked = out / "scenarios" / "event-001-CSn2-18.6s.xosc"
    blocked.mkdir(parents=True)  # a folder where event 1's file belongs
    args = ["run", CASE, str(logs / "drive.jsonl"), "-o", str(out), "--format", "none"]
    assert main([*args, "--quiet", "--scenarios"]) == 1
    err = capsys.readouterr().err
    assert "casewatch run: hazard event 1 (CSn2 at 18.6 s) not exported: " in err
    entries = json.loads((out / "scenarios" / "scenarios.json").read_text())["scenarios"]
    assert [(e["event"], e["file"]) for e in entries] == [
        (1, None),
        (2, "event-002-CSn2-46.8s.xosc"),
    ]
    assert str(blocked) in entries[0]["error"] and entries[0]["trace"][0][-1] == "G1"
    assert (out / "scenarios" / entries[1]["file"]).is_file()
    # --fail-on never: the run passes, and a failed export does not turn it into a 2
    assert main([*args, "--quiet", "--scenarios", "--fail-on", "never"]) == 0
    # export-scenarios on its own: 1 when an event could not be written, 0 once it can
    again = ["export-scenarios", str(out), str(logs / "drive.jsonl"), "-o", str(out / "scenarios")]
    assert main(again) == 1
    blocked.rmdir()
    assert main(again) == 0
    entries = json.loads((out / "scenarios" / "scenarios.json").read_text())["scenarios"]
    assert [e["file"] for e in entries] == [
        "event-001-CSn2-18.6s.xosc",
        "event-002-CSn2-46.8s.xosc",
    ]


def test_run_refuses_unusable_scenario_options_before_judging(
    logs: Path, tmp_path: Path, capsys
) -> None:
    out = tmp_path / "never"
    base = ["run", CASE, str(logs / "short.jsonl"), "-o", str(out), "--scenarios"]
    assert main([*base, "--scenario-channel", "cam"]) == 2
    assert "--scenario-channel 'cam' is not one of the case's channels (lav, tfuse)" in (
        capsys.readouterr().err
    )
    assert main([*base, "--scenario-opendrive", str(tmp_path / "road.xodr")]) == 2
    assert f"{tmp_path / 'road.xodr'}: no such OpenDRIVE file" in capsys.readouterr().err
    assert main([*base, "--scenario-radius", "-3"]) == 2
    assert "--scenario-radius must be a number >= 0, got -3" in capsys.readouterr().err
    stdin = ["run", CASE, "-", "-o", str(out), "--scenarios"]
    assert main(stdin) == 2
    assert "standard input cannot be read twice" in capsys.readouterr().err
    assert not out.exists()  # nothing was judged
