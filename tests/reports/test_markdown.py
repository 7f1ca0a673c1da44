"""The Markdown report: tables survive hostile text; headline and traces present."""

from __future__ import annotations

import re

from hypothesis import given, settings
from hypothesis import strategies as st

from casewatch.evaluator.result import RunResult
from casewatch.reports.markdown import md_escape, render_markdown


def _unescaped_pipes(line: str) -> int:
    return len(re.findall(r"(?<!\\)\|", line))


def test_tables_stay_intact_with_hostile_text(hostile_result: RunResult) -> None:
    md = render_markdown(hostile_result)
    lines = md.splitlines()
    tables = 0
    for i, line in enumerate(lines):
        if re.fullmatch(r"\| (?:-+:?|---:)(?: \| (?:---|---:))* \|", line):
            tables += 1
            columns = _unescaped_pipes(line)
            assert _unescaped_pipes(lines[i - 1]) == columns
            j = i + 1
            while j < len(lines) and lines[j].startswith("|"):
                assert _unescaped_pipes(lines[j]) == columns, lines[j]
                j += 1
    assert tables >= 5  # summary, SPI, hazard, gaps, defects
    outside_code = re.sub(r"`[^`]*`", "", md)  # code spans render literally
    assert "<script>" not in outside_code
    assert "\x01" not in md and "\x1b" not in md


def test_escape() -> None:
    assert md_escape("a|b") == r"a\|b"
    assert md_escape("<script>") == r"\<script\>"
    assert md_escape("x\ny") == "x y"
    assert md_escape("a & b") == "a &amp; b"


def test_headline_tables_and_traces(reference_result: RunResult) -> None:
    md = render_markdown(reference_result)
    assert f"**Top claim G1: {reference_result.verdict.upper()}**" in md
    sn1 = next(f for f in reference_result.formulas if f.id == "Sn1")
    assert f"| {sn1.ticks_violated:,} / {sn1.ticks_evaluated:,} |" in md
    first = reference_result.episodes[0]
    assert f"**#1 {first.node_id}**" in md
    assert "→ **G1**" in md  # every trace ends at the root goal
    assert f"## Episodes ({len(reference_result.episodes)})" in md
    assert "| precision | recall |" in md


@settings(max_examples=60, deadline=None)
@given(st.text())
def test_escaped_text_never_breaks_a_table_cell(text: str) -> None:
    escaped = md_escape(text)
    assert "\n" not in escaped and "\r" not in escaped
    assert _unescaped_pipes(escaped.replace("\\\\", "")) == 0
    assert re.search(r"(?<!\\)<", escaped.replace("\\\\", "")) is None
