"""`casewatch compile` and the files it writes (`spec/artifacts.py`, `commands/compile.py`)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import pytest

from casewatch.commands import compile as compile_command
from casewatch.spec.artifacts import specs_text, trace_map
from casewatch.spec.compiler import compile_case
from tests.spec.cases import hazard_node, make_case, spi_node

CASE_YAML = """\
module: {name: tiny}
monitor:
  channels: [lav, tfuse]
  period: 0.1s
  signals: {speed: ego speed in m/s, lane: lane offset in m}
G1:
  text: Ego drives safely
  supportedBy: [Sn1, Sn2]
Sn1:
  text: Locations agree
  spi: {signal: els, threshold: ">= 0.6", for: 0.3s}
Sn2:
  text: Speed stays legal
  spi: {stl: "speed <= 13.9"}
CSn1:
  text: Tailgated
  challenges: [G1]
  hazard: {when: "abs(ocs - ols) > 0.5 and ss < 0.8 and ppcs >= 0.8"}
"""


def run(case_path: Path, out: Path, mode: str = "online") -> int:
    parser = argparse.ArgumentParser()
    compile_command.register(parser.add_subparsers(dest="command"))
    return compile_command.main(
        parser.parse_args(["compile", str(case_path), "-o", str(out), "--mode", mode])
    )


def test_specs_text_lists_every_formula_after_its_comment() -> None:
    spec, _ = compile_case(
        make_case(spi_node("Sn1", "els", ">=", 0.6), hazard_node("CSn1", "ss < 0.5"))
    )
    assert spec is not None
    lines = specs_text(spec).splitlines()
    i = lines.index("# Sn1 (spi): els >= 0.6")
    assert lines[i + 1] == "# source: els >= 0.6" and lines[i + 2] == "(els >= 0.6)"
    j = lines.index("# CSn1 (hazard): hazard CSn1")
    assert lines[j + 2] == "(not (ss < 0.5))"
    assert trace_map(spec)["CSn1"]["CSn1"] == [
        [{"id": "CSn1", "text": "hazard CSn1"}, {"id": "G1", "text": "Ego drives safely"}]
    ]


def test_compile_command_writes_three_files(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    case_path = tmp_path / "tiny.yaml"
    case_path.write_text(CASE_YAML, encoding="utf-8")
    assert run(case_path, tmp_path / "out") == 0
    stl = (tmp_path / "out" / "specs.stl").read_text(encoding="utf-8")
    formulas = [line for line in stl.splitlines() if line and not line.startswith("#")]
    assert formulas == [
        "(once[0s:0.3s] (els >= 0.6))",
        "(speed <= 13.9)",
        "(not (((abs((ocs - ols)) > 0.5) and (ss < 0.8)) and (ppcs >= 0.8)))",
    ]
    traces = json.loads((tmp_path / "out" / "trace.json").read_text(encoding="utf-8"))
    assert [step["id"] for step in traces["Sn2"]["Sn2"][0]] == ["Sn2", "G1"]
    signals = json.loads((tmp_path / "out" / "signals.json").read_text(encoding="utf-8"))["signals"]
    assert signals["speed"] == {
        "source": "declared",
        "description": "ego speed in m/s",
        "formulas": ["Sn2"],
    }
    assert signals["lane"]["formulas"] == []  # declared, unused: still listed
    assert signals["els"]["source"] == "builtin" and signals["els"]["formulas"] == ["Sn1"]


def test_compile_command_exits_2_on_errors_and_writes_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    case_path = tmp_path / "bad.yaml"
    case_path.write_text(CASE_YAML.replace('"speed <= 13.9"', '"sped <= 13.9"'), encoding="utf-8")
    assert run(case_path, tmp_path / "out") == 2
    out = capsys.readouterr().out
    assert "CW041 error: unknown signal 'sped' in formula of node Sn2; did you mean 'speed'?" in out
    assert f"{case_path}:14:" in out  # the line of the `stl:` value
    assert not (tmp_path / "out").exists()


def test_compile_command_online_rejects_future_offline_accepts(tmp_path: Path) -> None:
    case_path = tmp_path / "future.yaml"
    case_path.write_text(
        CASE_YAML.replace('"speed <= 13.9"', '"eventually[0:1s] speed <= 13.9"'), encoding="utf-8"
    )
    assert run(case_path, tmp_path / "online") == 2
    assert run(case_path, tmp_path / "offline", mode="offline") == 0
    assert "(eventually[0s:1s] (speed <= 13.9))" in (tmp_path / "offline" / "specs.stl").read_text()
