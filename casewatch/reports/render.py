"""Entry points: read `result.json`, write the reports.

Reports are rebuilt from `result.json` alone (`casewatch report OUTDIR` re-renders without
re-running), so `load_result` is strict: a file that is missing, not JSON, of another format or
version, or not shaped like a `RunResult` is refused with a message saying which and where.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from pathlib import Path

from pydantic import ValidationError

from casewatch.errors import CasewatchError
from casewatch.evaluator.result import RESULT_FORMAT, RESULT_VERSION, RunResult
from casewatch.reports.html import render_html
from casewatch.reports.junit import render_junit
from casewatch.reports.markdown import render_markdown

#: format name -> (file name, renderer)
FORMATS: dict[str, tuple[str, Callable[[RunResult], str]]] = {
    "html": ("report.html", render_html),
    "md": ("report.md", render_markdown),
    "junit": ("junit.xml", render_junit),
}


class ResultError(CasewatchError):
    """`result.json` cannot be read as a casewatch result; the message says why and where."""


def _integer(digits: str) -> int | float:
    return int(digits) if len(digits) < 300 else float(digits)


def load_result(path: Path | str) -> RunResult:
    """Read and validate a `result.json`."""
    path = Path(path)
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise ResultError(
            f"{path}: no such file (expected the result.json of a casewatch run)"
        ) from None
    except OSError as exc:
        raise ResultError(f"{path}: cannot read: {exc.strerror or exc}") from None
    try:
        # an integer beyond float range (401 digits) reads as infinity, which the model then
        # refuses with its key, instead of overflowing where a report divides by it
        data = json.loads(raw.decode("utf-8"), parse_int=_integer)
    except UnicodeDecodeError as exc:
        raise ResultError(f"{path}: not UTF-8 text (byte {exc.start})") from None
    except json.JSONDecodeError as exc:
        raise ResultError(f"{path}:{exc.lineno}:{exc.colno}: not valid JSON: {exc.msg}") from None
    except RecursionError:
        raise ResultError(f"{path}: JSON nested too deeply to be a casewatch result") from None
    if not isinstance(data, dict):
        raise ResultError(f"{path}: expected a JSON object, found {type(data).__name__}")
    found_format = data.get("format")
    if found_format != RESULT_FORMAT:
        raise ResultError(
            f"{path}: 'format' is {found_format!r}, expected {RESULT_FORMAT!r} "
            "(is this the result.json of a casewatch run?)"
        )
    version = data.get("version")
    if version != RESULT_VERSION:
        raise ResultError(
            f"{path}: result version {version!r}; this casewatch reads version {RESULT_VERSION} "
            "(re-run the evaluator, or use the casewatch that wrote it)"
        )
    try:
        return RunResult.model_validate(data)
    except ValidationError as exc:
        problems = []
        for error in exc.errors()[:5]:
            where = ".".join(str(part) for part in error["loc"]) or "(top level)"
            problems.append(f"  {where}: {error['msg']}")
        more = exc.error_count() - len(problems)
        if more > 0:
            problems.append(f"  ... and {more} more")
        raise ResultError(
            f"{path}: not a valid casewatch result:\n" + "\n".join(problems)
        ) from None


def parse_formats(text: str | Sequence[str]) -> list[str]:
    """`"html,md"` -> `["html", "md"]`; unknown names are refused with the valid list."""
    names = text.split(",") if isinstance(text, str) else list(text)
    chosen: list[str] = []
    for name in (n.strip().lower() for n in names):
        if not name:
            continue
        if name not in FORMATS:
            raise ValueError(f"unknown report format {name!r}; valid formats: {', '.join(FORMATS)}")
        if name not in chosen:
            chosen.append(name)
    if not chosen:
        raise ValueError(f"no report format given; valid formats: {', '.join(FORMATS)}")
    return chosen


def render_reports(
    result: RunResult, out_dir: Path, formats: Sequence[str] = ("html", "md", "junit")
) -> dict[str, Path]:
    """Write the chosen reports of `result` into `out_dir`; returns format -> path written."""
    chosen = parse_formats(formats)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    written: dict[str, Path] = {}
    for name in chosen:
        filename, render = FORMATS[name]
        target = out_dir / filename
        tmp = target.with_name(target.name + ".tmp")
        tmp.write_text(render(result), encoding="utf-8")
        tmp.replace(target)  # never leave a half-written report behind
        written[name] = target
    return written
