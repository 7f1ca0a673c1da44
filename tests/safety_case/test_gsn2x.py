"""gsn2x files load: its attributes, id spellings, pure arguments and modules over files.

The examples are written out by hand from gsn2x's documentation (syntax, module information,
stylesheets, layout, dialectic extension), not copied from its sources."""

from __future__ import annotations

from pathlib import Path

from casewatch.safety_case.checks import check_file
from casewatch.safety_case.findings import has_errors
from casewatch.safety_case.model import NodeType

SYNTAX = """\
module:
  name: MainModule
  brief: This is a short description of the module
  additionalInformation:
    v1: Changed line 2
    v2: Added line 4
  horizontalIndex: 0
G-TopLevelGoal:
  text: This is a Goal
  supportedBy: [S1]
  inContextOf: [C_A_certain_context]
  classes: [important, reviewed]
  level: top
S1:
  text: This is a Strategy
  supportedBy: [G2, Top]
  horizontalIndex:
    relative: -1
  rankIncrement: 2
C_A_certain_context:
  text: This is a Context
  url: https://example.org/context
G2:
  text: A sub-goal
  undeveloped: true
  acp:
    ACP1: supportedBy
Top:
  nodeType: Goal
  text: An element named freely, typed by nodeType
  undeveloped: true
CG1:
  text: A counter goal
  challenges: G2
  defeated: true
  supportedBy: [CSn1]
CSn1:
  text: A counter solution
"""


def write(folder: Path, name: str, text: str) -> Path:
    path = folder / name
    path.write_text(text, encoding="utf-8")
    return path


def test_a_plain_gsn2x_file_checks_as_a_pure_argument(tmp_path: Path) -> None:
    case, findings = check_file(write(tmp_path, "main.gsn.yaml", SYNTAX))
    assert [f.code for f in findings] == ["CW011"]  # a warning: nothing to monitor
    assert case is not None and not has_errors(findings)
    assert case.nodes["G-TopLevelGoal"].type is NodeType.GOAL
    assert case.nodes["C_A_certain_context"].type is NodeType.CONTEXT
    assert case.nodes["Top"].type is NodeType.GOAL
    assert case.nodes["G-TopLevelGoal"].gsn == {
        "classes": ["important", "reviewed"],
        "level": "top",
    }
    assert case.nodes["S1"].gsn == {"horizontalIndex": {"relative": -1}, "rankIncrement": 2}
    assert case.nodes["CG1"].gsn == {"defeated": True}
    assert case.module.gsn["additionalInformation"] == {
        "v1": "Changed line 2",
        "v2": "Added line 4",
    }
    assert case.monitor.channels == []


def test_modules_over_files(tmp_path: Path) -> None:
    """main uses a and b; both use shared (loaded once); an error in a used file is reported
    in that file, on its own line."""
    write(
        tmp_path,
        "main.gsn.yaml",
        "module:\n  name: main\n  brief: top\n"
        "  uses: [a.gsn.yaml, b.gsn.yaml]\nG1:\n  text: top\n  supportedBy: [S1]\n"
        "S1:\n  text: over parts\n  supportedBy: [G-A, G-B]\n",
    )
    write(
        tmp_path,
        "a.gsn.yaml",
        "module: {name: a, brief: part a, uses: [shared.gsn.yaml]}\n"
        "G-A:\n  text: part a\n  supportedBy: [G-Shared]\n",
    )
    write(
        tmp_path,
        "b.gsn.yaml",
        "module: {name: b, brief: part b, uses: [shared.gsn.yaml]}\n"
        "G-B:\n  text: part b\n  supportedBy: [G-Shared]\n",
    )
    write(tmp_path, "shared.gsn.yaml", "G-Shared:\n  text: shared\n  undeveloped: true\n")
    case, findings = check_file(tmp_path / "main.gsn.yaml")
    assert [f.code for f in findings] == ["CW011"]
    assert set(case.nodes) == {"G1", "S1", "G-A", "G-B", "G-Shared"}
    assert case.nodes["G-Shared"].mark.path == str(tmp_path / "shared.gsn.yaml")
    digest = case.digest
    write(tmp_path, "shared.gsn.yaml", "G-Shared:\n  text: changed\n  undeveloped: true\n")
    assert check_file(tmp_path / "main.gsn.yaml")[0].digest != digest  # every file counts
    write(tmp_path, "shared.gsn.yaml", "G-Shared:\n  text: shared\n  supportedBy: [Sn9]\n")
    _, findings = check_file(tmp_path / "main.gsn.yaml")
    dangling = [f for f in findings if f.code == "CW030"]
    assert [(Path(f.path).name, f.line) for f in dangling] == [("shared.gsn.yaml", 3)]


def test_module_errors(tmp_path: Path) -> None:
    write(
        tmp_path,
        "main.gsn.yaml",
        "module:\n  name: main\n  brief: top\n"
        "  uses: [a.gsn.yaml, missing.gsn.yaml]\nG1:\n  text: top\n  supportedBy: [G2]\n"
        "G2:\n  text: twice\n  undeveloped: true\n",
    )
    write(
        tmp_path,
        "a.gsn.yaml",
        "module: {name: a, brief: b, uses: [main.gsn.yaml]}\n"
        "G2:\n  text: again\n  undeveloped: true\n",
    )
    case, findings = check_file(tmp_path / "main.gsn.yaml")
    assert case is None
    found = {(f.code, Path(f.path).name, f.line) for f in findings}
    assert ("CW028", "main.gsn.yaml", 4) in found  # missing.gsn.yaml cannot be read
    assert ("CW028", "a.gsn.yaml", 1) in found  # a uses main again: a cycle
    assert ("CW029", "a.gsn.yaml", 2) in found  # G2 in both files
    text = next(f.message for f in findings if f.code == "CW029")
    assert text == f"node G2 is defined in a.gsn.yaml and already in {tmp_path / 'main.gsn.yaml'}:8"


def test_a_used_module_s_own_monitor_is_ignored_with_a_warning(tmp_path: Path) -> None:
    write(
        tmp_path,
        "main.yaml",
        "module: {name: main, brief: top, uses: [rules.yaml]}\n"
        "monitor: {channels: [a, b], period: 0.1s}\nG1:\n  text: top\n"
        "  supportedBy: [G2]\n",
    )
    write(
        tmp_path,
        "rules.yaml",
        "module: {name: rules, brief: b}\n"
        "monitor: {channels: [x, y], period: 0.2s}\nG2:\n  text: rules\n"
        "  undeveloped: true\n",
    )
    case, findings = check_file(tmp_path / "main.yaml")
    assert case is not None  # a warning: the case still runs, with its own monitor
    assert case.monitor.channels == ["a", "b"]
    (hit,) = [f for f in findings if f.code == "CW060"]
    assert (Path(hit.path).name, hit.line, hit.severity) == ("rules.yaml", 2, "warning")
    assert "its own `monitor` block is ignored" in hit.message


def test_kept_bindings_and_used_files_that_cannot_be_read(tmp_path: Path) -> None:
    (tmp_path / "latin1.gsn.yaml").write_bytes(b"G-X:\n  text: caf\xe9\n  undeveloped: true\n")
    write(
        tmp_path,
        "main.gsn.yaml",
        "module:\n  name: m\n  brief: b\n  uses: [latin1.gsn.yaml]\n"
        "  additionalInformation:\n    casewatch:\n      bindings:\n"
        "        Sn7: {spi: {signal: els, threshold: '>= 0.6'}}\n"
        "G1: {text: top, undeveloped: true}\n",
    )
    case, findings = check_file(tmp_path / "main.gsn.yaml")
    assert case is None
    found = {(f.code, f.line) for f in findings}
    assert ("CW028", 4) in found  # latin1.gsn.yaml is not UTF-8
    assert ("CW030", 8) in found  # a kept binding for a node that does not exist


def test_contracts_and_odds_survive_an_export_to_gsn2x(tmp_path: Path) -> None:
    """export-gsn keeps `contract:` (library name and parameters, or the written pair) and
    `odd:` (the domain itself, read from its file) for casewatch; reading the export back gives
    the same contracts and domain."""
    from casewatch.reports.gsn_export import write_gsn
    from casewatch.safety_case.loader import load_case

    source = Path(__file__).resolve().parents[2] / "examples" / "odd" / "contracts-case.yaml"
    case, findings = load_case(source)
    assert case is not None, findings
    (written,) = write_gsn(case, tmp_path)
    again, findings = load_case(written)
    assert again is not None, [f.format() for f in findings]
    for node_id, node in case.nodes.items():
        other = again.nodes[node_id]
        assert (other.contract is None) == (node.contract is None), node_id
        if node.contract is not None:
            assert (
                other.contract.use,
                other.contract.params,
                other.contract.assume,
                other.contract.guarantee,
            ) == (
                node.contract.use,
                node.contract.params,
                node.contract.assume,
                node.contract.guarantee,
            )
        if node.odd is not None:
            assert other.odd.attributes == node.odd.attributes
            assert other.odd.combinations == node.odd.combinations
