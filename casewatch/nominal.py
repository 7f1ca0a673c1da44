"""`python -m casewatch.nominal OUT_DIR`: each SPI's violated share of nominal ticks, per drive.

OUT_DIR is the output folder of `casewatch run ... --labels auto` (one run or a fleet folder
with `summary.json`). Every run must have been judged with labels: a tick counts as nominal
when it lies farther than `--margin` seconds from every label (`evaluator.nominal`). `make demo`
prints this table for the bundled drives; run it on freshly generated drives to check that a
change holds on data it was not tuned on:

    python -m examples.sim.build_data --only highway-realstack --seed 7 --out /tmp/heldout
    casewatch run examples/reference-case.yaml /tmp/heldout --labels auto -o /tmp/heldout-run
    python -m casewatch.nominal /tmp/heldout-run

Ticks near a conflict that the simulator's own SSM device measured (the labels file's
sibling `NAME.ssm-labels.jsonl`, when there is one) are not nominal either: there the
simulator itself measured a short TTC or PET (a lead braking hard, a car crossing close), and an
SPI that turns red there is doing its job. `--no-ssm` counts them as nominal.

Exit 0 when every SPI is within `--limit` (default 1 %) on every run, 1 otherwise, 2 for a
folder that holds no usable run.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from casewatch.evaluator.ground_truth import Label, LabelsError, read_labels
from casewatch.evaluator.nominal import DEFAULT_MARGIN, NominalShare, nominal_shares
from casewatch.reports.render import ResultError, load_result


def run_folders(out_dir: Path) -> list[Path]:
    """The run folders under `out_dir`: the fleet's `per_log` entries, or `out_dir` itself."""
    summary = out_dir / "summary.json"
    if summary.is_file():
        logs = json.loads(summary.read_text(encoding="utf-8")).get("per_log", [])
        return [Path(log["out_dir"]) for log in logs if log.get("ok", True)]
    return [out_dir]


def ssm_labels_path(labels: Path) -> Path | None:
    """`NAME.ssm-labels.jsonl` beside `NAME.labels.jsonl`, when it exists."""
    if not labels.name.endswith(".labels.jsonl"):
        return None
    ssm = labels.with_name(labels.name[: -len(".labels.jsonl")] + ".ssm-labels.jsonl")
    return ssm if ssm.is_file() else None


def nominal_labels(labels_path: Path, ssm: bool = True) -> list[Label]:
    """Every interval that is not nominal for a run judged with `labels_path`: its labels and,
    with `ssm`, the simulator's SSM conflicts beside them (raises `LabelsError`)."""
    labels, _ = read_labels(labels_path)
    conflicts = ssm_labels_path(labels_path) if ssm else None
    if conflicts is not None:
        labels += read_labels(conflicts)[0]
    return labels


def table(rows: dict[str, list[NominalShare]], limit: float) -> tuple[str, bool]:
    """The per-SPI x per-drive table as text, and whether every share is within `limit`."""
    drives = list(rows)
    spis = [(s.node_id, s.signal) for s in next(iter(rows.values()))]
    width = max(8, *(len(d) for d in drives))
    lines = [f"{'SPI':<14}" + "".join(f"{d:>{width + 2}}" for d in drives)]
    ok = True
    for k, (node, signal) in enumerate(spis):
        cells = []
        for d in drives:
            share = rows[d][k].share
            if share is None:
                cells.append("n/a")
            else:
                ok &= share <= limit
                flag = "" if share <= limit else " !"
                cells.append(f"{share:.2%}{flag}")
        lines.append(f"{node + ' ' + signal:<14}" + "".join(f"{c:>{width + 2}}" for c in cells))
    evaluated = "".join(f"{sum(r.evaluated for r in rows[d]):>{width + 2}}" for d in drives)
    lines.append(f"{'(ticks)':<14}" + evaluated)
    return "\n".join(lines), ok


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m casewatch.nominal",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ap.add_argument("out_dir", type=Path, help="output folder of `casewatch run --labels ...`")
    ap.add_argument(
        "--margin",
        type=float,
        default=DEFAULT_MARGIN,
        help="seconds around each label that are not nominal (default %(default)s)",
    )
    ap.add_argument(
        "--limit",
        type=float,
        default=0.01,
        help="largest acceptable violated share (default %(default)s)",
    )
    ap.add_argument(
        "--no-ssm",
        dest="ssm",
        action="store_false",
        help="count ticks near the simulator's SSM conflicts as nominal",
    )
    args = ap.parse_args(argv)
    rows: dict[str, list[NominalShare]] = {}
    for folder in run_folders(args.out_dir):
        try:
            result = load_result(folder / "result.json")
        except ResultError as exc:
            print(f"casewatch.nominal: {exc}", file=sys.stderr)
            return 2
        if result.ground_truth is None:
            print(
                f"casewatch.nominal: {folder}: the run was judged without labels; run it "
                "with --labels FILE (or --labels auto)",
                file=sys.stderr,
            )
            return 2
        try:
            labels = nominal_labels(Path(result.ground_truth.labels_path), args.ssm)
        except LabelsError as exc:
            print(f"casewatch.nominal: {exc}", file=sys.stderr)
            return 2
        rows[folder.name] = nominal_shares(result, labels, args.margin)
    if not rows:
        print(f"casewatch.nominal: {args.out_dir}: no run folders found", file=sys.stderr)
        return 2
    text, ok = table(rows, args.limit)
    which = "label and SSM conflict" if args.ssm else "label"
    print(
        f"SPI violated share of nominal ticks (farther than {args.margin:g} s from every "
        f"{which}); limit {args.limit:.0%}"
    )
    print(text)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
