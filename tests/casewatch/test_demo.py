"""`make demo`'s printing: every line within 100 columns, commands broken only between
options, each part ending on its verdict line."""

from __future__ import annotations

from tools import demo


def test_commands_wrap_within_100_columns_between_options(capsys):
    demo.command(
        "casewatch",
        "run",
        "examples/rules/rules-case.yaml",
        "examples/data/rules",
        "--labels",
        "auto",
        "--jobs",
        "2",
        "--format",
        "none",
        "--quiet",
        "-o",
        "out/demo-rules",
    )
    lines = capsys.readouterr().out.splitlines()
    first = (
        "$ casewatch run examples/rules/rules-case.yaml examples/data/rules --labels auto "
        "--jobs 2 \\"
    )
    assert lines == [first, "    --format none --quiet -o out/demo-rules"]
    assert len(first) == 91  # "--format none" would make it 105


def test_long_output_and_verdicts_are_wrapped_with_an_indent(capsys):
    demo.show("  " + "ACCEPTED road.type=highway, environment.weather=clear " * 4)
    demo.verdict("12 of 12 cells accepted; " + "x " * 60)
    lines = capsys.readouterr().out.splitlines()
    assert all(len(line) <= demo.WIDTH for line in lines)
    assert lines[0].startswith("  ACCEPTED") and lines[1].startswith("      ")
    assert [line for line in lines if line.startswith("  => ")] == [lines[3]]
    assert lines[-1].startswith("      x")  # the verdict's continuation, indented under it
