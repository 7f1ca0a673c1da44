"""`casewatch check`: output lines, exit codes and the JSON format."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import pytest

from casewatch.commands import check
from tests.safety_case.fixtures import BASE, case

REFERENCE = Path(__file__).resolve().parents[2] / "examples" / "reference-case.yaml"


def run(path: Path | str, fmt: str = "text") -> int:
    return check.main(argparse.Namespace(case=str(path), format=fmt))


def test_reference_case_passes(capsys: pytest.CaptureFixture[str]) -> None:
    assert run(REFERENCE) == 0
    out, err = capsys.readouterr()
    assert out == ""
    assert err.strip().endswith(": 0 errors, 0 warnings, 30 nodes")


def test_errors_exit_1_with_one_line_per_finding(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "bad.yaml"
    # line 5: supportedBy names Sn9 (dangling, column 22); line 6: Sn1 then unreachable
    path.write_text(case("G1:\n  text: top\n  supportedBy: [Sn9]\nSn1:\n  text: e\n"))
    assert run(path) == 1
    out, err = capsys.readouterr()
    lines = [line for line in out.splitlines() if not line.startswith("    ")]
    assert lines == [
        f"{path}:5:17: CW030 error: G1 `supportedBy` names 'Sn9', which is not a node in this "
        "case; did you mean 'Sn1'?",
        f"{path}:6:1: CW037 error: solution Sn1 is not connected to the root goal G1",
    ]
    assert "2 errors, 0 warnings" in err


def test_warnings_only_exit_0(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "warn.yaml"
    path.write_text(case("G1:\n  text: top\n"))
    assert run(path) == 0
    out, _ = capsys.readouterr()
    assert out.startswith(f"{path}:3:1: CW039 warning: ")


def test_unreadable_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert run(tmp_path / "nope.yaml") == 2
    out, _ = capsys.readouterr()
    assert ": CW001 error: cannot read file" in out


def test_json_format(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "dup.yaml"
    path.write_text(BASE + "Sn1:\n  text: again\n")  # duplicate key on line 8
    assert run(path, "json") == 1
    out, err = capsys.readouterr()
    assert err == ""
    data = json.loads(out)
    assert [(d["code"], d["severity"], d["line"], d["col"], d["path"]) for d in data] == [
        ("CW005", "error", 8, 1, str(path))
    ]
    assert run(REFERENCE, "json") == 0
    assert json.loads(capsys.readouterr().out) == []


def test_collect_findings_returns_case_even_with_structural_errors(tmp_path: Path) -> None:
    path = tmp_path / "s.yaml"
    path.write_text(case("G1:\n  text: top\n  supportedBy: [Sn9]\n"))
    value, findings = check.collect_findings(path)
    assert value is not None and [f.code for f in findings] == ["CW030"]


def test_through_the_cli_entry_point(capsys: pytest.CaptureFixture[str]) -> None:
    # Needs every command module of casewatch/cli.py (compile, run, report) to import.
    from casewatch.cli import main

    assert main(["check", str(REFERENCE)]) == 0
    assert main(["check", str(REFERENCE), "--format", "yaml"]) == 2  # usage error
    assert main(["check"]) == 2
    capsys.readouterr()
