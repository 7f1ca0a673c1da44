"""The `casewatch` command line. It only parses arguments and dispatches to a command module.

Exit codes are shared by every command: 0 success, 1 findings/violations (a damaged log
included), 2 usage or input that cannot be used, 3 an internal error (a bug: one line on the
terminal, the traceback in `casewatch-crash.log`, see `casewatch/crash.py`), 4 the rtamt and
numpy STL engines disagreeing (`run --stl-engine both`; README.md, "Exit codes").

Only the chosen command's module is imported (they pull in numpy, numba, pydantic, jinja2...):
`casewatch --help` lists the commands from `COMMANDS` alone and answers in well under 0.3 s.
The command's own parser reads the rest of the command line, so a bad flag prints that
command's usage (`casewatch run --lables` shows `run`'s options, not the command list).
"""

from __future__ import annotations

import argparse
import importlib
import sys
from types import ModuleType

from casewatch import __version__
from casewatch.crash import report_crash
from casewatch.errors import CasewatchError

#: Every command and its one-line help, in the order `--help` lists them. Each module's
#: `register` gives the same help to its own parser (a test keeps the two in step).
COMMANDS: dict[str, str] = {
    "check": "check a safety case and report every problem with its line",
    "compile": "compile the SPIs and hazard rules of a safety case into rtamt STL files",
    "run": "judge one or more streams against a safety case",
    "report": "re-render the reports of a run from OUTDIR/result.json",
    "tune": "thresholds from labelled logs (PR curves, held-out scores)",
    "calibrate": "SPI thresholds and for: from nominal logs (false alarms per hour)",
    "diff": "compare two runs (or two fleets) of the same logs",
    "export-scenarios": "hazard events as OpenSCENARIO 1.2 files",
    "convert": "convert a ROS 2 bag to a JSON Lines stream, or a stream to a bag",
    "export-gsn": "write the argument as gsn2x YAML, with a run's node statuses as CSS classes",
    "odd": "the operational design domain judged runs support (heatmap, YAML ODD)",
    "compare": "compare many runs grouped by agent and scenario, with a violation map",
    "annotate": "write a run's verdicts into its recording (MCAP with Foxglove schemas)",
    "warm-up": "fill numba's cache with the compiled kernels, once after installing or upgrading",
}


def top_parser() -> argparse.ArgumentParser:
    """`casewatch [--version] COMMAND`: the command list, without importing any command."""
    parser = argparse.ArgumentParser(
        prog="casewatch",
        description="Monitor driving channels against a GSN safety case compiled to STL.",
        epilog="'casewatch COMMAND --help' shows a command's options.",
    )
    parser.add_argument("--version", action="version", version=f"casewatch {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, text in COMMANDS.items():
        sub.add_parser(name, help=text, add_help=False)
    return parser


def command_parser(name: str) -> tuple[argparse.ArgumentParser, ModuleType]:
    """The parser of one command (prog `casewatch NAME`) and its module, imported now."""
    module = importlib.import_module(f"casewatch.commands.{name.replace('-', '_')}")
    holder = argparse.ArgumentParser(prog="casewatch")
    sub = holder.add_subparsers(dest="command")
    module.register(sub)
    return sub.choices[name], module


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] not in COMMANDS:
        try:  # --help, --version, or an unknown command (argparse names the valid ones)
            top_parser().parse_args(argv[:1])
        except SystemExit as exc:  # argparse exits 2 on usage errors, 0 on --help
            return int(exc.code or 0)
        top_parser().print_help(sys.stderr)
        return 2
    command = argv[0]
    try:
        parser, module = command_parser(command)
    except Exception as exc:  # an import or registration bug: still exit 3, not a traceback
        return report_crash(exc, argv, None)
    try:
        args = parser.parse_args(argv[1:])
    except SystemExit as exc:
        return int(exc.code or 0)
    args.command = command
    try:
        return int(module.main(args))
    except KeyboardInterrupt:
        print("casewatch: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        return 0
    except CasewatchError as exc:  # a refusal the command did not word itself: one line, its code
        print(f"casewatch {command}: {exc}", file=sys.stderr)
        return exc.exit_code
    except Exception as exc:  # a bug, never a verdict: exit 3 with the traceback in a file
        return report_crash(exc, argv, args)


if __name__ == "__main__":
    sys.exit(main())
