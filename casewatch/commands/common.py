"""What several commands do the same way: load and compile the case, refusing one with errors."""

from __future__ import annotations

import sys
from pathlib import Path

from casewatch import api
from casewatch.batch import FleetError, read_summary
from casewatch.errors import CasewatchError
from casewatch.safety_case.findings import CaseError
from casewatch.safety_case.model import Case
from casewatch.safety_case.structure import unmonitored_reason
from casewatch.spec.model import CompiledSpec


def prepare_case(command: str, path: str) -> tuple[Case, CompiledSpec] | None:
    """The case and its compiled formulas; None (exit 2) after printing every finding of a
    case with errors. A case that binds no evidence is said to judge nothing (docs/gsn2x.md)."""
    try:
        prepared = api.prepare(path)
        if prepared[0].monitor.channels and (reason := unmonitored_reason(prepared[0])):
            print(f"casewatch {command}: {path}: {reason}", file=sys.stderr)
        return prepared
    except CaseError as exc:
        for finding in exc.findings:
            print(finding.format(), file=sys.stderr)
        print(
            f"casewatch {command}: {path} has errors; fix them first (casewatch check {path})",
            file=sys.stderr,
        )
        return None


def sweep_options_ok(command: str, candidates: int, jobs: int) -> bool:
    """`--candidates` and `--jobs` of tune and calibrate in range; otherwise print why."""
    if not 2 <= candidates <= 10_000:
        print(f"casewatch {command}: --candidates must be between 2 and 10000", file=sys.stderr)
        return False
    if jobs < 1:
        print(f"casewatch {command}: --jobs must be at least 1", file=sys.stderr)
        return False
    return True


class UsageError(CasewatchError, ValueError):
    """Input a command cannot use: printed as one line, exit 2."""


def run_folders(folder: Path) -> dict[str, Path]:
    """{log name: run folder} of a run folder (result.json) or a fleet folder (summary.json;
    the logs that could be judged)."""
    if (folder / "summary.json").is_file():
        try:
            logs = read_summary(folder)["per_log"]
        except FleetError as exc:
            raise UsageError(str(exc)) from None
        return {
            Path(log["out_dir"]).name: Path(log["out_dir"]) for log in logs if log.get("ok", True)
        }
    if (folder / "result.json").is_file():
        return {folder.name: folder}
    raise UsageError(
        f"{folder}: neither a run folder (result.json) nor a fleet folder (summary.json)"
    )
