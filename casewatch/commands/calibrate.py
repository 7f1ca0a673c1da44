"""`casewatch calibrate CASE NOMINAL_LOGS... --false-alarms-per-hour X -o OUT`: each SPI's
threshold from nominal driving.

For every SPI bound by `signal` + `threshold`, sweeps the threshold over the observed range (at
its own `for:`) and takes the strictest one whose episodes on these nominal logs stay within X
an hour. Prints per SPI the original threshold and its rate, the calibrated one and its rate,
and the margin: how far the calibrated threshold lies beyond the original, towards stricter
(negative: on these logs the original raises more alarms than the budget allows). Writes
OUT/calibrated-case.yaml (comments and layout kept), OUT/calibrated-case.diff and
OUT/calibration.json. Exit 0; 1 when an original threshold exceeds the budget; 2 for input
that cannot be used. The logs must be nominal; with `--labels auto` a labelled log counts only
its stretches farther than `--margin` seconds from every label (as `python -m casewatch.nominal`
counts them).
"""

from __future__ import annotations

import argparse
import difflib
import json
import math
import sys
from pathlib import Path

from casewatch.commands.common import prepare_case, sweep_options_ok
from casewatch.tuning_logs import LogsError, load_logs
from evaluator.nominal import DEFAULT_MARGIN
from evaluator.signal_store import SignalsError, nominal_only
from evaluator.tuning import TuningError, calibrate, knobs, sweep
from safety_case.rewrite import Change, RewriteError, rewrite


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "calibrate", help="SPI thresholds from nominal logs (false alarms per hour)",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter,
    )  # fmt: skip
    p.add_argument("case", help="the safety case (YAML)")
    p.add_argument("logs", nargs="+", metavar="NOMINAL_LOG",
                   help="run folders of `casewatch run --save-signals`, fleet folders, or "
                        "streams of nominal driving (judged once, into OUT/runs)")  # fmt: skip
    p.add_argument("--false-alarms-per-hour", type=float, required=True, metavar="X",
                   help="episodes an hour each SPI may raise on nominal driving")
    p.add_argument("-o", "--out", required=True, type=Path, help="output folder")
    p.add_argument("--labels", default=None,
                   help="'auto': logs with labels count only their nominal stretches (farther "
                        "than --margin from every label); a file: for a single log")
    p.add_argument("--margin", type=float, default=DEFAULT_MARGIN,
                   help="seconds around each label that are not nominal (default %(default)s)")
    p.add_argument("--candidates", type=int, default=200,
                   help="threshold candidates per SPI (quantiles of the observed values)")
    p.add_argument("--jobs", type=int, default=1, help="processes for judging streams")


def main(args: argparse.Namespace) -> int:
    budget = args.false_alarms_per_hour
    if not (math.isfinite(budget) and budget >= 0):
        print("casewatch calibrate: --false-alarms-per-hour must be a number >= 0",
              file=sys.stderr)  # fmt: skip
        return 2
    if not sweep_options_ok("calibrate", args.candidates, args.jobs):
        return 2
    prepared = prepare_case("calibrate", args.case)
    if prepared is None:
        return 2
    case, spec = prepared
    if not (math.isfinite(args.margin) and args.margin >= 0):
        print("casewatch calibrate: --margin must be a number of seconds >= 0", file=sys.stderr)
        return 2
    try:
        logs = load_logs(args.logs, args.case, args.out, args.jobs, args.labels)
    except LogsError as exc:
        print(f"casewatch calibrate: {exc}", file=sys.stderr)
        return 2
    signals = [nominal_only(log.signals, log.labels or [], args.margin) for log in logs]
    hours = sum(s.hours for s in signals)
    if hours <= 0:
        print("casewatch calibrate: the logs hold no ticks", file=sys.stderr)
        return 2
    all_knobs, _ = knobs(case, spec)
    spis = [k for k in all_knobs if k.kind == "spi" and not k.raw_stl]
    rows, changes = [], []
    try:
        for knob in spis:
            row = calibrate(sweep(knob, signals, None, args.candidates), budget, hours)
            rows.append(row)
            if row["calibrated"] != knob.value:
                changes.append(Change(knob.node_id, "spi", knob.signal, knob.op,
                                      knob.signal_left, knob.value, row["calibrated"], None,
                                      knob.duration, knob.duration))  # fmt: skip
    except (TuningError, SignalsError) as exc:
        print(f"casewatch calibrate: {exc}", file=sys.stderr)
        return 2
    if not rows:
        print(f"casewatch calibrate: {args.case} has no SPI bound by signal + threshold",
              file=sys.stderr)  # fmt: skip
        return 2
    args.out.mkdir(parents=True, exist_ok=True)
    original = Path(args.case).read_text(encoding="utf-8")
    try:
        calibrated = rewrite(original, changes)
    except RewriteError as exc:
        print(f"casewatch calibrate: {args.case}: {exc}", file=sys.stderr)
        return 2
    (args.out / "calibrated-case.yaml").write_text(calibrated, encoding="utf-8")
    diff = "".join(difflib.unified_diff(original.splitlines(True), calibrated.splitlines(True),
                                        str(args.case), "calibrated-case.yaml"))  # fmt: skip
    (args.out / "calibrated-case.diff").write_text(diff, encoding="utf-8")
    report = {"format": "casewatch-calibration", "version": 1, "case": str(args.case),
              "logs": len(logs), "hours": round(hours, 6), "per_hour": budget, "spis": rows}
    (args.out / "calibration.json").write_text(json.dumps(report, indent=1), encoding="utf-8")
    which = f" (nominal stretches: {args.margin:g} s from every label)" if args.labels else ""
    print(f"{len(logs)} nominal logs, {hours:.3f} h{which}; budget {budget:g} episodes an hour "
          "per SPI")
    print(f"  {'SPI':<6} {'parameter':<14} {'original':>10} {'/h':>7} {'calibrated':>11} "
          f"{'/h':>7} {'margin':>10}")
    over = 0
    for r in rows:
        flag = ""
        if r["original_per_hour"] > budget + 1e-12:
            over += 1
            flag = "  original over budget"
        if r["at_edge"]:
            flag += "  at the edge of the observed values: on these logs it never fires"
        print(f"  {r['formula']:<6} {r['parameter']:<14} {r['original']:>10g} "
              f"{r['original_per_hour']:>7.2f} {r['calibrated']:>11g} "
              f"{r['calibrated_per_hour']:>7.2f} {r['margin']:>+10.4g}{flag}")
    print(f"calibrated case: {args.out / 'calibrated-case.yaml'} "
          f"(diff: {args.out / 'calibrated-case.diff'})")
    return 1 if over else 0
