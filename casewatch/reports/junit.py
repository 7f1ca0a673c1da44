"""JUnit XML: the run as a test suite, so CI systems show violated evidence like failed tests.

One test case per SPI node and per hazard node; it fails when its formula had any episode that
the run's `--fail-on` policy counts (evaluator.policy), and the failure holds the worst episode
(span, worst robustness) and its trace; episodes the policy does not count are listed in the
test's output. A formula that was
never evaluated (no tick had data) is an error, not a pass: missing data is never a success.
Built with xml.etree so the output is always well-formed; characters XML 1.0 forbids are dropped.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET

from casewatch.evaluator.policy import damaged, gated
from casewatch.evaluator.result import Episode, FormulaStats, RunResult
from casewatch.reports.view import fmt_share, fmt_time

#: Episodes listed in a failure's body after the worst one.
JUNIT_EPISODE_CAP = 50

_ILLEGAL_XML = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\ud800-\udfff\ufffe\uffff]")


def xml_text(text: object) -> str:
    """`text` without the characters XML 1.0 cannot hold (control characters, lone surrogates)."""
    return _ILLEGAL_XML.sub("", str(text))


def _episode_line(e: Episode) -> str:
    return (
        f"{fmt_time(e.start)} to {fmt_time(e.end)} ({e.ticks} ticks), "
        f"worst robustness {e.worst_robustness:+.3f} at {fmt_time(e.t_worst)}"
    )


def _trace_lines(e: Episode) -> list[str]:
    return ["  " + " -> ".join(f"{s.id} ({s.text})" for s in path) for path in e.trace]


def _case(
    suite: ET.Element,
    classname: str,
    formula: FormulaStats,
    episodes: list[Episode],
    period: float,
    fail_on: str = "any",
) -> tuple[int, int]:
    """Add one test case; returns (failures, errors) it adds."""
    name = f"{formula.node_id}: {formula.node_text}"
    case = ET.SubElement(suite, "testcase", classname=xml_text(classname), name=xml_text(name))
    case.set("time", f"{formula.ticks_evaluated * period:.3f}")
    what = "SPI" if formula.kind == "spi" else "hazard"
    out = [
        f"formula: {formula.source}",
        f"evaluated {formula.ticks_evaluated} ticks, violating {formula.ticks_violated} "
        f"({fmt_share(formula.ticks_violated, formula.ticks_evaluated)}), without data "
        f"{formula.ticks_no_data}",
    ]
    if episodes and not gated(formula.kind, fail_on):
        noun = "episode" if formula.kind == "spi" else "event"
        worst = min(episodes, key=lambda e: e.worst_robustness)
        out.append(
            f"{len(episodes)} {noun}{'s' if len(episodes) != 1 else ''}, not counted as "
            f"failures (--fail-on {fail_on}); worst {_episode_line(worst)}"
        )
        episodes = []
    ET.SubElement(case, "system-out").text = xml_text("\n".join(out))
    if episodes:
        worst = min(episodes, key=lambda e: e.worst_robustness)
        noun = "episode" if formula.kind == "spi" else "event"
        plural = "s" if len(episodes) != 1 else ""
        message = (
            f"{what} {formula.node_id} had {len(episodes)} {noun}{plural}"
            f"; worst {_episode_line(worst)}"
        )
        body = [message, "trace:", *_trace_lines(worst), f"all {noun}s:"]
        body += [f"  {_episode_line(e)}" for e in episodes[:JUNIT_EPISODE_CAP]]
        if len(episodes) > JUNIT_EPISODE_CAP:
            body.append(f"  ... and {len(episodes) - JUNIT_EPISODE_CAP} more")
        failure = ET.SubElement(
            case, "failure", message=xml_text(message), type=f"casewatch.{formula.kind}"
        )
        failure.text = xml_text("\n".join(body))
        return 1, 0
    if formula.ticks_evaluated == 0:
        message = f"{what} {formula.node_id} was never evaluated: no tick had all its inputs"
        error = ET.SubElement(case, "error", message=message, type="casewatch.no-data")
        error.text = message
        return 0, 1
    return 0, 0


def render_junit(result: RunResult) -> str:
    """The JUnit XML document of `result` (a `testsuites` root with one `testsuite`)."""
    module = result.case.module
    root = ET.Element("testsuites", name=xml_text(f"casewatch {module}"))
    suite = ET.SubElement(
        root,
        "testsuite",
        name=xml_text(module),
        timestamp=xml_text(result.created),
        hostname="casewatch",
    )
    props = ET.SubElement(suite, "properties")
    for key, value in (
        ("verdict", result.verdict),
        ("root", result.case.root_id),
        ("case", result.case.path),
        ("case_digest", result.case.digest),
        ("stream", result.stream.path),
        ("stream_digest", result.stream.digest or "not hashed"),
        ("frames", result.stream.frames_read),
        ("complete", str(result.complete).lower()),
        ("fail_on", result.fail_on),
    ):
        ET.SubElement(props, "property", name=key, value=xml_text(value))
    by_formula: dict[str, list[Episode]] = {}
    for episode in result.episodes:
        by_formula.setdefault(episode.formula_id, []).append(episode)
    tests = failures = errors = 0
    slug = re.sub(r"[^A-Za-z0-9_.-]+", "_", module).strip("_") or "case"
    for kind in ("spi", "hazard"):
        for formula in (f for f in result.formulas if f.kind == kind):
            f_count, e_count = _case(
                suite,
                f"casewatch.{slug}.{kind}",
                formula,
                by_formula.get(formula.id, []),
                result.case.period,
                result.fail_on,
            )
            tests, failures, errors = tests + 1, failures + f_count, errors + e_count
    if damaged(result.stream.defect_count):  # a finding under every --fail-on policy
        stream_case = ET.SubElement(
            suite,
            "testcase",
            classname=f"casewatch.{slug}.stream",
            name="stream read without damage",
        )
        message = (
            f"the log is damaged: {result.stream.defect_count} stream defect(s); the "
            "frames they lost were not judged"
        )
        failure = ET.SubElement(
            stream_case, "failure", message=xml_text(message), type="casewatch.damage"
        )
        failure.text = xml_text(
            "\n".join(
                [
                    message,
                    *(
                        f"  line {d.line}: {d.kind}: {d.message}"
                        for d in result.stream.defects[:JUNIT_EPISODE_CAP]
                    ),
                ]
            )
        )
        tests, failures = tests + 1, failures + 1
    if not result.complete:
        case = ET.SubElement(
            suite, "testcase", classname=f"casewatch.{slug}.run", name="run completed"
        )
        ET.SubElement(
            case,
            "error",
            message="the run stopped before the end of the stream",
            type="casewatch.incomplete",
        )
        tests, errors = tests + 1, errors + 1
    for element in (suite, root):
        element.set("tests", str(tests))
        element.set("failures", str(failures))
        element.set("errors", str(errors))
        element.set("skipped", "0")
        element.set("time", f"{result.stream.duration:.3f}")
    ET.indent(root)
    declaration = '<?xml version="1.0" encoding="UTF-8"?>\n'
    return declaration + ET.tostring(root, encoding="unicode") + "\n"
