"""`casewatch calibrate` end to end on two hand-built half-hour logs (saved signals, hazard and
fault labels), every figure computed by hand; and its refusals."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from casewatch.cli import main as cli
from casewatch.evaluator.signal_store import FILE_NAME, FORMAT_VERSION

PERIOD = 0.1
TICKS = 18000  # half an hour
CASE = """\
# A tiny case: two SPIs on the ego pose
module: {name: tiny}
monitor:
  channels: [lav, tfuse]
  period: 0.1s
  merge_gap: 0s

G1:
  text: Channels locate the ego vehicle consistently
  supportedBy: [Sn1, Sn2, Sn3]

Sn1:
  text: Ego location is consistent across channels (ELS)
  spi: {signal: els, threshold: ">= 0.6"}

Sn2:
  text: Ego orientation is consistent across channels (EOS)
  spi:
    signal: eos
    threshold: ">= 0.5"   # from the HARA
    for: 1s

Sn3:
  text: Ego location is never far off in either channel
  spi: {stl: "els >= 0.1"}
"""
# nominal ticks: 2 x 18000, less 3 s around the hazard label of drive-a (t 1197-1208: 111
# ticks) and around the two faults of drive-b (t 997-1006: 91, t 1497-1505: 81)
NOMINAL = 2 * TICKS - 111 - 91 - 81
HOURS = NOMINAL * PERIOD / 3600


def series(base: float, spans: list[tuple[int, int, float]]) -> np.ndarray:
    x = np.full(TICKS, base)
    for start, length, value in spans:
        x[start : start + length] = value
    return x


def write_run(
    folder: Path,
    streams: Path,
    name: str,
    els: np.ndarray,
    eos: np.ndarray,
    labels: list[dict] | None = None,
    faults: list[dict] | None = None,
) -> Path:
    """A run folder as `casewatch run --save-signals` leaves it, for a stream `name` in
    `streams` (which need not exist: calibrate reads the saved signals)."""
    run = folder / name
    run.mkdir(parents=True)
    t = np.round(np.arange(TICKS) * PERIOD, 6)
    np.savez_compressed(
        run / FILE_NAME,
        t=t,
        names=np.array(["els", "eos"]),
        values=np.stack([els, eos], axis=1),
        period=np.float64(PERIOD),
        max_gap=np.float64(0.5),
        version=np.int64(FORMAT_VERSION),
    )
    result: dict = {"stream": {"path": str(streams / f"{name}.jsonl.gz")}}
    if labels is not None:
        path = streams / f"{name}.labels.jsonl"
        path.write_text("".join(json.dumps(lab) + "\n" for lab in labels))
        result["ground_truth"] = {"labels_path": str(path)}
    if faults is not None:
        (streams / f"{name}.fault-labels.jsonl").write_text(
            "".join(json.dumps(f) + "\n" for f in faults)
        )
    (run / "result.json").write_text(json.dumps(result))
    return run


@pytest.fixture
def fleet(tmp_path: Path) -> tuple[Path, list[Path]]:
    """drive-a: els 0.9 with two 0.3 s ghost dips to 0.5 and a nominal 2 s dip to 0.3, and a
    labelled hazard (els 0.2 for 5 s, not nominal); drive-b: the same ghosts, a localisation
    drift (els 0.4 for 3 s) and a frozen channel (els stays 0.9), both injected faults. eos is
    0.95 in both, dropping to exactly 0.0 for 4 s twice a log (a cliff)."""
    streams = tmp_path / "streams"
    streams.mkdir()
    eos = series(0.95, [(2000, 40, 0.0), (6000, 40, 0.0)])
    a = write_run(
        tmp_path / "runs",
        streams,
        "drive-a",
        series(0.9, [(1000, 3, 0.5), (5000, 3, 0.5), (8000, 20, 0.3), (12000, 51, 0.2)]),
        eos,
        labels=[{"hazard": "G1", "start": 1200.0, "end": 1205.0}],
    )
    b = write_run(
        tmp_path / "runs",
        streams,
        "drive-b",
        series(0.9, [(1000, 3, 0.5), (5000, 3, 0.5), (10000, 31, 0.4)]),
        eos,
        faults=[
            {"fault": "localisation_drift", "start": 1000.0, "end": 1003.0, "channel": "lav"},
            {"fault": "frozen_channel", "start": 1500.0, "end": 1502.0, "channel": "tfuse"},
        ],
    )
    case = tmp_path / "case.yaml"
    case.write_text(CASE)
    return case, [a, b]


def test_calibrate_loosens_by_persistence_and_refuses_a_cliff(fleet, tmp_path, capsys):
    case, runs = fleet
    out = tmp_path / "cal"
    code = cli(
        [
            "calibrate",
            str(case),
            *map(str, runs),
            "--labels",
            "auto",
            "--false-alarms-per-hour",
            "2",
            "-o",
            str(out),
        ]
    )
    assert code == 1  # both originals are over the budget
    report = json.loads((out / "calibration.json").read_text())
    assert report["hours"] == pytest.approx(HOURS, abs=1e-6) and report["faults"] == 2
    sn1, sn2 = report["spis"]
    # Sn1: 2 + 2 ghosts and the nominal dip at for 0; for 0.5 s lets the 3-tick ghosts through
    assert sn1["original"]["episodes"] == 5 and sn1["status"] == "calibrated"
    assert (sn1["chosen"]["threshold"], sn1["chosen"]["for"]) == (0.6, 0.5)
    assert sn1["chosen"]["episodes"] == 1
    assert sn1["chosen"]["per_hour"] == pytest.approx(1 / HOURS)
    assert sn1["chosen"]["per_hour_upper"] == pytest.approx(4.743865 / HOURS, abs=1e-4)
    # the drift (els 0.4 for 31 ticks) is detected, the frozen channel is not
    assert (sn1["faults"], sn1["chosen"]["detected"]) == (2, 1)
    # Sn2: every threshold that can fire raises the 4 cliffs (4 s each: longer than any for:)
    assert sn2["status"] == "not calibratable" and sn2["faults"] == 0
    assert (sn2["chosen"]["threshold"], sn2["chosen"]["for"]) == (0.5, 1.0)
    reason = (
        "no threshold that can fire keeps 2/h: eos is exactly 0 on 160 nominal ticks "
        "(0.4%), and every threshold above 0 fires there; quietest that can fire: "
        ">= 0.5 for 3 s at 4.0/h"
    )
    assert sn2["reason"] == reason
    text = (out / "calibrated-case.yaml").read_text()
    assert 'spi: {signal: els, threshold: ">= 0.6", for: 0.5s}' in text
    # the reason beside the number, after the author's own comment
    assert (
        f'threshold: ">= 0.5"  # from the HARA; casewatch calibrate: not calibratable on '
        f"these logs: {reason}\n"
    ) in text
    assert text.startswith("# A tiny case")
    assert cli(["check", str(out / "calibrated-case.yaml")]) == 0
    printed = capsys.readouterr().out
    assert "2 injected faults" in printed and reason in " ".join(printed.split())
    assert report["skipped"] == [
        {"formula": "Sn3", "reason": "a raw stl: formula; calibrate sets signal + threshold SPIs"}
    ]
    assert "  Sn3: not calibrated (a raw stl: formula;" in printed
    assert max(len(line) for line in printed.splitlines() if "/tmp" not in line) <= 100
    # 5 and 1 episodes in 0.992 h; 95 % bounds 10.51 and 4.74 episodes
    assert (
        "  Sn1    0.99  >= 0.6 0s       5.0 (10.6)*   >= 0.6 0.5s     1.0 (4.8)     1/2"
        "      calibrated\n"
    ) in printed
    html = (out / "calibration.html").read_text()
    assert "<script" not in html and "faults detected" in html and "<polyline" in html
    assert "not calibratable" in html


def test_calibrating_the_calibrated_case_changes_nothing_but_its_notes(fleet, tmp_path):
    case, runs = fleet
    first, second = tmp_path / "one", tmp_path / "two"
    assert (
        cli(
            [
                "calibrate",
                str(case),
                *map(str, runs),
                "--labels",
                "auto",
                "--false-alarms-per-hour",
                "2",
                "-o",
                str(first),
            ]
        )
        == 1
    )
    calibrated = first / "calibrated-case.yaml"
    assert (
        cli(
            [
                "calibrate",
                str(calibrated),
                *map(str, runs),
                "--labels",
                "auto",
                "--false-alarms-per-hour",
                "2",
                "-o",
                str(second),
            ]
        )
        == 1
    )
    # Sn1 now keeps the budget; Sn2's note is written again, not twice
    again = (second / "calibrated-case.yaml").read_text()
    assert again == calibrated.read_text() and again.count("casewatch calibrate:") == 1


def test_too_few_hours_and_tighten(fleet, tmp_path):
    case, runs = fleet
    out = tmp_path / "few"
    assert (
        cli(
            [
                "calibrate",
                str(case),
                *map(str, runs),
                "--labels",
                "auto",
                "--min-hours",
                "2",
                "--false-alarms-per-hour",
                "2",
                "-o",
                str(out),
            ]
        )
        == 1
    )
    report = json.loads((out / "calibration.json").read_text())
    assert [r["status"] for r in report["spis"]] == ["not calibrated", "not calibrated"]
    assert report["spis"][0]["reason"] == (
        f"{HOURS:.2f} h of nominal driving with a value of els, fewer than the 2 h asked "
        "(--min-hours)"
    )
    assert (out / "calibrated-case.yaml").read_text().count("not calibrated on these logs") == 2
    # a generous budget: the originals keep it and stay, unless --tighten
    loose = tmp_path / "loose"
    assert (
        cli(
            [
                "calibrate",
                str(case),
                *map(str, runs),
                "--labels",
                "auto",
                "--false-alarms-per-hour",
                "10",
                "-o",
                str(loose),
            ]
        )
        == 0
    )
    assert (loose / "calibrated-case.diff").read_text() == ""
    tight = tmp_path / "tight"
    assert (
        cli(
            [
                "calibrate",
                str(case),
                *map(str, runs),
                "--labels",
                "auto",
                "--tighten",
                "--false-alarms-per-hour",
                "10",
                "-o",
                str(tight),
            ]
        )
        == 0
    )
    sn1 = json.loads((tight / "calibration.json").read_text())["spis"][0]
    # the strictest threshold that can fire within 10/h (up to 9 episodes): x < 0.9 fires on
    # every dip; at for 0: 4 ghosts + the nominal dip = 5 episodes
    assert (sn1["chosen"]["threshold"], sn1["chosen"]["for"], sn1["chosen"]["episodes"]) == (
        0.9,
        0.0,
        5,
    )


def test_calibrate_refuses_what_it_cannot_use(fleet, tmp_path, capsys):
    case, runs = fleet
    out = tmp_path / "x"
    base = ["calibrate", str(case), *map(str, runs), "-o", str(out)]
    assert cli([*base, "--false-alarms-per-hour", "-1"]) == 2
    assert "--false-alarms-per-hour must be a number >= 0" in capsys.readouterr().err
    assert cli([*base, "--false-alarms-per-hour", "2", "--min-hours", "-1"]) == 2
    assert "--min-hours must be a number of hours >= 0" in capsys.readouterr().err
    # a damaged fault-labels file names its line and the families
    faults = tmp_path / "streams" / "drive-b.fault-labels.jsonl"
    faults.write_text('{"fault": "ghost", "start": 1, "end": 2, "channel": "lav"}\n')
    assert cli([*base, "--labels", "auto", "--false-alarms-per-hour", "2"]) == 2
    err = capsys.readouterr().err
    assert "drive-b.fault-labels.jsonl:1: 'fault' must be one of object_drop" in err
    assert "Traceback" not in err
    # a run that kept no signals
    (runs[0] / FILE_NAME).unlink()
    assert cli([*base, "--false-alarms-per-hour", "2"]) == 2
    assert "--save-signals" in capsys.readouterr().err
