"""render_reports, load_result errors and the `casewatch report` command."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from casewatch.cli import main as cli_main
from casewatch.evaluator.result import RunResult
from casewatch.reports.render import ResultError, load_result, parse_formats, render_reports


def test_render_reports_writes_the_chosen_files(
    reference_result: RunResult, tmp_path: Path
) -> None:
    written = render_reports(reference_result, tmp_path, ("md", "junit"))
    assert written == {"md": tmp_path / "report.md", "junit": tmp_path / "junit.xml"}
    assert not (tmp_path / "report.html").exists()
    assert all(p.stat().st_size > 0 for p in written.values())


def test_round_trip_through_result_json(reference_result: RunResult, tmp_path: Path) -> None:
    path = tmp_path / "result.json"
    path.write_text(reference_result.model_dump_json())
    assert load_result(path) == reference_result


@pytest.mark.parametrize(
    ("content", "expected"),
    [
        (None, "no such file"),
        ("{not json", "result.json:1:2: not valid JSON"),
        ("[]", "expected a JSON object"),
        ('{"format": "other", "version": 1}', "'format' is 'other'"),
        ('{"format": "casewatch-result", "version": 99}', "result version 99"),
        ('{"format": "casewatch-result", "version": 1}', "casewatch_version: Field required"),
        ("[" * 100_000, "nested too deeply"),
    ],
)
def test_load_result_errors(tmp_path: Path, content: str | None, expected: str) -> None:
    path = tmp_path / "result.json"
    if content is not None:
        path.write_text(content)
    with pytest.raises(ResultError) as info:
        load_result(path)
    assert expected in str(info.value)
    assert str(path) in str(info.value)


def test_parse_formats() -> None:
    assert parse_formats("html, md,html") == ["html", "md"]
    with pytest.raises(ValueError, match="valid formats: html, md, junit"):
        parse_formats("html,pdf")


def test_cli_rerenders(
    reference_result: RunResult, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "result.json").write_text(reference_result.model_dump_json())
    assert cli_main(["report", str(tmp_path), "--format", "md"]) == 0
    assert capsys.readouterr().out.strip() == f"md: {tmp_path / 'report.md'}"
    assert (tmp_path / "report.md").exists()


def test_cli_missing_or_invalid_result_exits_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert cli_main(["report", str(tmp_path)]) == 2
    assert "no such file" in capsys.readouterr().err
    (tmp_path / "result.json").write_text(json.dumps({"format": "casewatch-result"}))
    assert cli_main(["report", str(tmp_path)]) == 2
    assert "result version None" in capsys.readouterr().err


def test_cli_rejects_unknown_format(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert cli_main(["report", str(tmp_path), "--format", "pdf"]) == 2
    assert "valid formats: html, md, junit" in capsys.readouterr().err


def test_empty_run_renders_every_format(reference_result: RunResult, tmp_path: Path) -> None:
    # A run that read no frame: no episodes, gaps, series or status, times unknown.
    stream = reference_result.stream.model_copy(
        update={
            "frames_read": 0,
            "t_start": None,
            "t_end": None,
            "duration": 0.0,
            "defects": [],
            "defect_count": 0,
            "digest": None,
        }
    )
    empty = reference_result.model_copy(
        update={
            "stream": stream,
            "episodes": [],
            "data_gaps": [],
            "series": [],
            "status": [],
            "verdict": "no-data",
            "ground_truth": None,
            "formulas": [],
        }
    )
    written = render_reports(empty, tmp_path)
    html = written["html"].read_text()
    assert "No SPI violation and no hazard event" in html
    assert 'class="verdict bg-no-data"' in html
    assert "not hashed" in html
    assert "No SPI violation" in written["md"].read_text()
