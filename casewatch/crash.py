"""Internal errors: exit code 3, one line on the terminal, the traceback in a log file.

A crash must never look like a finding (exit 1) or like bad input (exit 2): CI would read it as
a verdict. The terminal gets one line naming the file to attach to a bug report; the traceback,
the command line and the versions go into that file, in the command's output folder when it
has one (`OUT/casewatch-crash.log`), else in a fresh temporary file.
"""

from __future__ import annotations

import argparse
import platform
import sys
import tempfile
import traceback
from pathlib import Path

from casewatch import __version__

#: The exit code of an internal error (0 fine, 1 findings, 2 unusable input).
INTERNAL_ERROR = 3
#: The exit code of the rtamt and numpy STL engines disagreeing (`--stl-engine both`): a bug in
#: one of them, never a verdict, told apart from other internal errors.
ENGINES_DISAGREE = 4
CRASH_LOG = "casewatch-crash.log"


def output_folder(args: argparse.Namespace | None) -> Path | None:
    """The output folder a command writes to (`run -o`, `compile -o`, `report OUTDIR`)."""
    for name in ("out", "output", "outdir"):
        value = getattr(args, name, None)
        if value:
            if getattr(args, "command", None) == "convert":
                # convert's -o is the file (or new bag folder) to write: a crash log inside it
                # would leave a folder at that path and fail the next, correct run
                return Path(value).parent
            return Path(value)
    return None


def write_crash_log(exc: BaseException, argv: list[str], folder: Path | None) -> Path:
    """Write what a bug report needs; fall back to a temporary file when `folder` is unwritable."""
    text = (
        f"casewatch {__version__} internal error\n"
        f"command: casewatch {' '.join(argv)}\n"
        f"python: {sys.version.split()[0]} on {platform.platform()}\n\n"
        + "".join(traceback.format_exception(exc))
    )
    if folder is not None:
        try:
            folder.mkdir(parents=True, exist_ok=True)
            path = folder / CRASH_LOG
            path.write_text(text, encoding="utf-8")
            return path
        except OSError:
            pass
    fd, name = tempfile.mkstemp(prefix="casewatch-crash-", suffix=".log")
    with open(fd, "w", encoding="utf-8") as fh:
        fh.write(text)
    return Path(name)


def report_crash(exc: BaseException, argv: list[str], args: argparse.Namespace | None) -> int:
    """Log `exc`, print the one line and return the exit code of an internal error."""
    path = write_crash_log(exc, argv, output_folder(args))
    reason = f"{type(exc).__name__}: {exc}".strip().splitlines()[0][:200]
    print(
        f"casewatch: internal error ({reason}); this is a bug in casewatch, not in your input: "
        f"please attach {path} to a bug report",
        file=sys.stderr,
    )
    return INTERNAL_ERROR
