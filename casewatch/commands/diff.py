"""`casewatch diff RUN_A RUN_B -o OUT`: what changed between two runs of the same logs.

RUN_A and RUN_B are two output folders of `casewatch run` (each with result.json), or two
fleet folders (each with summary.json; logs are paired by their folder name). Per log and node
it lists new episodes (in B only: regressions), fixed ones (in A only) and changed ones
(paired by overlap, moved or with another worst robustness), episodes per hour and the
verdicts; writes OUT/diff.md, OUT/diff.html and OUT/diff.json. Exit 1 when B has new episodes
that `--fail-on` counts (any, the default; hazard; spi; never), 0 otherwise, 2 for input that
cannot be used.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from casewatch.commands.common import UsageError, run_folders
from evaluator.diff import diff_runs, regressions
from evaluator.policy import FAIL_ON
from reports.diff import render_diff_html, render_diff_md
from reports.render import ResultError, load_result


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "diff", help="compare two runs (or two fleets) of the same logs",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter,
    )  # fmt: skip
    p.add_argument("run_a", metavar="RUN_A", help="the baseline run or fleet folder")
    p.add_argument("run_b", metavar="RUN_B", help="the run or fleet folder to compare")
    p.add_argument("-o", "--out", required=True, type=Path, help="output folder")
    p.add_argument("--fail-on", choices=FAIL_ON, default="any",
                   help="which new episodes are regressions (default any)")


def main(args: argparse.Namespace) -> int:
    a_dir, b_dir = Path(args.run_a), Path(args.run_b)
    try:
        a_runs, b_runs = run_folders(a_dir), run_folders(b_dir)
        if len(a_runs) == 1 and len(b_runs) == 1:  # two single runs: paired whatever the names
            (_, a_one), (b_name, b_one) = next(iter(a_runs.items())), next(iter(b_runs.items()))
            pairs = [(b_name, a_one, b_one)]
        else:
            pairs = [(name, a_runs[name], b_runs[name]) for name in sorted(a_runs)
                     if name in b_runs]  # fmt: skip
        diffs = [diff_runs(load_result(a / "result.json"), load_result(b / "result.json"), name)
                 for name, a, b in pairs]  # fmt: skip
    except (UsageError, ResultError) as exc:
        print(f"casewatch diff: {exc}", file=sys.stderr)
        return 2
    if not pairs:
        print(f"casewatch diff: {a_dir} and {b_dir} share no log", file=sys.stderr)
        return 2
    paired = {name for name, _, _ in pairs}
    report = {
        "format": "casewatch-diff", "version": 1, "a": str(a_dir), "b": str(b_dir),
        "fail_on": args.fail_on, "regressions": regressions(diffs, args.fail_on),
        "only_a": sorted(set(a_runs) - paired) if len(pairs) > 1 or len(a_runs) > 1 else [],
        "only_b": sorted(set(b_runs) - paired) if len(pairs) > 1 or len(b_runs) > 1 else [],
        "logs": diffs,
    }  # fmt: skip
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "diff.json").write_text(json.dumps(report, indent=1), encoding="utf-8")
    (args.out / "diff.md").write_text(render_diff_md(report), encoding="utf-8")
    (args.out / "diff.html").write_text(render_diff_html(report), encoding="utf-8")
    for d in diffs:
        counts = [(len(r["new"]), len(r["fixed"]), len(r["changed"])) for r in d["nodes"]]
        new, fixed, changed = (sum(c[k] for c in counts) for k in range(3))
        verdict = ("" if d["verdict_a"] == d["verdict_b"]
                   else f"; verdict {d['verdict_a']} -> {d['verdict_b']}")  # fmt: skip
        print(f"{d['log']}: {new} new, {fixed} fixed, {changed} changed{verdict}")
        for r in d["nodes"]:
            if r["new"] or r["fixed"] or r["changed"]:
                print(f"  {r['formula']:<6} {r['a']:>3} -> {r['b']:<3} new {len(r['new'])}, "
                      f"fixed {len(r['fixed'])}, changed {len(r['changed'])}")
    for name in report["only_a"] + report["only_b"]:
        print(f"{name}: in only one of the two")
    print(f"{report['regressions']} regression(s) under --fail-on {args.fail_on}; "
          f"{args.out / 'diff.md'}, {args.out / 'diff.html'}")
    return 1 if report["regressions"] else 0
