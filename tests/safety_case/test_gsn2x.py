"""gsn2x files load: its attributes, id spellings, pure arguments and modules over files; gsn2x's
own example files load, export and read back the same.

The small examples are written out by hand from gsn2x's documentation (syntax, module
information, stylesheets, layout, dialectic extension), not copied from its sources; gsn2x's
example files are read from ../shared/gsn2x-examples when it is there (never copied here)."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from casewatch.reports.gsn_export import gsn_document, write_gsn
from casewatch.safety_case.checks import check_file
from casewatch.safety_case.findings import has_errors
from casewatch.safety_case.gsn2x_schema import gsn2x_problems
from casewatch.safety_case.loader import load_file
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
  defeated: true
  acp:
    ACP1: G2
Top:
  nodeType: Goal
  text: An element named freely, typed by nodeType
  undeveloped: true
CG1:
  text: A counter goal
  challenges: G2
  defeatedRelation: G2
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
    assert case.nodes["CG1"].gsn == {"defeatedRelation": "G2"}
    assert case.nodes["G2"].gsn == {"defeated": True, "acp": {"ACP1": "G2"}}
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


# -- gsn2x's own example files (../shared/gsn2x-examples, gsn2x 4.3.2, MIT) -----------------

REPO = Path(__file__).resolve().parents[2]
EXAMPLES = REPO.parent / "shared" / "gsn2x-examples"
needs_examples = pytest.mark.skipif(
    not EXAMPLES.is_dir(), reason=f"gsn2x's example files are not in {EXAMPLES}"
)

#: file -> (node count, warning codes, error codes): what gsn2x 4.3.2 itself says of each file
#: given alone, in casewatch's codes. sub1 names J1, C2 and Sn1 of the files index uses (gsn2x:
#: C03 errors); instance extends module template, which it does not use (gsn2x: C09); two
#: roots are gsn2x's C01 warning (entangled: G1, G2; sub1: G3, A1; sub3: C2, Sn1).
KNOWN = {
    "bullet_lists.gsn.yaml": (2, ["CW011"], []),
    "confidence.gsn.yaml": (8, ["CW011"], []),
    "dialectic/first.gsn.yaml": (25, ["CW011"], []),
    "dialectic/second.gsn.yaml": (29, ["CW011"], []),
    "entangled.gsn.yaml": (4, ["CW011", "CW061"], []),
    "example.gsn.yaml": (20, ["CW011"], []),
    "minimalcss/min.gsn.yaml": (1, ["CW011"], []),
    "modular/index.gsn.yaml": (8, ["CW011"], []),
    "modular/sub1.gsn.yaml": (2, ["CW011", "CW061"], ["CW030", "CW030", "CW030"]),
    "modular/sub2.gsn.yaml": (2, ["CW011"], []),
    "modular/sub3.gsn.yaml": (2, ["CW011", "CW061"], []),
    "template/instance.gsn.yaml": (2, ["CW011"], ["CW065"]),
    "template/template.gsn.yaml": (4, ["CW011"], []),
}


def example(name: str) -> Path:
    return EXAMPLES / name


@needs_examples
def test_the_known_answers_cover_every_example_file() -> None:
    found = {str(p.relative_to(EXAMPLES)) for p in EXAMPLES.rglob("*.yaml")}
    assert found == set(KNOWN)


@needs_examples
@pytest.mark.parametrize("name", sorted(KNOWN))
def test_each_gsn2x_example_loads_as_gsn2x_reads_it(name: str) -> None:
    nodes, warnings, errors = KNOWN[name]
    result = load_file(example(name))
    findings = check_file(example(name))[1]
    assert sorted(f.code for f in findings if f.severity == "warning") == warnings
    assert sorted(f.code for f in findings if f.severity == "error") == errors
    assert result.gsn2x_rules and len(result.partial.nodes) == nodes
    assert has_errors(findings) == bool(errors)


@needs_examples
def test_what_the_examples_hold_is_read() -> None:
    first = check_file(example("dialectic/first.gsn.yaml"))[0]
    assert first.nodes["C1"].text == "" and first.nodes["C1"].type is NodeType.CONTEXT
    assert first.nodes["CG4"].challenges == ["S2"]  # a strategy: gsn2x allows it
    assert first.nodes["CG4"].gsn == {"horizontalIndex": {"absolute": "last"}}
    assert first.nodes["Sn3"].gsn == {"defeated": True}
    second = check_file(example("dialectic/second.gsn.yaml"))[0]
    assert second.nodes["CCSn1"].type is NodeType.COUNTER_SOLUTION  # nodeType, not prefix C
    assert second.nodes["CCSn1"].challenged_relations == [("G2", "CG1")]
    assert second.nodes["CCSn1"].challenges == []
    assert second.nodes["CCG1"].challenges == ["CSn2"]  # a counter node challenged
    assert second.nodes["CG1"].gsn["defeatedRelation"] == "G2"
    assert second.nodes["CG1"].gsn["rankIncrement"] == 1
    ex = check_file(example("example.gsn.yaml"))[0]
    assert ex.nodes["Sn2"].gsn == {
        "layer1": "Additional information on layer 1",
        "layer2": "Additional information on layer 2",
    }
    assert ex.nodes["A2"].gsn == {"classes": ["mycssclass", "anotherclass"]}
    assert ex.nodes["Sn1"].url == "https://github.com/jonasthewolf/gsn2x"
    assert check_file(example("bullet_lists.gsn.yaml"))[0].nodes["G1"].gsn == {"charWrap": 20}
    confidence = check_file(example("confidence.gsn.yaml"))[0]
    assert confidence.nodes["G3"].gsn == {"acp": {"ACP3": ["Sn2a", "Sn2b"]}}
    mini = check_file(example("minimalcss/min.gsn.yaml"))[0]
    assert mini.module.name == "min"  # no module block: the file names it
    index = check_file(example("modular/index.gsn.yaml"))[0]
    assert set(index.nodes) == {"G1", "S1", "G2", "J1", "G3", "A1", "C2", "Sn1"}
    instance = load_file(example("template/instance.gsn.yaml")).partial
    assert instance.module.gsn["extends"] == [{"module": "template", "develops": {"G1": ["G2"]}}]


def _binding(value) -> object:
    """A binding without its source positions (they differ between the two files)."""
    marks = {"mark", "formula_mark", "guarantee_mark", "assume_mark"}
    return None if value is None else value.model_dump(exclude=marks)


def _graph(case) -> dict:
    """Per node: type, text, edges, challenged relations, gsn2x attributes and layers,
    bindings (what the round trip must keep)."""
    return {
        i: (
            n.type,
            n.text,
            n.supported_by,
            n.in_context_of,
            n.challenges,
            n.challenged_relations,
            n.undeveloped,
            n.url,
            n.gsn,
            _binding(n.spi),
            _binding(n.hazard),
            _binding(n.contract),
        )
        for i, n in case.nodes.items()
    }


@needs_examples
@pytest.mark.parametrize("name", sorted(n for n, (_, _, errors) in KNOWN.items() if not errors))
def test_each_example_exports_to_gsn2x_and_reads_back_the_same(name: str, tmp_path: Path) -> None:
    case = check_file(example(name))[0]
    (written,) = write_gsn(case, tmp_path)
    document = yaml.safe_load(written.read_text(encoding="utf-8"))
    assert gsn2x_problems(document) == []
    again, findings = check_file(written)
    assert again is not None, [f.format() for f in findings]
    assert _graph(again) == _graph(case)
    source = yaml.safe_load(example(name).read_text(encoding="utf-8"))
    if "module" not in source or not source["module"].get("uses"):
        # a file alone is gsn2x input by the schema too (a module's uses are other files)
        assert gsn2x_problems(source) == []


# -- small hand-written files with known answers -------------------------------------------


def findings_of(folder: Path, text: str, name: str = "arg.gsn.yaml") -> list[tuple]:
    return [(f.code, f.severity, f.line) for f in check_file(write(folder, name, text))[1]]


def test_relation_challenges_are_checked_by_gsn2x_s_rules(tmp_path: Path) -> None:
    base = "G1:\n  supportedBy: [Sn1]\nSn1: {}\n"  # lines 1-3
    assert findings_of(tmp_path, base + "CSn1:\n  challenges: G1 -> Sn1\n") == [
        ("CW011", "warning", 1)
    ]
    # the relation read backwards is the same link
    assert findings_of(tmp_path, base + "CSn1:\n  challenges: Sn1 -> G1\n")[1:] == []
    assert findings_of(tmp_path, base + "CSn1:\n  challenges: G1 -> G1\n")[1:] == [
        ("CW062", "error", 5)
    ]
    assert findings_of(tmp_path, base + "CSn1:\n  challenges: G1 -> Sn9\n")[1:] == [
        ("CW030", "error", 5)
    ]
    # G2 is a second root (only a warning); G1 and G2 are not linked
    text = base + "G2: {undeveloped: true}\nCSn1:\n  challenges: G1 -> G2\n"
    assert findings_of(tmp_path, text)[1:] == [("CW061", "warning", 4), ("CW062", "error", 6)]


def test_pure_argument_ids_and_node_types_as_gsn2x_types_them(tmp_path: Path) -> None:
    text = "Goal:\n  supportedBy: [Evidence]\nEvidence:\n  nodeType: Solution\nC1:\n"
    text += "  nodeType: Solution\n  text: a solution despite its prefix\nX1: {text: x}\n"
    case, findings = check_file(write(tmp_path, "arg.gsn.yaml", text))
    assert case is None and [(f.code, f.line) for f in findings if f.severity == "error"] == [
        ("CW020", 8)  # no prefix, no nodeType: gsn2x's V01 too
    ]
    partial = load_file(tmp_path / "arg.gsn.yaml").partial
    assert partial.nodes["Goal"].type is NodeType.GOAL
    assert partial.nodes["C1"].type is NodeType.SOLUTION
    # in a monitored case `Goal` stays CW020, as before (casewatch's own id rule)
    monitored = "module: {name: m}\nmonitor: {channels: [a, b]}\nGoal: {text: t}\n"
    assert ("CW020", 3) in [(c, line) for c, _, line in findings_of(tmp_path, monitored)]


def test_layers_in_a_pure_argument_and_in_a_monitored_case(tmp_path: Path) -> None:
    pure = "G1:\n  text: t\n  undevelopped: true\n  layer1: [any, value]\n"
    case = check_file(write(tmp_path, "pure.gsn.yaml", pure))[0]
    assert case.nodes["G1"].gsn == {"undevelopped": True, "layer1": ["any", "value"]}
    assert findings_of(tmp_path, pure, "pure.gsn.yaml") == [
        ("CW011", "warning", 1),
        ("CW039", "warning", 1),  # undeveloped is not set: the typo is a layer
        ("CW063", "warning", 3),
    ]
    head = "module: {name: m}\nmonitor: {channels: [a, b]}\n"
    text_layer = head + "G1:\n  text: t\n  undeveloped: true\n  review: passed on 2026-11-02\n"
    case = check_file(write(tmp_path, "case.yaml", text_layer))[0]
    assert case.nodes["G1"].gsn == {"review": "passed on 2026-11-02"}
    # a monitored case keeps CW013 for what is no text, looks like a typo or a binding key
    for key, value in (("review", "[a, b]"), ("undevelopped", "true"), ("threshold", "'> 1'")):
        text = head + f"G1:\n  text: t\n  undeveloped: true\n  {key}: {value}\n"
        assert ("CW013", "error", 6) in findings_of(tmp_path, text, "case.yaml"), key


def test_a_monitored_relation_challenge_is_said_not_judged(tmp_path: Path) -> None:
    text = (
        "module: {name: m}\nmonitor: {channels: [a, b]}\n"
        "G1:\n  text: t\n  supportedBy: [Sn1]\nSn1:\n  text: e\n"
        "  spi: {signal: els, threshold: '>= 0.6'}\n"
        "CSn1:\n  text: d\n  challenges: [G1, G1 -> Sn1]\n  hazard: {when: 'els < 0.1'}\n"
    )
    case, findings = check_file(write(tmp_path, "case.yaml", text))
    assert [(f.code, f.severity, f.line) for f in findings] == [("CW064", "warning", 11)]
    assert case.nodes["CSn1"].challenges == ["G1"]
    assert case.nodes["CSn1"].challenged_relations == [("G1", "Sn1")]
    # gsn2x holds one challenge: the export writes the first and keeps the list for casewatch
    doc = gsn_document(case)
    assert doc["CSn1"]["challenges"] == "G1"
    kept = doc["module"]["additionalInformation"]["casewatch"]["bindings"]["CSn1"]
    assert kept["challenges"] == ["G1", "G1 -> Sn1"]
    assert gsn2x_problems(doc) == []
    (written,) = write_gsn(case, tmp_path / "out")
    again = check_file(written)[0]
    assert _graph(again) == _graph(case)


def test_check_says_when_nothing_is_monitored(tmp_path: Path, capsys) -> None:
    from casewatch.cli import main

    head = "module: {name: m}\nmonitor: {channels: [a, b]}\n"
    bare = write(
        tmp_path, "bare.yaml", head + "G1: {text: t, supportedBy: [Sn1]}\nSn1: {text: e}\n"
    )
    assert main(["check", str(bare)]) == 0
    assert "nothing is monitored: no solution has an `spi`" in capsys.readouterr().err
    pure = write(tmp_path, "pure.gsn.yaml", "G1: {undeveloped: true}\n")
    assert main(["check", str(pure)]) == 0
    assert "nothing is monitored: it has no `monitor` block" in capsys.readouterr().err
    reference = REPO / "examples" / "reference-case.yaml"
    assert main(["check", str(reference)]) == 0
    assert "nothing is monitored" not in capsys.readouterr().err


def test_the_gsn2x_schema_refuses_what_gsn2x_refuses() -> None:
    good = {
        "module": {"name": "m", "stylesheets": ["a.css"], "extra": {"any": 1}},
        "G1": {"supportedBy": "Sn1", "horizontalIndex": {"absolute": "last"}, "layer": [1]},
        "Sn1": {"classes": ["x"], "rankIncrement": 2, "charWrap": 20},
        "CSn1": {"challenges": "G1 -> Sn1", "acp": {"ACP1": ["CSn1"]}},
    }
    assert gsn2x_problems(good) == []
    bad = {
        "G1": {"supportedBy": ["Sn1"], "undeveloped": True},
        "Sn1": {"classes": "x", "horizontalIndex": {"relative": 1, "absolute": 0}},
        "CSn1": {"challenges": ["G1"]},
        "Sn2": {"challenges": "G1"},
        "Sn3": {"rankIncrement": -1},
        "X1": {"text": "x"},
        "G2": {"nodeType": "Claim"},
        "G3": {"supportedBy": "G9"},
    }
    problems = gsn2x_problems(bad)
    for fragment in (
        "G1: undeveloped but supported",
        "Sn1: classes",
        "Sn1: horizontalIndex",
        "CSn1: challenges",
        "Sn2: only counter nodes challenge",
        "Sn3: rankIncrement",
        "X1: no type",
        "G2: nodeType",
        "G3: names 'G9', no element",
    ):
        assert any(p.startswith(fragment) for p in problems), (fragment, problems)


def test_imports_run_one_way_between_checks_loader_and_structure() -> None:
    """Issue 32: checks -> loader -> structure, never back (no cycle, not even a lazy one)."""
    import ast

    package = REPO / "casewatch" / "safety_case"

    def imported(name: str) -> set[str]:
        tree = ast.parse((package / f"{name}.py").read_text(encoding="utf-8"))
        return {
            node.module.rsplit(".", 1)[-1]
            for node in ast.walk(tree)
            if isinstance(node, ast.ImportFrom) and node.module
        }

    assert "checks" not in imported("loader") | imported("structure")
    assert "loader" not in imported("structure")
    assert {"loader", "structure"} <= imported("checks")


def test_extends_develops_another_module_s_undeveloped_element(tmp_path: Path) -> None:
    """gsn2x's distributed development (its documentation's template and instance): the
    template's undeveloped G1 is supported by the instance's G2 once both are in the case."""
    write(
        tmp_path,
        "template.gsn.yaml",
        "module: {name: template, brief: b}\nG0:\n  text: top\n  supportedBy: [G1]\n"
        "G1:\n  text: for somebody else\n  undeveloped: true\n",
    )
    instance = (
        "module:\n  name: instance\n  uses: [template.gsn.yaml]\n  extends:\n"
        "    - module: template\n      develops: {G1: [G2]}\n"
        "G2:\n  text: developed here\n  supportedBy: [Sn1]\nSn1: {text: a solution}\n"
    )
    case, findings = check_file(write(tmp_path, "instance.gsn.yaml", instance))
    assert [f.code for f in findings] == ["CW011"]  # G2 is no second root: G1 names it
    assert case.nodes["G1"].supported_by == ["G2"] and not case.nodes["G1"].undeveloped
    # the export holds every module in one file: the development is written out, `extends`
    # (of a module gsn2x would not find there) is not
    document = gsn_document(case)
    assert "extends" not in document["module"] and document["G1"]["supportedBy"] == ["G2"]
    assert gsn2x_problems(document) == []
    for develops, problem in (
        ("{G9: [G2]}", "G9 is not a node of module template"),
        ("{G0: [G2]}", "G0 is not undeveloped"),
        ("{G1: [G7]}", "G7 (to develop G1) is not a node of module instance"),
    ):
        text = instance.replace("{G1: [G2]}", develops)
        _, findings = check_file(write(tmp_path, "instance.gsn.yaml", text))
        hits = [f for f in findings if f.code == "CW065"]
        assert len(hits) == 1 and problem in hits[0].message and hits[0].line == 4, develops


def test_a_command_that_prepares_a_case_says_when_it_judges_nothing(tmp_path: Path, capsys) -> None:
    """`casewatch run` (and tune, calibrate) on a monitored case that binds no evidence: the
    run goes on (its root goal is `external`, no verdict), and stderr says why."""
    from casewatch.commands.common import prepare_case

    head = "module: {name: m}\nmonitor: {channels: [a, b]}\n"
    bare = write(
        tmp_path, "bare.yaml", head + "G1: {text: t, supportedBy: [Sn1]}\nSn1: {text: e}\n"
    )
    assert prepare_case("run", str(bare)) is not None
    assert capsys.readouterr().err == (
        f"casewatch run: {bare}: nothing is monitored: no solution has an `spi` or `contract` "
        "and no counter solution a `hazard`, so a run judges none of its claims (docs/gsn2x.md)\n"
    )
    assert prepare_case("run", str(REPO / "examples" / "reference-case.yaml")) is not None
    assert capsys.readouterr().err == ""


def test_a_pure_argument_node_may_be_empty_or_null(tmp_path: Path) -> None:
    text = "G1:\n  inContextOf: C1\n  supportedBy: Sn1\nC1:\nSn1: {}\n"
    case, findings = check_file(write(tmp_path, "arg.gsn.yaml", text))
    assert [f.code for f in findings] == ["CW011"]
    assert (case.nodes["C1"].text, case.nodes["C1"].type) == ("", NodeType.CONTEXT)
    assert case.module.name == "arg" and case.nodes["G1"].supported_by == ["Sn1"]
    # a monitored case keeps casewatch's rule: a node says what it claims
    head = "module: {name: m}\nmonitor: {channels: [a, b]}\n"
    assert findings_of(tmp_path, head + text, "case.yaml") == [
        ("CW014", "error", 3),  # G1 has no text
        ("CW012", "error", 6),  # C1 is no mapping
        ("CW014", "error", 7),  # Sn1 has no text
    ]


@pytest.mark.parametrize(
    ("attribute", "kept", "error"),
    [
        ("horizontalIndex: {relative: -1}", {"horizontalIndex": {"relative": -1}}, None),
        ("horizontalIndex: {absolute: last}", {"horizontalIndex": {"absolute": "last"}}, None),
        ("horizontalIndex: -2", {"horizontalIndex": {"relative": -2}}, None),  # gsn2x 2's form
        ("horizontalIndex: 3", {"horizontalIndex": {"absolute": 3}}, None),
        ("horizontalIndex: {absolute: -1}", None, "`horizontalIndex`: expected gsn2x's"),
        ("horizontalIndex: {relative: 1, absolute: 0}", None, "`horizontalIndex`: expected"),
        ("rankIncrement: -1", None, "`rankIncrement`"),
        ("charWrap: 20", {"charWrap": 20}, None),
        ("nodeType: Claim", None, "`nodeType` should be 'Goal'"),
        ("acp: {ACP1: [G1, 2]}", None, "`acp`: expected gsn2x's assurance claim points"),
        ("acp: {ACP1: [G1]}", {"acp": {"ACP1": ["G1"]}}, None),
        ("defeatedRelation: 5", None, "`defeatedRelation`"),
    ],
)
def test_gsn2x_attributes_are_read_by_gsn2x_s_types(
    tmp_path: Path, attribute: str, kept: dict | None, error: str | None
) -> None:
    text = f"G1:\n  text: t\n  undeveloped: true\n  {attribute}\n"
    case, findings = check_file(write(tmp_path, "arg.gsn.yaml", text))
    errors = [f for f in findings if f.severity == "error"]
    if error is None:
        assert errors == [] and case.nodes["G1"].gsn == kept
    else:
        assert [(f.code, f.line) for f in errors] == [("CW012", 4)]
        assert error in errors[0].message, errors[0].message


def test_defeats_and_claim_points_are_backed_by_the_argument(tmp_path: Path) -> None:
    """gsn2x's V10, V13 and V09: a defeated node is challenged, a defeated relation is one of
    the node's, an assurance claim point sits on the node or one of its links."""
    base = "G1:\n  supportedBy: [S1]\nS1:\n  supportedBy: [G2, G3]\n"  # lines 1-4
    fine = (
        base + "  defeatedRelation: [G2, G3]\n  acp: {ACP1: [G2, S1]}\n"  # lines 5-6
        "G2: {undeveloped: true, defeated: true}\nG3: {undeveloped: true}\n"  # lines 7-8
        "CG1: {challenges: G2, undeveloped: true}\n"
    )
    assert findings_of(tmp_path, fine) == [("CW011", "warning", 1)]
    wrong = fine.replace("[G2, G3]\n  acp", "[G2, G9]\n  acp").replace("[G2, S1]", "[G1]")
    wrong = wrong.replace("challenges: G2", "challenges: G3")
    assert findings_of(tmp_path, wrong)[1:] == [
        ("CW066", "error", 5),  # S1 has no relation to G9
        ("CW067", "error", 6),  # G1 is above S1, not one of its links
        ("CW066", "error", 7),  # G2 is defeated, but CG1 now challenges G3
    ]


def test_module_information_is_kept_through_the_export(tmp_path: Path) -> None:
    text = (
        "module:\n  name: arg\n  brief: b\n  version: 3\n  stylesheets: [a.css]\n"
        "  charWrap: 30\n  horizontalIndex: {relative: 1}\nG1: {text: t, undeveloped: true}\n"
    )
    case = check_file(write(tmp_path, "arg.gsn.yaml", text))[0]
    expected = {
        "version": 3,
        "stylesheets": ["a.css"],
        "charWrap": 30,
        "horizontalIndex": {"relative": 1},
    }
    assert case.module.gsn == expected
    (written,) = write_gsn(case, tmp_path / "out")
    document = yaml.safe_load(written.read_text(encoding="utf-8"))
    assert gsn2x_problems(document) == [] and document["module"]["version"] == 3
    assert check_file(written)[0].module.gsn == expected
    # a monitored case keeps casewatch's module keys: an unknown one is CW013
    monitored = text.replace("module:", "monitor: {channels: [a, b]}\nmodule:")
    assert ("CW013", "error", 5) in findings_of(tmp_path, monitored, "case.yaml")
