"""`casewatch calibrate CASE NOMINAL_LOGS... --false-alarms-per-hour X -o OUT`: each SPI's
threshold and persistence (`for:`) from nominal driving.

For every SPI bound by `signal` + `threshold`, sweeps the threshold over the observed values
and `for:` over 0, 0.5, 1, 1.5, 2 and 3 s, and counts each candidate's episodes on nominal
driving. An SPI whose original threshold raises more than X episodes an hour is loosened: the
shortest `for:` (no shorter than its own) at which a threshold that can still fire keeps the
budget, and at it the strictest such threshold (never stricter than the original; `--tighten`
lets it move both ways). An SPI is left as it is, with the reason printed and written as a
comment beside its threshold, when it has fewer than `--min-hours` of nominal driving with a
value, or when no threshold that can fire on these logs keeps the budget (a threshold beyond
every observed value would switch it off). Rates are printed with their exact 95 % Poisson
upper bound. With fault labels (`NAME.fault-labels.jsonl` beside a log's labels or stream,
found with `--labels auto`), each SPI's detection rate of the faults of its families is
printed too.

Writes OUT/calibrated-case.yaml (comments and layout kept), OUT/calibrated-case.diff,
OUT/calibration.json and OUT/calibration.html (alarms an hour against detection over the
sweep). Exit 0; 1 when an original threshold exceeds the budget on these logs; 2 for input that
cannot be used. With `--labels auto` a labelled log counts only its stretches farther than
`--margin` seconds from every label and injected fault (as `python -m casewatch.nominal` counts
them); without it, every tick must be nominal. docs/tuning.md has a worked example.
"""

from __future__ import annotations

import argparse
import difflib
import json
import math
import sys
import textwrap
from pathlib import Path

from casewatch.commands.common import prepare_case, sweep_options_ok
from casewatch.evaluator.calibration import (
    CONFIDENCE,
    DEFAULT_MIN_HOURS,
    CalibrationLog,
    calibration_sweep,
    choose,
)
from casewatch.evaluator.nominal import DEFAULT_MARGIN
from casewatch.evaluator.signal_store import SignalsError, nominal_only
from casewatch.evaluator.tuning import TuningError, knobs
from casewatch.reports.calibration import render_calibration
from casewatch.safety_case.rewrite import Change, RewriteError, rewrite
from casewatch.tuning_logs import LogsError, TuningLog, load_logs


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "calibrate",
        help="SPI thresholds and for: from nominal logs (false alarms per hour)",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("case", help="the safety case (YAML)")
    p.add_argument(
        "logs",
        nargs="+",
        metavar="NOMINAL_LOG",
        help="run folders of `casewatch run --save-signals`, fleet folders, or "
        "streams of nominal driving (judged once, into OUT/runs)",
    )
    p.add_argument(
        "--false-alarms-per-hour",
        type=float,
        required=True,
        metavar="X",
        help="episodes an hour each SPI may raise on nominal driving",
    )
    p.add_argument("-o", "--out", required=True, type=Path, help="output folder")
    p.add_argument(
        "--labels",
        default=None,
        help="'auto': logs with labels count only their nominal stretches (farther "
        "than --margin from every label and injected fault), and fault labels "
        "beside them give detection rates; a file: for a single log",
    )
    p.add_argument(
        "--margin",
        type=float,
        default=DEFAULT_MARGIN,
        help="seconds around each label and fault that are not nominal (default %(default)s)",
    )
    p.add_argument(
        "--min-hours",
        type=float,
        default=DEFAULT_MIN_HOURS,
        metavar="H",
        help="nominal hours with a value an SPI needs to be calibrated (default %(default)s)",
    )
    p.add_argument(
        "--tighten",
        action="store_true",
        help="also tighten SPIs whose original keeps the budget (spend it all); "
        "by default calibrate only loosens",
    )
    p.add_argument(
        "--candidates",
        type=int,
        default=200,
        help="threshold candidates per SPI (quantiles of the observed values)",
    )
    p.add_argument("--jobs", type=int, default=1, help="processes for judging streams")


def _fail(message: str) -> int:
    print(f"casewatch calibrate: {message}", file=sys.stderr)
    return 2


def _calibration_log(log: TuningLog, margin: float) -> CalibrationLog:
    """The log's nominal ticks (away from its labels and faults), the whole log, its faults."""
    faults = log.faults or []
    nominal = nominal_only(log.signals, [*(log.labels or []), *faults], margin)
    return CalibrationLog(nominal, log.signals, list(faults), log.name)


def main(args: argparse.Namespace) -> int:
    budget = args.false_alarms_per_hour
    if not (math.isfinite(budget) and budget >= 0):
        return _fail(f"--false-alarms-per-hour must be a number >= 0, got {budget:g}")
    if not (math.isfinite(args.min_hours) and args.min_hours >= 0):
        return _fail(f"--min-hours must be a number of hours >= 0, got {args.min_hours:g}")
    if not sweep_options_ok("calibrate", args.candidates, args.jobs):
        return 2
    if not (math.isfinite(args.margin) and args.margin >= 0):
        return _fail(f"--margin must be a number of seconds >= 0, got {args.margin:g}")
    prepared = prepare_case("calibrate", args.case)
    if prepared is None:
        return 2
    case, spec = prepared
    try:
        logs = load_logs(args.logs, args.case, args.out, args.jobs, args.labels)
    except LogsError as exc:
        return _fail(str(exc))
    cal_logs = [_calibration_log(log, args.margin) for log in logs]
    if sum(len(c.nominal.t) for c in cal_logs) == 0:
        return _fail("the logs hold no ticks")
    all_knobs, skipped = knobs(case, spec)
    spis = [k for k in all_knobs if k.kind == "spi" and not k.raw_stl]
    kinds = {f.id: f.kind for f in spec.formulas}
    skipped = [s for s in skipped if kinds.get(s["formula"]) == "spi"] + [
        {
            "formula": k.formula_id,
            "reason": "a raw stl: formula; calibrate sets signal + threshold SPIs",
        }
        for k in all_knobs
        if k.kind == "spi" and k.raw_stl
    ]
    if not spis:
        return _fail(f"{args.case} has no SPI bound by signal + threshold")
    rows, changes, notes = [], [], {}
    try:
        for knob in spis:
            sw = calibration_sweep(knob, cal_logs, args.candidates)
            row = choose(sw, budget, args.min_hours, args.tighten)
            rows.append(row)
            chosen = row["chosen"]
            if (chosen["threshold"], chosen["for"]) != (knob.value, knob.duration):
                changes.append(
                    Change(
                        knob.node_id,
                        "spi",
                        knob.signal,
                        knob.op,
                        knob.signal_left,
                        knob.value,
                        chosen["threshold"],
                        "for",
                        knob.duration,
                        chosen["for"],
                    )
                )
            notes[knob.node_id] = (
                f"{row['status']} on these logs: {row['reason']}"
                if row["status"].startswith("not")
                else ""
            )
    except (TuningError, SignalsError) as exc:
        return _fail(str(exc))
    args.out.mkdir(parents=True, exist_ok=True)
    original = Path(args.case).read_text(encoding="utf-8")
    try:
        calibrated = rewrite(original, changes, notes)
    except RewriteError as exc:
        return _fail(f"{args.case}: {exc}")
    (args.out / "calibrated-case.yaml").write_text(calibrated, encoding="utf-8")
    diff = "".join(
        difflib.unified_diff(
            original.splitlines(True),
            calibrated.splitlines(True),
            str(args.case),
            "calibrated-case.yaml",
        )
    )
    (args.out / "calibrated-case.diff").write_text(diff, encoding="utf-8")
    hours = sum(c.nominal.hours for c in cal_logs)
    faults = sum(len(c.faults) for c in cal_logs)
    report = {
        "format": "casewatch-calibration",
        "version": 2,
        "case": str(args.case),
        "logs": len(logs),
        "hours": round(hours, 6),
        "per_hour": budget,
        "min_hours": args.min_hours,
        "tighten": args.tighten,
        "margin": args.margin,
        "confidence": CONFIDENCE,
        "faults": faults,
        "fault_files": [log.faults_path for log in logs if log.faults_path],
        "spis": rows,
        "skipped": skipped,
    }
    (args.out / "calibration.json").write_text(json.dumps(report, indent=1), encoding="utf-8")
    (args.out / "calibration.html").write_text(render_calibration(report), encoding="utf-8")
    _print(report, bool(args.labels))
    print(
        f"calibrated case: {args.out / 'calibrated-case.yaml'} "
        f"(diff: {args.out / 'calibrated-case.diff'})"
    )
    print(f"trade-off curves: {args.out / 'calibration.html'}")
    return 1 if any(r["original_over_budget"] for r in rows) else 0


def _setting(point: dict, op: str) -> str:
    """`>= 0.6 1s`: the threshold and its `for:`."""
    return f"{op} {point['threshold']:g} {point['for']:g}s"


def _rate(point: dict) -> str:
    """`6.5 (19.6)`: episodes an hour and its upper bound."""
    if point["per_hour"] is None:
        return "n/a"
    return f"{point['per_hour']:.1f} ({point['per_hour_upper']:.1f})"


def _print(report: dict, labelled: bool) -> None:
    which = f" ({report['margin']:g} s from labels and faults)" if labelled else ""
    print(
        f"{report['logs']} logs, {report['hours']:.3f} h nominal{which}; budget "
        f"{report['per_hour']:g}/h per SPI, at least {report['min_hours']:g} h each"
    )
    faults = report["faults"] > 0
    if faults:
        print(f"{report['faults']} injected faults ({', '.join(report['fault_files'])})")
    bound = f"/h ({report['confidence']:.0%})"
    print(
        f"  {'SPI':<5} {'hours':>5}  {'original':<15} {bound:<13} {'chosen':<15} {bound:<13}"
        + (f" {'detected':<8}" if faults else "")
        + " status"
    )
    for r in report["spis"]:
        o, c = r["original"], r["chosen"]
        same = (o["threshold"], o["for"]) == (c["threshold"], c["for"])
        over = "*" if r["original_over_budget"] else ""
        detected = ""
        if faults:
            text = f"{c['detected']}/{r['faults']}" if r["faults"] else "-"
            detected = f" {text:<8}"
        print(
            f"  {r['formula']:<5} {r['hours']:>5.2f}  {_setting(o, r['op']):<15} "
            f"{_rate(o) + over:<13} {'(same)' if same else _setting(c, r['op']):<15} "
            f"{_rate(c):<13}{detected} {r['status']}"
        )
        if r["status"].startswith("not"):
            print(
                textwrap.fill(
                    r["reason"],
                    100,
                    initial_indent=" " * 8,
                    subsequent_indent=" " * 8,
                    break_long_words=False,
                )
            )
    for s in report["skipped"]:
        print(
            textwrap.fill(
                f"{s['formula']}: not calibrated ({s['reason']})",
                100,
                initial_indent="  ",
                subsequent_indent="    ",
            )
        )
    print("  /h: false alarms (episodes) an hour of nominal driving with the SPI's signal, and")
    print(f"  its {report['confidence']:.0%} upper bound; *: the original is over the budget")
