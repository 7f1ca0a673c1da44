"""Property: no input makes the loader or the checks raise; every failure is a coded finding."""

from __future__ import annotations

import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from casewatch.safety_case.checks import check_case
from casewatch.safety_case.codes import CODES
from casewatch.safety_case.loader import load_bytes, load_text

FUZZ = settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])

IDS = st.sampled_from(["G1", "G2", "S1", "Sn1", "Sn2", "C1", "A1", "J1", "CG1", "CSn1", "X1"])
KEYS = st.sampled_from(
    [
        "text",
        "supportedBy",
        "inContextOf",
        "challenges",
        "undeveloped",
        "url",
        "spi",
        "hazard",
        "signal",
        "threshold",
        "for",
        "stl",
        "when",
        "merge_gap",
        "min_duration",
        "channels",
        "period",
        "metrics",
        "signals",
        "name",
        "brief",
        "pairing_gate",
        "junk",
    ]
)
SCALARS = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-5, 5),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=12),
    IDS,
    st.sampled_from([">= 0.6", "< x", "0.5s", "300ms", "-1s", "els > 1", "lav", "tfuse"]),
)
VALUES = st.recursive(
    SCALARS,
    lambda inner: st.one_of(
        st.lists(inner, max_size=4),
        st.dictionaries(st.one_of(KEYS, IDS, st.text(max_size=5)), inner, max_size=5),
    ),
    max_leaves=20,
)
NODE = st.fixed_dictionaries(
    {"text": st.one_of(st.text(max_size=8), SCALARS)},
    optional={
        "supportedBy": st.one_of(IDS, st.lists(IDS, max_size=3), VALUES),
        "inContextOf": st.one_of(IDS, st.lists(IDS, max_size=3)),
        "challenges": st.one_of(IDS, st.lists(IDS, max_size=2)),
        "undeveloped": st.one_of(st.booleans(), SCALARS),
        "spi": st.one_of(
            st.fixed_dictionaries(
                {"signal": st.just("els"), "threshold": SCALARS},
                optional={"for": SCALARS, "stl": SCALARS},
            ),
            VALUES,
        ),
        "hazard": st.one_of(st.fixed_dictionaries({"when": SCALARS}), VALUES),
    },
)
CASES = st.fixed_dictionaries(
    {},
    optional={
        "module": st.one_of(st.fixed_dictionaries({"name": st.text(max_size=5)}), VALUES),
        "monitor": st.one_of(
            st.fixed_dictionaries(
                {"channels": st.lists(st.sampled_from(["lav", "tfuse", "x__y", "A"]), max_size=3)},
                optional={"period": SCALARS, "metrics": VALUES, "signals": VALUES},
            ),
            VALUES,
        ),
    },
).flatmap(
    lambda head: st.dictionaries(IDS, st.one_of(NODE, VALUES), max_size=8).map(
        lambda nodes: {**head, **nodes}
    )
)


def assert_all_coded(findings: list) -> None:
    for item in findings:
        assert item.code in CODES
        assert item.severity == CODES[item.code].severity
        assert item.line >= 1 and item.col >= 1, item  # every finding points into the file
        assert item.message


def run_everything(text: str) -> list:
    result = load_text(text, "fuzz.yaml")
    findings = list(result.findings)
    if result.partial is not None:
        findings += check_case(result.partial, skipped=result.skipped)
    if result.case is None:
        assert any(f.severity == "error" for f in result.findings)
    return findings


@FUZZ
@given(st.binary(max_size=300))
def test_random_bytes_never_raise(data: bytes) -> None:
    result = load_bytes(data, "fuzz.yaml")
    findings = list(result.findings)
    if result.partial is not None:
        findings += check_case(result.partial, skipped=result.skipped)
    assert_all_coded(findings)


@FUZZ
@given(st.text(alphabet=st.sampled_from(list("GSnC:{}[],-&*!|>'\" \n\t#.01ab")), max_size=120))
def test_random_yaml_like_text_never_raises(text: str) -> None:
    assert_all_coded(run_everything(text))


@FUZZ
@given(CASES)
def test_random_case_trees_never_raise(tree: dict) -> None:
    text = yaml.safe_dump(tree, allow_unicode=True, sort_keys=False)
    assert_all_coded(run_everything(text))


@FUZZ
@given(VALUES)
def test_random_yaml_trees_never_raise(tree: object) -> None:
    text = yaml.safe_dump(tree, allow_unicode=True)
    assert_all_coded(run_everything(text))
