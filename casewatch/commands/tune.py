"""`casewatch tune CASE LOGS... --labels auto -o OUT`: thresholds from labelled logs.

For every hazard rule and SPI with labels in the logs, sweeps its threshold (and its `for:` or
`min_duration`) over the observed range, scores each candidate's episodes against the labels
with the matcher of `casewatch run --labels`, picks an operating point (`--objective f1`, or
`--min-precision P`: the best recall at that precision; among equal scores the threshold in
the middle of the best-scoring range, and the duration by held-out score), and reports it
fitted on all logs and held out (leave one log out). Writes OUT/tuned-case.yaml (the case
with the tuned numbers, its comments and layout kept), OUT/tuned-case.diff, OUT/tuning.json
and OUT/tuning.html (a PR curve per rule). `docs/tuning.md` has a worked example.
"""

from __future__ import annotations

import argparse
import difflib
import json
import sys
import textwrap
from pathlib import Path

from casewatch.commands.common import prepare_case, sweep_options_ok
from casewatch.evaluator.score_text import pr_text
from casewatch.evaluator.signal_store import SignalsError
from casewatch.evaluator.tuning import TuningError, knobs, labels_of, sweep, tune
from casewatch.reports.tuning import render_tuning
from casewatch.safety_case.rewrite import Change, RewriteError, rewrite
from casewatch.tuning_logs import LogsError, load_logs


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "tune",
        help="thresholds from labelled logs (PR curves, held-out scores)",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("case", help="the safety case (YAML)")
    p.add_argument(
        "logs",
        nargs="+",
        metavar="LOG",
        help="run folders of `casewatch run --save-signals`, fleet folders, or "
        "streams (judged once, into OUT/runs)",
    )
    p.add_argument("-o", "--out", required=True, type=Path, help="output folder")
    p.add_argument(
        "--labels",
        default="auto",
        help="'auto' (default): each log's labels; a file: for a single log",
    )
    p.add_argument("--objective", choices=("f1", "min-precision"), default="f1")
    p.add_argument(
        "--min-precision",
        type=float,
        default=None,
        metavar="P",
        help="with it: the best recall among candidates at least this precise",
    )
    p.add_argument(
        "--candidates",
        type=int,
        default=50,
        help="threshold candidates per rule (quantiles of the observed values)",
    )
    p.add_argument("--jobs", type=int, default=1, help="processes for judging streams")


def main(args: argparse.Namespace) -> int:
    objective = "min-precision" if args.min_precision is not None else args.objective
    if objective == "min-precision" and not (
        args.min_precision is not None and 0.0 < args.min_precision <= 1.0
    ):
        print(
            "casewatch tune: --objective min-precision needs --min-precision P, 0 < P <= 1",
            file=sys.stderr,
        )
        return 2
    if not sweep_options_ok("tune", args.candidates, args.jobs):
        return 2
    prepared = prepare_case("tune", args.case)
    if prepared is None:
        return 2
    case, spec = prepared
    try:
        logs = load_logs(args.logs, args.case, args.out, args.jobs, args.labels, need_labels=True)
    except LogsError as exc:
        print(f"casewatch tune: {exc}", file=sys.stderr)
        return 2
    all_knobs, skipped = knobs(case, spec)
    names = {k.node_id: k.node_text for k in all_knobs}
    every_label = [lab for log in logs for lab in log.labels or []]
    unknown = sorted(
        {lab.hazard for lab in every_label}
        - {lab.hazard for k in all_knobs for lab in every_label if labels_of(k, [lab])}
    )
    if every_label and len(unknown) == len({lab.hazard for lab in every_label}):
        print(
            f"casewatch tune: the labels name no node of {args.case} ({', '.join(unknown)}); "
            f"label hazards by node id ({', '.join(sorted(names))})",
            file=sys.stderr,
        )
        return 2
    rules = []
    try:
        for knob in all_knobs:
            signals = [log.signals for log in logs]
            labels = [log.labels or [] for log in logs]
            if not any(labels_of(knob, lab) for lab in labels):
                skipped.append(
                    {
                        "formula": knob.formula_id,
                        "reason": "no label names it; calibrate SPIs on nominal logs",
                    }
                )
                continue
            result = tune(
                sweep(knob, signals, labels, args.candidates), objective, args.min_precision
            )
            result["node_text"] = knob.node_text
            rules.append((knob, result))
    except (TuningError, SignalsError) as exc:
        print(f"casewatch tune: {exc}", file=sys.stderr)
        return 2
    if not rules:
        print(
            "casewatch tune: no rule has labels in these logs; nothing to tune "
            f"(labels named: {', '.join(sorted({lab.hazard for lab in every_label})) or 'none'})",
            file=sys.stderr,
        )
        return 2
    hours = sum(log.signals.hours for log in logs)
    report = {
        "format": "casewatch-tuning",
        "version": 1,
        "case": str(args.case),
        "logs": len(logs),
        "hours": round(hours, 6),
        "objective": objective,
        "min_precision": args.min_precision,
        "rules": [r for _, r in rules],
        "skipped": skipped,
        "unknown_labels": unknown,
    }
    args.out.mkdir(parents=True, exist_ok=True)
    original = Path(args.case).read_text(encoding="utf-8")
    changes = [_change(k, r) for k, r in rules]
    try:
        tuned = rewrite(original, [c for c in changes if c is not None])
    except RewriteError as exc:
        print(f"casewatch tune: {args.case}: {exc}", file=sys.stderr)
        return 2
    (args.out / "tuned-case.yaml").write_text(tuned, encoding="utf-8")
    diff = "".join(
        difflib.unified_diff(
            original.splitlines(True), tuned.splitlines(True), str(args.case), "tuned-case.yaml"
        )
    )
    (args.out / "tuned-case.diff").write_text(diff, encoding="utf-8")
    (args.out / "tuning.json").write_text(json.dumps(report, indent=1), encoding="utf-8")
    (args.out / "tuning.html").write_text(render_tuning(report), encoding="utf-8")
    _print(report)
    print(f"tuned case: {args.out / 'tuned-case.yaml'} (diff: {args.out / 'tuned-case.diff'})")
    print(f"PR curves: {args.out / 'tuning.html'}")
    return 0


def _change(knob, result: dict) -> Change | None:
    t, o = result["tuned"], result["original"]
    if (t["threshold"], t["duration"]) == (o["threshold"], o["duration"]):
        return None
    return Change(
        knob.node_id,
        knob.kind,
        knob.signal,
        knob.op,
        knob.signal_left,
        o["threshold"],
        t["threshold"],
        knob.duration_kind,
        o["duration"],
        t["duration"],
        knob.raw_stl,
    )


def _print(report: dict) -> None:
    """The table, within 100 columns (a parameter name longer than 14 characters widens it)."""
    print(f"{report['logs']} logs, {report['hours']:.3f} h; objective {report['objective']}")
    print(
        f"  {'rule':<6} {'parameter':<14} {'original':>9} {'tuned':>9}  "
        f"{'fitted (orig.)':<14} {'fitted (tuned)':<14} {'held-out':<13} duration"
    )
    for r in report["rules"]:
        o, t = r["original"], r["tuned"]
        dur = ""
        if r["duration_kind"] is not None:
            dur = f" {o['duration']:g}s->{t['duration']:g}s"
        held = pr_text(r["heldout"])
        print(
            f"  {r['formula']:<6} {r['parameter']:<14} {o['threshold']:>9g} "
            f"{t['threshold']:>9g}  {pr_text(o):<14} {pr_text(t):<14} {held:<13}{dur}"
        )
    reasons: dict[str, list[str]] = {}
    for s in report["skipped"]:
        reasons.setdefault(s["reason"], []).append(s["formula"])
    for reason, formulas in reasons.items():
        print(
            textwrap.fill(
                f"not tuned ({reason}): {', '.join(formulas)}",
                100,
                initial_indent="  ",
                subsequent_indent="    ",
            )
        )
