"""`casewatch export-gsn`: gsn2x YAML that reads back as the same case, with live status."""

from __future__ import annotations

import json
from pathlib import Path

import yaml

from casewatch.cli import main
from casewatch.reports.gsn_export import CSS_NAME, gsn_document, status_class
from casewatch.safety_case.gsn2x_schema import gsn2x_problems
from casewatch.safety_case.loader import require_case
from casewatch.spec.compiler import compile_case

REPO = Path(__file__).resolve().parents[2]
CASES = [REPO / "examples" / "reference-case.yaml", REPO / "examples" / "study-case.yaml"]


def _without_marks(value):
    """A model dump with every source position removed (they differ between the files)."""
    if isinstance(value, dict):
        return {
            k: _without_marks(v)
            for k, v in value.items()
            if k not in ("mark", "key_marks", "ref_marks", "formula_mark")
        }
    if isinstance(value, list):
        return [_without_marks(v) for v in value]
    return value


def test_export_then_import_gives_the_same_case(tmp_path: Path) -> None:
    for path in CASES:
        case = require_case(path)
        out = tmp_path / path.stem
        assert main(["export-gsn", str(path), "-o", str(out)]) == 0
        (exported,) = out.glob("*.gsn.yaml")
        again = require_case(exported)
        assert _without_marks(
            again.model_dump(include={"module", "monitor", "nodes"})
        ) == _without_marks(case.model_dump(include={"module", "monitor", "nodes"}))
        a, _ = compile_case(case)
        b, _ = compile_case(again)
        assert [f.rtamt for f in a.formulas] == [f.rtamt for f in b.formulas]


def test_the_export_is_plain_gsn2x(tmp_path: Path) -> None:
    """Only gsn2x's attributes on the nodes; casewatch's own data in the module's
    additionalInformation, which gsn2x prints in the legend and otherwise ignores."""
    doc = gsn_document(require_case(CASES[0]))
    gsn2x_keys = {
        "text",
        "supportedBy",
        "inContextOf",
        "challenges",
        "undeveloped",
        "url",
        "classes",
        "level",
        "horizontalIndex",
        "rankIncrement",
        "nodeType",
        "acp",
        "defeated",
        "defeatedRelation",
        "additionalInformation",
    }
    for node_id, node in doc.items():
        if node_id != "module":
            assert set(node) <= gsn2x_keys, node_id
    assert set(doc["module"]) == {"name", "brief", "additionalInformation"}
    kept = doc["module"]["additionalInformation"]["casewatch"]
    assert kept["bindings"]["Sn1"] == {"spi": {"signal": "els", "threshold": ">= 0.6", "for": 0.5}}
    assert kept["bindings"]["CSn2"]["hazard"]["when"] == "lead_thw < 1.0 and ego_speed > 5.0"
    assert kept["monitor"]["channels"] == ["lav", "tfuse"]


def test_the_export_is_gsn2x_input_by_gsn2x_s_rules() -> None:
    """Checked against the schema of gsn2x's format (safety_case.gsn2x_schema): in particular
    `challenges` is one node, as gsn2x's parser takes it, never a list."""
    for path in CASES:
        doc = gsn_document(require_case(path))
        assert gsn2x_problems(doc) == [], path
        challenging = {k: v["challenges"] for k, v in doc.items() if "challenges" in v}
        assert challenging and all(isinstance(t, str) for t in challenging.values())
    doc = gsn_document(require_case(CASES[0]))
    assert (doc["CSn1"]["challenges"], doc["CSn2"]["challenges"]) == ("G2", "G5")
    # a list gsn2x cannot hold is refused by the schema, so the check above can fail
    doc["CSn1"]["challenges"] = ["G2"]
    assert gsn2x_problems(doc) == ["CSn1: challenges: Input should be a valid string"]


def test_a_run_puts_each_node_s_worst_status_in_its_classes(tmp_path: Path, capsys) -> None:
    run = tmp_path / "run"
    drive = REPO / "examples/data/highway-tailgating.jsonl.gz"
    assert (
        main(["run", str(CASES[0]), str(drive), "-o", str(run), "--format", "none", "--quiet"]) == 1
    )
    assert main(["export-gsn", str(CASES[0]), str(run), "-o", str(tmp_path / "out")]) == 0
    doc = yaml.safe_load(next((tmp_path / "out").glob("*.gsn.yaml")).read_text())
    worst = {
        s["node_id"]: s["worst"] for s in json.loads((run / "result.json").read_text())["status"]
    }
    for node_id, status in worst.items():
        assert doc[node_id]["classes"] == [status_class(status)], node_id
    assert gsn2x_problems(doc) == []
    assert worst["G1"] in ("undermined", "violated")
    css = (tmp_path / "out" / CSS_NAME).read_text()
    assert f".{status_class(worst['G1'])} rect" in css
    # a run of another case is refused: its statuses would land on the wrong nodes
    assert main(["export-gsn", str(CASES[1]), str(run), "-o", str(tmp_path / "x")]) == 2
    assert "another version of the case" in capsys.readouterr().err
