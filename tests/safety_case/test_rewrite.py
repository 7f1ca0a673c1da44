"""safety_case.rewrite: new thresholds in the user's own YAML, nothing else changed."""

from __future__ import annotations

import re

import pytest

from casewatch.safety_case.rewrite import Change, RewriteError, replace_number, rewrite

CASE = """\
# my case
G1:
  text: Top goal   # keep me
  supportedBy: [Sn1]

Sn1:
  text: els
  spi: {signal: els, threshold: ">= 0.6"}   # the study's

Sn2:
  text: block style
  spi:
    signal: ols
    threshold: '>= 0.5'
    for: 1s

CSn1:
  text: hazard
  challenges: G1
  hazard: {when: "2.5 > x and lead_thw < 1.0", min_duration: 1s}
"""


def change(node, kind, signal, op, old, new, dkind=None, dold=0.0, dnew=0.0, left=True):
    return Change(node, kind, signal, op, left, old, new, dkind, dold, dnew)


def test_only_the_numbers_change():
    out = rewrite(
        CASE,
        [
            change("Sn1", "spi", "els", ">=", 0.6, 0.55, "for", 0.0, 0.0),
            change("Sn2", "spi", "ols", ">=", 0.5, 0.45, "for", 1.0, 0.0),
            change("CSn1", "hazard", "lead_thw", "<", 1.0, 0.9, "min_duration", 1.0, 1.5),
        ],
    )
    want = (
        CASE.replace('threshold: ">= 0.6"', 'threshold: ">= 0.55"')
        .replace("threshold: '>= 0.5'\n    for: 1s\n", "threshold: '>= 0.45'\n")
        .replace('lead_thw < 1.0", min_duration: 1s', 'lead_thw < 0.9", min_duration: 1.5s')
    )
    # ruamel keeps every comment; an end-of-line comment may move by a column
    assert re.sub(r" +#", " #", out) == re.sub(r" +#", " #", want)


def test_replace_number_finds_the_comparison_either_way_round():
    assert replace_number("a < 1 and b>=2.50", "b", ">=", True, 3.0) == "a < 1 and b>=3.0"
    assert replace_number("2.5 > x", "x", ">", False, 1.25) == "1.25 > x"
    assert replace_number("lead_thw2 < 1 or lead_thw < 1", "lead_thw", "<", True, 0.8) == (
        "lead_thw2 < 1 or lead_thw < 0.8"
    )
    with pytest.raises(RewriteError, match="cannot find"):
        replace_number("x < y", "x", "<", True, 1.0)


def test_unknown_node_is_an_error():
    with pytest.raises(RewriteError, match="Sn9 is not in the case"):
        rewrite(CASE, [change("Sn9", "spi", "els", ">=", 0.6, 0.5)])


def test_notes_sit_beside_the_threshold_and_replace_their_own_earlier_notes():
    text = (
        'Sn1:\n  spi: {signal: els, threshold: ">= 0.6"}  # from the HARA\n\n'
        "Sn2:\n  spi:\n    signal: ols\n    threshold: '>= 0.5'\n\n# --- next part\nSn3:\n"
        '  spi: {signal: eos, threshold: ">= 0.8"}\n'
    )
    once = rewrite(text, [], {"Sn1": "not calibratable (a)", "Sn2": "not calibrated (b)"})
    assert once == (
        'Sn1:\n  spi: {signal: els, threshold: ">= 0.6"}  # from the HARA; casewatch '
        "calibrate: not calibratable (a)\n\n"
        "Sn2:\n  spi:\n    signal: ols\n    threshold: '>= 0.5'  # casewatch calibrate: not "
        'calibrated (b)\n\n# --- next part\nSn3:\n  spi: {signal: eos, threshold: ">= 0.8"}\n'
    )
    # a later run: Sn1 changes (its note goes, the author's comment stays), Sn2 gets a new note
    twice = rewrite(
        once,
        [change("Sn1", "spi", "els", ">=", 0.6, 0.5, "for", 0.0, 1.0)],
        {"Sn2": "not calibrated (c)"},
    )
    assert twice == (
        'Sn1:\n  spi: {signal: els, threshold: ">= 0.5", for: 1s}  # from the HARA\n\n'
        "Sn2:\n  spi:\n    signal: ols\n    threshold: '>= 0.5'  # casewatch calibrate: not "
        'calibrated (c)\n\n# --- next part\nSn3:\n  spi: {signal: eos, threshold: ">= 0.8"}\n'
    )
