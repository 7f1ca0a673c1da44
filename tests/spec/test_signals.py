"""Signal resolution: catalogue names, per-pair and per-channel forms, declared signals,
and did-you-mean for unknown names."""

from __future__ import annotations

from casewatch.spec.parser import parse_formula
from casewatch.spec.signals import resolve_signals

CHANNELS = ["lav", "tfuse"]


def test_known_forms_resolve() -> None:
    formula = parse_formula(
        "els__lav__tfuse >= 0.6 and ppcs__lav > 0.8 and ss__tfuse__lav > 0.5 and speed < 14"
    )
    known, unknown = resolve_signals(formula, CHANNELS, {"speed": "ego speed [m/s]"})
    assert known == ["els__lav__tfuse", "ppcs__lav", "speed", "ss__tfuse__lav"]
    assert unknown == []


def test_unknown_name_suggests_the_closest() -> None:
    _known, unknown = resolve_signals(parse_formula("x >= 1 or elss >= 0.6"), CHANNELS)
    assert [(u.name, u.col, u.suggestion) for u in unknown] == [
        ("x", 1, None),
        ("elss", 11, "els"),
    ]
    assert unknown[1].message() == "unknown signal 'elss' in formula; did you mean 'els'?"
    hint = unknown[1].hint(CHANNELS)
    assert hint.startswith("(signals available for channels lav, tfuse: els, els_var, eos,")
    assert "els__lav" not in hint  # families only, not every suffixed form


def test_channel_not_declared_is_unknown() -> None:
    _known, unknown = resolve_signals(parse_formula("ppcs__carla > 0.8"), CHANNELS)
    assert [u.name for u in unknown] == ["ppcs__carla"]
    assert unknown[0].suggestion in {"ppcs__lav", "ppcs"}


def test_declared_signal_suggested() -> None:
    _known, unknown = resolve_signals(parse_formula("sped < 14"), CHANNELS, {"speed": "ego speed"})
    assert unknown[0].suggestion == "speed"
    assert "speed" in unknown[0].families
