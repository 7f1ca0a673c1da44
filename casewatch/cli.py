"""The `casewatch` command line. It only parses arguments and dispatches to a command module.

Exit codes are shared by every command: 0 success, 1 findings/violations, 2 usage or input
that cannot be used, 3 an internal error (a bug: one line on the terminal, the traceback in
`casewatch-crash.log`, see `casewatch/crash.py`).
"""

from __future__ import annotations

import argparse
import importlib
import sys

from casewatch import __version__
from casewatch.crash import report_crash

COMMANDS = ("check", "compile", "run", "report", "tune", "calibrate", "diff", "export_scenarios",
            "convert", "export_gsn", "odd", "compare")


def build_parser() -> tuple[argparse.ArgumentParser, dict[str, object]]:
    parser = argparse.ArgumentParser(
        prog="casewatch",
        description="Monitor driving channels against a GSN safety case compiled to STL.",
    )
    parser.add_argument("--version", action="version", version=f"casewatch {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    modules: dict[str, object] = {}
    for name in COMMANDS:
        module = importlib.import_module(f"casewatch.commands.{name}")
        module.register(sub)
        modules[name.replace("_", "-")] = module  # the command line spells it with a hyphen
    return parser, modules


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    try:
        parser, modules = build_parser()
    except Exception as exc:  # an import or registration bug: still exit 3, not a traceback
        return report_crash(exc, argv, None)
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse exits 2 on usage errors, 0 on --help
        return int(exc.code or 0)
    if args.command is None:
        parser.print_help(sys.stderr)
        return 2
    try:
        return int(modules[args.command].main(args))
    except KeyboardInterrupt:
        print("casewatch: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        return 0
    except Exception as exc:  # a bug, never a verdict: exit 3 with the traceback in a file
        return report_crash(exc, argv, args)


if __name__ == "__main__":
    sys.exit(main())
