"""Issue 23: inputs that used to crash casewatch, each now a finding or a defect (no traceback)."""

from __future__ import annotations

import gzip
import json
from pathlib import Path

from casewatch.cli import main
from tests.evaluator.streams import frame, write_case, write_stream

REPO = Path(__file__).resolve().parents[2]
REFERENCE = REPO / "examples" / "reference-case.yaml"


def test_reference_case_without_its_root_goal_is_a_finding(tmp_path, capsys):
    text = REFERENCE.read_text()
    start = text.index("\nG1:\n")
    end = text.index("\n\n", start + 1)
    path = tmp_path / "no-root.yaml"
    path.write_text(text[:start] + text[end:])
    assert main(["check", str(path)]) == 1
    assert main(["compile", str(path), "-o", str(tmp_path / "c")]) == 2
    assert main(["run", str(path), "-", "-o", str(tmp_path / "o")]) == 2
    out, err = capsys.readouterr()
    assert "CW036 error: the argument starts at S1" in out and "Traceback" not in out + err


def test_supported_by_cycle_without_root_is_a_finding(tmp_path, capsys):
    path = tmp_path / "cycle.yaml"
    path.write_text(
        "module: {name: t}\nmonitor: {channels: [lav, tfuse]}\n"
        "G1: {text: a, supportedBy: [G2]}\nG2: {text: b, supportedBy: [G1, Sn1]}\n"
        "Sn1:\n  text: e\n  spi: {signal: els, threshold: '>= 0.6'}\n"
    )
    assert main(["check", str(path)]) == 1
    out = capsys.readouterr().out
    assert ":3:1: CW035 error: no root goal" in out and "CW034" in out


def test_truncated_gzip_stream_judges_the_frames_before_and_writes_result(tmp_path, capsys):
    case = write_case(tmp_path / "case.yaml")
    plain = write_stream(tmp_path / "s.jsonl").read_bytes()
    whole = gzip.compress(plain, mtime=0)
    stream = tmp_path / "half.jsonl.gz"
    stream.write_bytes(whole[: len(whole) // 2])
    code = main(["run", str(case), str(stream), "-o", str(tmp_path / "o"), "--format", "none"])
    assert code in (0, 1)
    result = json.loads((tmp_path / "o" / "result.json").read_text())
    defect = result["stream"]["defects"][-1]
    assert defect["kind"] == "truncated-stream"
    assert 0 < result["stream"]["frames_read"] == defect["line"] - 2  # header on line 1


def test_five_byte_gzip_is_unusable_input_not_a_crash(tmp_path, capsys):
    case = write_case(tmp_path / "case.yaml")
    stream = tmp_path / "five.jsonl.gz"
    stream.write_bytes(b"\x1f\x8b\x08\x00\x00")
    assert main(["run", str(case), str(stream), "-o", str(tmp_path / "o"), "--quiet"]) == 2
    result = json.loads((tmp_path / "o" / "result.json").read_text())
    assert result["stream"]["defects"][0]["kind"] == "truncated-stream"


def test_deeply_nested_line_is_one_malformed_json_defect(tmp_path):
    case = write_case(tmp_path / "case.yaml")
    stream = tmp_path / "deep.jsonl"
    rows = [json.dumps(frame(i)) for i in range(40)]
    rows.insert(20, "[" * 100_000)
    stream.write_text("\n".join(rows) + "\n")
    code = main(["run", str(case), str(stream), "-o", str(tmp_path / "o"), "--format", "none",
                 "--quiet"])
    assert code in (0, 1)
    result = json.loads((tmp_path / "o" / "result.json").read_text())
    assert [(d["line"], d["kind"]) for d in result["stream"]["defects"]] == [
        (21, "malformed-json")
    ]
    assert result["stream"]["frames_read"] == 40
