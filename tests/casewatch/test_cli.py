"""The command line's front door: a fast `--help` and each command's own usage on a bad flag."""

from __future__ import annotations

import argparse
import subprocess
import sys

import pytest

from casewatch.cli import COMMANDS, command_parser, main

HEAVY = ("numpy", "numba", "pydantic", "jinja2", "rtamt", "networkx", "shapely", "lark")


def test_help_imports_no_command_and_lists_every_one():
    code = (
        "import sys; from casewatch.cli import main; main(['--help']); "
        f"print('loaded:', sorted(m for m in {HEAVY!r} if m in sys.modules))"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert "loaded: []" in done.stdout  # nothing heavy: --help answers in under 0.1 s
    for name in COMMANDS:
        assert f"    {name}" in done.stdout


@pytest.mark.parametrize("name", list(COMMANDS))
def test_the_command_list_says_what_each_command_says_of_itself(name):
    module = __import__(f"casewatch.commands.{name.replace('-', '_')}", fromlist=["register"])
    holder = argparse.ArgumentParser(prog="casewatch")
    sub = holder.add_subparsers()
    module.register(sub)
    assert [a.help for a in sub._choices_actions] == [COMMANDS[name]]
    parser, _ = command_parser(name)
    assert parser.prog == f"casewatch {name}"


def test_a_misspelt_flag_prints_that_commands_usage(capsys):
    assert main(["run", "case.yaml", "drive.jsonl", "-o", "out", "--lables", "auto"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("usage: casewatch run ")
    assert "casewatch run: error: unrecognized arguments: --lables auto" in err
    assert main(["diff", "a"]) == 2
    assert capsys.readouterr().err.startswith("usage: casewatch diff ")


def test_no_command_or_an_unknown_one_exits_2_with_the_list(capsys):
    assert main([]) == 2
    assert "check           check a safety case" in capsys.readouterr().err
    assert main(["chek"]) == 2
    assert "invalid choice: 'chek' (choose from 'check'," in capsys.readouterr().err
    assert main(["--version"]) == 0
    assert capsys.readouterr().out.startswith("casewatch ")
