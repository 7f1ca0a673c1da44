"""Channel names of any case (`chA`, `Apollo7`) through the whole path: check, compile, the
formula grammar, rtamt variable names, the metric engine and a real run."""

from __future__ import annotations

import json
from pathlib import Path

from casewatch import api
from casewatch.cli import main
from casewatch.spec.parser import parse_formula
from tests.evaluator.streams import SMALL_CASE, frame

RENAME = {"lav": "chA", "tfuse": "Apollo7"}

CASE = (
    SMALL_CASE.replace("[lav, tfuse]", "[chA, Apollo7]")
    .replace('spi: {signal: els, threshold: ">= 0.6"}', 'spi: {stl: "els__chA__Apollo7 >= 0.6"}')
    .replace(
        'hazard: {when: "speed > 20"}',
        'hazard: {when: "speed > 20 or ss__Apollo7__chA < -1 or ppcs__chA < -1"}',
    )
)


def renamed_frame(i: int) -> dict[str, object]:
    raw = frame(i)
    raw["channels"] = {RENAME[name]: state for name, state in raw["channels"].items()}
    for state in raw["channels"].values():  # a straight plan, so ss and ppcs have values
        x, y = state["ego"]["x"], state["ego"]["y"]
        state["plan"] = [[k * 0.1, x + k * 1.0, y] for k in range(30)]
    return raw


def write_inputs(tmp_path: Path, frames: int = 100) -> tuple[Path, Path]:
    case = tmp_path / "case.yaml"
    case.write_text(CASE)
    stream = tmp_path / "s.jsonl"
    header = {"header": {"channels": ["chA", "Apollo7"], "period": 0.1}}
    lines = [json.dumps(header)] + [json.dumps(renamed_frame(i)) for i in range(frames)]
    stream.write_text("\n".join(lines) + "\n")
    return case, stream


def test_grammar_reads_mixed_case_signal_names() -> None:
    assert parse_formula("ss__Apollo7__chA >= 0.5").left.name == "ss__Apollo7__chA"


def test_check_and_compile_accept_mixed_case_channels(tmp_path, capsys) -> None:
    case, _ = write_inputs(tmp_path)
    assert main(["check", str(case)]) == 0
    assert main(["compile", str(case), "-o", str(tmp_path / "compiled")]) == 0
    specs = (tmp_path / "compiled" / "specs.stl").read_text()
    assert "els__chA__Apollo7" in specs and "ss__Apollo7__chA" in specs
    assert "0 errors" in capsys.readouterr().err


def test_run_end_to_end_with_chA_and_Apollo7(tmp_path) -> None:
    case, stream = write_inputs(tmp_path)
    result = api.run(case, stream, out_dir=tmp_path / "out", formats=("md",))
    # Apollo7's ego is 2 m off from 2.0 to 3.0 s: els = 1/3 < 0.6, one episode, as with lav/tfuse
    assert [(e.node_id, e.start, e.end) for e in result.episodes] == [("Sn1", 2.0, 3.0)]
    assert result.stream.dropouts == {"chA": 0, "Apollo7": 6}
    hazard = next(f for f in result.formulas if f.node_id == "CSn1")
    assert hazard.signals == ["ppcs__chA", "speed", "ss__Apollo7__chA"]
    assert hazard.ticks_evaluated > 0 and hazard.episodes == 0
    assert (
        main(
            [
                "run",
                str(case),
                str(stream),
                "-o",
                str(tmp_path / "cli"),
                "--quiet",
                "--format",
                "none",
            ]
        )
        == 1
    )
