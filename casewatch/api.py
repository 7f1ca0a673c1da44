"""The small public Python API: the same jobs as the CLI, composed from the five packages.

    from casewatch import api
    case, spec = api.prepare("examples/reference-case.yaml")
    result = api.run("examples/reference-case.yaml", "examples/data/highway-tailgating.jsonl.gz",
                     out_dir="out/demo")

Everything here only composes: loading and checks live in `safety_case`, compilation in `spec`,
metrics in `monitor`, judging in `evaluator`, rendering in `reports`.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from casewatch.evaluator.options import RunOptions, RunSinks
from casewatch.evaluator.result import RunResult, result_digest
from casewatch.evaluator.session import evaluate_stream
from casewatch.safety_case.checks import check_file, sort_findings
from casewatch.safety_case.findings import CaseError, Finding, has_errors
from casewatch.safety_case.model import Case
from casewatch.spec.compiler import Mode, check_formulas, compile_case
from casewatch.spec.model import CompiledSpec


def check(path: str | Path, mode: Mode = "online") -> tuple[Case | None, list[Finding]]:
    """Every finding for a case file, sorted by position: loading, structure, formulas.

    Formulas are checked whenever the case loaded, even with structural errors, so one
    `casewatch check` shows everything there is to fix.
    """
    case, findings = check_file(path)
    if case is not None:
        findings = sort_findings(findings + check_formulas(case, mode=mode))
    return case, findings


def prepare(path: str | Path, mode: Mode = "online") -> tuple[Case, CompiledSpec]:
    """Load, check and compile a case; raises `CaseError` (with every finding) on errors."""
    case, findings = check(path, mode)
    if case is None or has_errors(findings):
        raise CaseError([f for f in findings if f.severity == "error"])
    spec, more = compile_case(case, mode=mode)
    if spec is None or has_errors(more):
        raise CaseError([f for f in more if f.severity == "error"])
    return case, spec


def run(
    case_path: str | Path,
    stream: str | Path,
    out_dir: str | Path | None = None,
    options: RunOptions | None = None,
    formats: Sequence[str] = ("html", "md", "junit"),
    **settings: Any,
) -> RunResult:
    """Judge one stream; with `out_dir`, write events.jsonl, result.json and the reports.

    `options` (a `RunOptions`) shape the result; instead, its fields may be given by name
    (`api.run(case, stream, labels="x.labels.jsonl", max_no_data=0.1)`).
    `result.root_no_data.exceeded` says whether the root goal was `no-data` on more than
    `max_no_data` of the ticks (what `casewatch run` reports as unusable input, exit 2)."""
    if options is not None and settings:
        raise TypeError("api.run: give either options or its fields by name, not both")
    options = options if options is not None else RunOptions(**settings)
    case, spec = prepare(case_path)
    out = Path(out_dir) if out_dir is not None else None
    sinks = RunSinks(events_path=out / "events.jsonl" if out is not None else None)
    result = evaluate_stream(case, spec, stream, options, sinks)
    if out is not None:
        write_result(result, out)
        if formats:
            render(out, formats)
    return result


def write_result(result: RunResult, out_dir: Path) -> Path:
    """Write result.json atomically (a reader never sees a half-written record)."""
    out_dir.mkdir(parents=True, exist_ok=True)
    target = out_dir / "result.json"
    partial = out_dir / "result.json.partial"
    sealed = result.model_copy(update={"content_digest": result_digest(result)})
    partial.write_text(sealed.model_dump_json(indent=1), encoding="utf-8")
    partial.replace(target)
    return target


def render(
    out_dir: str | Path, formats: Sequence[str] = ("html", "md", "junit")
) -> dict[str, Path]:
    """Re-render the reports of a run folder from its result.json alone."""
    from casewatch.reports.render import load_result, render_reports

    out = Path(out_dir)
    return render_reports(load_result(out / "result.json"), out, formats)
