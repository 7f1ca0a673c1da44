"""`casewatch odd RUNS... -o OUT`: the Operational Design Domain the runs support.

RUNS are output folders of `casewatch run` (result.json) or fleet folders (summary.json). Each
run counts its formulas' ticks per combination of the conditions its stream reported
(`meta.odd`, frame `odd`; docs/odd.md). Grouped by the attributes `--by` names (default: every
attribute that varies over the runs; `--bins` turns a continuous one into bins), each cell
gets every contract's and SPI's violation rate with a 95 % confidence interval (runs as the
units) and its run count; a cell is accepted when every gating formula stays below
`--max-violation-rate` (the study's "less than 5 %"; `--inclusive`: at or below) and every MAE
bound holds (by default the study's MAE < 0.2 m of the lateral error `lane_offset`, where the
runs saved it with --save-signals; `--no-mae` turns it off). Writes OUT/odd.json (the table),
OUT/odd.html (the heatmap) and OUT/accepted-odd.yaml
(the accepted domain, which a case includes with `odd:` on the root goal's context). When the
runs' streams carry `meta.odd_truth.degraded` (generated data), it prints which cells agree.

Exit 0 when the table was written (1 when no cell is accepted), 2 for input it cannot use.
"""

from __future__ import annotations

import argparse
import json
import sys
import textwrap
from pathlib import Path

import numpy as np
import yaml

from casewatch.commands.common import UsageError, run_folders
from casewatch.evaluator.odd_analysis import (
    Bins,
    RunInput,
    accepted_odd,
    analyse,
    binned_domain_problem,
    parse_bins,
    varying_attributes,
)
from casewatch.evaluator.signal_store import SignalsError, load_signals
from casewatch.reports.odd import cell_label, render_odd_html, render_odd_text
from casewatch.reports.render import ResultError, load_result
from casewatch.safety_case.odd import attribute_problem, odd_to_data


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "odd",
        help="the operational design domain judged runs support (heatmap, YAML ODD)",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "runs",
        nargs="+",
        metavar="RUNS",
        type=Path,
        help="run folders (result.json) or fleet folders (summary.json)",
    )
    p.add_argument("-o", "--out", required=True, type=Path, help="output folder")
    p.add_argument(
        "--max-violation-rate",
        type=float,
        default=0.05,
        metavar="RATE",
        help="accepted: violated share of judged ticks below RATE (default 0.05)",
    )
    p.add_argument(
        "--inclusive",
        action="store_true",
        help="accept a rate (an MAE) equal to its bound too (default: strictly "
        "below, the study's rule)",
    )
    p.add_argument(
        "--bins",
        action="append",
        default=[],
        metavar="ATTR=EDGES[:NAMES]",
        help="bin a continuous condition: environment.fog=0,30,70,100 makes "
        "[0, 30], (30, 70], (70, 100]; names after a colon "
        "(:light,medium,heavy); ATTR may be the key alone (fog); repeatable",
    )
    p.add_argument(
        "--criterion",
        choices=("estimate", "upper"),
        default="estimate",
        help="compare the rate's estimate (default) or its upper 95 %% bound",
    )
    p.add_argument(
        "--by",
        default=None,
        metavar="ATTR,...",
        help="condition attributes that make the cells (default: those that vary)",
    )
    p.add_argument(
        "--formulas",
        default=None,
        metavar="ID,...",
        help="the contracts and SPIs that gate acceptance (default: all of them)",
    )
    p.add_argument(
        "--max-mae",
        action="append",
        default=[],
        metavar="SIGNAL[-REF]=BOUND",
        help="also require the mean absolute value of a saved signal (or of the "
        "difference of two, lead_gap__camera-gt_lead_gap) at most BOUND per cell; "
        "needs runs made with --save-signals; repeatable (default: "
        f"{DEFAULT_MAE[0]}={DEFAULT_MAE[1]:g} where the runs saved it)",
    )
    p.add_argument(
        "--no-mae", action="store_true", help="no MAE criterion, not even the default one"
    )
    p.add_argument("--name", default="accepted", help="the written ODD's name")


#: The study's MAE criterion (sec. 3.2.3: "the MAE should be less than 0.2 m"), applied to the
#: lateral error where runs saved it (docs/odd.md says why lateral).
DEFAULT_MAE = ("lane_offset", 0.2)


def _default_mae(runs: list[RunInput]) -> tuple[dict[str, float], str]:
    """The default MAE bound and a note saying whether it applies."""
    name, bound = DEFAULT_MAE
    for run in runs:
        try:
            saved = load_signals(Path(run.folder))
        except SignalsError:
            return {}, (
                f"MAE criterion ({name} < {bound:g} m) not applied: run "
                f"{Path(run.folder).name} saved no signals (--save-signals)"
            )
        if name not in saved.names:
            return {}, (
                f"MAE criterion ({name} < {bound:g} m) not applied: run "
                f"{Path(run.folder).name} has no signal {name} (no lateral error)"
            )
    return {name: bound}, f"MAE criterion (default): {name} < {bound:g} m"


def _bins(items: list[str], runs: list[RunInput], by: list[str]) -> dict[str, Bins]:
    known = sorted({k for run in runs for c in run.result.conditions for k in c.attributes})
    out: dict[str, Bins] = {}
    for item in items:
        try:
            b = parse_bins(item)
        except ValueError as exc:
            raise UsageError(f"--bins {exc}") from None
        name = b.attribute
        if name not in known:
            matches = [k for k in known if k.rsplit(".", 1)[-1] == name]
            if len(matches) != 1:
                why = f"several ({', '.join(matches)})" if matches else "none"
                raise UsageError(
                    f"--bins {item}: no condition {name!r} in the runs, and {why} "
                    f"end in .{name} (their conditions: {', '.join(known)})"
                )
            name = matches[0]
        if name not in by:
            raise UsageError(
                f"--bins {item}: {name} is not one of the cells' attributes (--by {','.join(by)})"
            )
        numbers = [
            v
            for run in runs
            for c in run.result.conditions
            for k, v in c.attributes.items()
            if k == name
        ]
        if not any(isinstance(v, int | float) and not isinstance(v, bool) for v in numbers):
            raise UsageError(
                f"--bins {item}: {name} takes no numbers in these runs (values: "
                f"{', '.join(sorted({str(v) for v in numbers}))})"
            )
        out[name] = Bins(name, b.edges, b.names)
    return out


def _mae_bounds(items: list[str]) -> dict[str, float]:
    out = {}
    for item in items:
        name, sep, bound = item.rpartition("=")
        try:
            value = float(bound)
        except ValueError:
            value = float("nan")
        if not sep or not name or not value >= 0:
            raise UsageError(
                f"--max-mae {item!r}: expected SIGNAL=BOUND or SIGNAL-REF=BOUND "
                "with a bound >= 0, e.g. lead_gap__camera-gt_lead_gap=1.5"
            )
        out[name] = value
    return out


def _signal_loader(names: list[str]):
    """Reads, per run folder, the columns `--max-mae` needs from its signals.npz."""

    def load(folder: str) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        try:
            saved = load_signals(Path(folder))
        except SignalsError as exc:
            raise UsageError(f"--max-mae: {exc}") from None
        index = {n: k for k, n in enumerate(saved.names)}
        columns = {}
        for name in names:
            parts = name.split("-")
            missing = [p for p in parts if p not in index]
            if len(parts) > 2 or missing:
                raise UsageError(
                    f"--max-mae {name}: {folder} saved no signal "
                    f"{', '.join(missing) or name!r} (saved: "
                    f"{', '.join(saved.names[:12])}...)"
                )
            column = saved.values[:, index[parts[0]]]
            if len(parts) == 2:
                column = column - saved.values[:, index[parts[1]]]
            columns[name] = column
        return saved.t, columns

    return load


def _read_runs(folders: list[Path]) -> list[RunInput]:
    runs = []
    for folder in folders:
        for path in run_folders(folder).values():
            try:
                runs.append(RunInput(str(path), load_result(path / "result.json")))
            except ResultError as exc:
                raise UsageError(str(exc)) from None
    return runs


def main(args: argparse.Namespace) -> int:
    try:
        if not 0 <= args.max_violation_rate <= 1:
            raise UsageError(
                f"--max-violation-rate {args.max_violation_rate:g}: a share of "
                "ticks, between 0 and 1 (0.05 for 5 %)"
            )
        if args.max_violation_rate == 0 and not args.inclusive:
            raise UsageError(
                "--max-violation-rate 0: no rate is below 0, so no cell could be "
                "accepted; for 'no violated tick at all' add --inclusive"
            )
        max_mae = _mae_bounds(args.max_mae)
        runs = _read_runs(args.runs)
        if not any(run.result.conditions for run in runs):
            raise UsageError(
                "no run counted its ticks per condition: judge the logs with "
                "this casewatch (result.json `conditions`), and report conditions "
                "in the streams (header meta.odd, docs/odd.md)"
            )
        by = (
            varying_attributes(runs)
            if args.by is None
            else [b.strip() for b in args.by.split(",") if b.strip()]
        )
        if not by:  # every run under the same conditions: one cell, named by all of them
            by = sorted({k for run in runs for c in run.result.conditions for k in c.attributes})
        if not by:
            raise UsageError(
                "the runs report no conditions (every meta.odd is empty): there "
                "is no domain to tell apart; report them in the streams' header "
                "meta.odd (docs/odd.md)"
            )
        for name in by:
            problem = attribute_problem(name, None)
            if problem or "." not in name:
                why = problem or "cells are made of layered conditions (environment.weather)"
                raise UsageError(f"--by {name}: {why}")
        known = {f.id for run in runs for f in run.result.formulas}
        formulas = None
        if args.formulas is not None:
            formulas = [f.strip() for f in args.formulas.split(",") if f.strip()]
            unknown = [f for f in formulas if f not in known]
            if unknown:
                raise UsageError(
                    f"--formulas: no formula {', '.join(unknown)} in these runs "
                    f"(they have {', '.join(sorted(known))})"
                )
        bins = _bins(args.bins, runs, by)
        mae_note = ""
        if not max_mae and not args.no_mae:
            max_mae, mae_note = _default_mae(runs)
        report = analyse(
            runs,
            by,
            formulas,
            args.max_violation_rate,
            args.criterion,
            max_mae,
            _signal_loader(list(max_mae)) if max_mae else None,
            bins,
            strict=not args.inclusive,
        )
        report["mae_note"] = mae_note
    except UsageError as exc:
        print(f"casewatch odd: {exc}", file=sys.stderr)
        return 2
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "odd.json").write_text(json.dumps(report, indent=1), encoding="utf-8")
    (args.out / "odd.html").write_text(render_odd_html(report), encoding="utf-8")
    odd = accepted_odd(report, args.name)
    written = args.out / "accepted-odd.yaml"
    if odd is not None:
        header = (
            f"# written by casewatch odd from {report['runs']} runs: the cells whose "
            f"contracts and SPIs stay {'at or ' if args.inclusive else ''}below "
            f"{args.max_violation_rate:g} violated share of judged ticks\n"
        )
        written.write_text(
            header + yaml.safe_dump(odd_to_data(odd), sort_keys=False), encoding="utf-8"
        )
    elif written.exists():
        written.unlink()  # a stale domain from an earlier analysis must not survive
    for line in render_odd_text(report):
        print(line)
    problem = binned_domain_problem(report)
    if problem:
        print(textwrap.fill(f"No accepted-odd.yaml: {problem}", width=100, subsequent_indent="  "))
    truth = [c for c in report["cells"] if "degraded_truth" in c]
    if truth:
        agree = sum(1 for c in truth if c["degraded_truth"] != c["accepted"])
        print(
            f"Against the streams' known degradation (meta.odd_truth): {agree} of "
            f"{len(truth)} cells agree"
        )
        for c in truth:  # the agreeing ones are in the heatmap's truth column
            if c["degraded_truth"] == c["accepted"]:
                print(
                    textwrap.fill(
                        f"DIFFERS {cell_label(c['conditions'])}: degraded "
                        f"{'yes' if c['degraded_truth'] else 'no'}, "
                        f"{'accepted' if c['accepted'] else 'rejected'}",
                        width=100,
                        initial_indent="  ",
                        subsequent_indent="    ",
                    )
                )
    where = (
        written
        if odd is not None
        else ("no ODD written" if problem else "no cell accepted, no ODD written")
    )
    print(f"{args.out / 'odd.html'}, {args.out / 'odd.json'}; {where}")
    return 0 if odd is not None else 1
