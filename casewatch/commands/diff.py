"""`casewatch diff RUN_A RUN_B -o OUT`: what changed between two runs of the same logs.

RUN_A and RUN_B are two output folders of `casewatch run` (each with result.json), or two
fleet folders (each with summary.json; logs are paired by their folder name). Per log and node
it lists episodes in B only (new: regressions), in A only (gone) and changed ones (paired by
overlap, moved or with another worst robustness), episodes per hour and the verdicts.

With ground-truth labels (both runs judged with the same labels, or --labels) a hazard's
unpaired events are judged against them: fixed (a false alarm of A gone), lost detection (a
labelled hazard A found and B does not: a regression), new detection (a labelled hazard only
B finds), new (a false alarm only B raises: a regression). Without labels nothing vanished is
called fixed.

Writes OUT/diff.md, OUT/diff.html and OUT/diff.json. Exit 1 when B has regressions that
--fail-on counts (any, the default; hazard; spi; never), 0 otherwise, 2 for input that cannot
be used.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from casewatch.batch import labels_for
from casewatch.commands.common import UsageError, run_folders
from casewatch.evaluator.diff import CHANGE_LABELS, diff_runs, regressions, totals
from casewatch.evaluator.ground_truth import LabelsError, read_labels, resolve_hazard
from casewatch.evaluator.policy import FAIL_ON
from casewatch.evaluator.result import LabelInterval, RunResult
from casewatch.reports.diff import render_diff_html, render_diff_md
from casewatch.reports.render import ResultError, load_result


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "diff",
        help="compare two runs (or two fleets) of the same logs",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("run_a", metavar="RUN_A", help="the baseline run or fleet folder")
    p.add_argument("run_b", metavar="RUN_B", help="the run or fleet folder to compare")
    p.add_argument("-o", "--out", required=True, type=Path, help="output folder")
    p.add_argument(
        "--fail-on",
        choices=FAIL_ON,
        default="any",
        help="which new episodes and lost detections are regressions (default any)",
    )
    p.add_argument(
        "--labels",
        metavar="FILE|auto",
        help="judge the hazards of both runs against these labels (JSON Lines); "
        "'auto': NAME.labels.jsonl beside each log's stream. Default: the "
        "labels both runs were judged with, if they were",
    )


def _labels_from_file(path: str, run: RunResult) -> list[LabelInterval]:
    """The labels of `path` that name a hazard of `run`'s case (by node id or text)."""
    hazards = {f.node_id for f in run.formulas if f.kind == "hazard"}
    texts = {n.id: n.text for n in run.case.nodes if n.id in hazards}
    found, _digest = read_labels(path)
    out = []
    for label in found:
        node_id = resolve_hazard(label.hazard, texts)
        if node_id is not None:
            out.append(LabelInterval(node_id=node_id, start=label.start, end=label.end))
    return out


def labels_of(a: RunResult, b: RunResult, given: str | None) -> tuple[list | None, str]:
    """The ground truth to judge the pair against, and where it comes from (for the page)."""
    if given is not None:
        path = labels_for(b.stream.path, given) or labels_for(a.stream.path, given)
        if path is None:
            return None, f"no labels file beside {b.stream.path}"
        return _labels_from_file(path, b), path
    ga, gb = a.ground_truth, b.ground_truth
    if ga is None or gb is None:
        which = "neither run" if ga is gb else ("only A" if gb is None else "only B")
        return None, f"{which} was judged with labels"
    if ga.labels_digest != gb.labels_digest:
        raise UsageError(
            f"the two runs were judged against different labels ({ga.labels_path} "
            f"and {gb.labels_path}); pass --labels FILE to judge both against one"
        )
    return list(gb.labels), gb.labels_path


def main(args: argparse.Namespace) -> int:
    a_dir, b_dir = Path(args.run_a), Path(args.run_b)
    try:
        a_runs, b_runs = run_folders(a_dir), run_folders(b_dir)
        if len(a_runs) == 1 and len(b_runs) == 1:  # two single runs: paired whatever the names
            (_, a_one), (b_name, b_one) = next(iter(a_runs.items())), next(iter(b_runs.items()))
            pairs = [(b_name, a_one, b_one)]
        else:
            pairs = [
                (name, a_runs[name], b_runs[name]) for name in sorted(a_runs) if name in b_runs
            ]
        if args.labels not in (None, "auto") and len(pairs) > 1:
            raise UsageError(
                "with several logs use --labels auto (each log's labels beside "
                "its stream), not one file"
            )
        diffs = []
        for name, a, b in pairs:
            ra, rb = load_result(a / "result.json"), load_result(b / "result.json")
            labels, source = labels_of(ra, rb, args.labels)
            diffs.append({**diff_runs(ra, rb, name, labels), "labels": source})
    except (UsageError, ResultError, LabelsError) as exc:
        print(f"casewatch diff: {exc}", file=sys.stderr)
        return 2
    if not pairs:
        print(f"casewatch diff: {a_dir} and {b_dir} share no log", file=sys.stderr)
        return 2
    paired = {name for name, _, _ in pairs}
    report = {
        "format": "casewatch-diff",
        "version": 1,
        "a": str(a_dir),
        "b": str(b_dir),
        "fail_on": args.fail_on,
        "regressions": regressions(diffs, args.fail_on),
        "only_a": sorted(set(a_runs) - paired) if len(pairs) > 1 or len(a_runs) > 1 else [],
        "only_b": sorted(set(b_runs) - paired) if len(pairs) > 1 or len(b_runs) > 1 else [],
        "logs": diffs,
    }
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "diff.json").write_text(json.dumps(report, indent=1), encoding="utf-8")
    (args.out / "diff.md").write_text(render_diff_md(report), encoding="utf-8")
    (args.out / "diff.html").write_text(render_diff_html(report), encoding="utf-8")
    for d in diffs:
        verdict = (
            ""
            if d["verdict_a"] == d["verdict_b"]
            else f"; verdict {d['verdict_a']} -> {d['verdict_b']}"
        )
        note = "" if d["labelled"] else " (no labels: vanished episodes are 'gone')"
        print(f"{d['log']}: {_counts(totals(d), always=('new', 'gone', 'changed'))}{verdict}{note}")
        for r in d["nodes"]:
            counts = {kind: len(r[kind]) for kind in CHANGE_LABELS}
            if any(counts.values()):
                print(f"  {r['formula']:<6} {r['a']:>3} -> {r['b']:<3} {_counts(counts)}")
    for name in report["only_a"] + report["only_b"]:
        print(f"{name}: in only one of the two")
    print(
        f"{report['regressions']} regression(s) (new episodes and lost detections) under "
        f"--fail-on {args.fail_on}; "
        f"{args.out / 'diff.md'}, {args.out / 'diff.html'}"
    )
    return 1 if report["regressions"] else 0


def _counts(counts: dict[str, int], always: tuple[str, ...] = ()) -> str:
    """`2 new, 1 lost detection, 3 changed`: the kinds with episodes, and `always`."""

    def name(kind: str) -> str:  # "1 lost detection", "2 lost detections", "2 new"
        plural = counts[kind] != 1 and CHANGE_LABELS[kind].endswith("detection")
        return CHANGE_LABELS[kind] + ("s" if plural else "")

    return ", ".join(f"{counts[k]} {name(k)}" for k in CHANGE_LABELS if counts[k] or k in always)
