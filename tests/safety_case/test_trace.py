"""Traces from a node up to the root."""

from __future__ import annotations

import pytest

from casewatch.safety_case.loader import load_case_text
from casewatch.safety_case.model import Case
from casewatch.safety_case.trace import parents, supporters, traces_to_root
from tests.safety_case.fixtures import case

DIAMOND = case(
    "G1: {text: root, supportedBy: [S1], inContextOf: [C1]}\n"
    "S1: {text: strategy, supportedBy: [G2, G3]}\n"
    "G2: {text: left, supportedBy: [Sn1]}\n"
    "G3: {text: right, supportedBy: [Sn1]}\n"
    "Sn1: {text: shared evidence}\n"
    "C1: {text: context}\n"
    "CSn1: {text: hazard, challenges: [G3, G2]}\n"
)


def load(text: str) -> Case:
    value, findings = load_case_text(text)
    assert value is not None, findings
    return value


def ids(paths: list[list[tuple[str, str]]]) -> list[list[str]]:
    return [[node_id for node_id, _ in path] for path in paths]


def test_shared_evidence_has_two_paths_in_yaml_order() -> None:
    value = load(DIAMOND)
    paths = traces_to_root(value, "Sn1")
    # parents of Sn1 in YAML order: G2 (line 5) before G3 (line 6)
    assert ids(paths) == [["Sn1", "G2", "S1", "G1"], ["Sn1", "G3", "S1", "G1"]]
    assert paths[0][0] == ("Sn1", "shared evidence")
    assert paths[0][-1] == ("G1", "root")


def test_counter_solution_goes_through_challenged_claims_in_its_order() -> None:
    paths = traces_to_root(load(DIAMOND), "CSn1")
    assert ids(paths) == [["CSn1", "G3", "S1", "G1"], ["CSn1", "G2", "S1", "G1"]]


def test_root_and_context() -> None:
    value = load(DIAMOND)
    assert ids(traces_to_root(value, "G1")) == [["G1"]]
    assert ids(traces_to_root(value, "C1")) == [["C1", "G1"]]


def test_unknown_id_raises() -> None:
    with pytest.raises(KeyError):
        traces_to_root(load(DIAMOND), "G9")


def test_helpers() -> None:
    value = load(DIAMOND)
    assert supporters(value)["S1"] == ["G2", "G3"]
    assert parents(value)["Sn1"] == ["G2", "G3"]
    assert parents(value)["CSn1"] == ["G3", "G2"]


def test_case_without_root_goal_has_no_traces() -> None:
    # a supportedBy cycle leaves no root goal (CW035); formula checks still ask for traces
    value = load(
        case(
            "G1: {text: a, supportedBy: [G2]}\nG2: {text: b, supportedBy: [G1, Sn1]}\n"
            "Sn1: {text: e}\n"
        )
    )
    assert traces_to_root(value, "Sn1") == []
