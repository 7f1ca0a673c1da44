"""`python -m bench.tuning`: how long `casewatch tune` takes on 1 hour of saved
signals (every formula of the reference case, 50 threshold candidates each, plus durations).

The bundled drives are judged once with `--save-signals`; their saved signals and labels are
tiled, with shifted times, into six 10-minute logs (1 hour). Tuning then sweeps the 17 formulas
(3 hazard rules scored against the labels, 14 SPIs, whose episodes are formed and counted all
the same) with leave-one-log-out cross-validation. Target (issue "Thresholds from data"):
<= 60 s on 2 cores. `make bench` runs it; prints the figures and the fitted vs held-out scores.
"""

from __future__ import annotations

import argparse
import dataclasses
import tempfile
import time
from pathlib import Path

import numpy as np

from casewatch import api, batch
from casewatch.evaluator.ground_truth import Label, read_labels
from casewatch.evaluator.options import RunOptions
from casewatch.evaluator.score_text import pr_text
from casewatch.evaluator.signal_store import SavedSignals, load_signals
from casewatch.evaluator.tuning import knobs, sweep, tune

REPO = Path(__file__).resolve().parent.parent
CASE = REPO / "examples" / "reference-case.yaml"
DATA = REPO / "examples" / "data"


def tiled_logs(runs: list[tuple[SavedSignals, list[Label]]], minutes: float, count: int):
    """`count` logs of `minutes` each, made of the runs one after the other (times shifted;
    one second of no frames between two runs)."""
    out = []
    k = 0
    for n in range(count):
        parts_t, parts_v, labels = [], [], []
        offset = 0.0
        while offset < minutes * 60:
            log, labs = runs[k % len(runs)]
            k += 1
            shift = offset - log.t[0]
            parts_t.append(log.t + shift)
            parts_v.append(log.values)
            labels += [
                Label(lab.hazard, lab.start + shift, lab.end + shift, lab.line) for lab in labs
            ]
            offset = parts_t[-1][-1] + 1.0
        base = runs[0][0]
        out.append(
            (
                dataclasses.replace(
                    base,
                    path=f"tiled-{n}",
                    t=np.concatenate(parts_t),
                    values=np.concatenate(parts_v),
                ),
                labels,
            )
        )
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.tuning", description=__doc__)
    ap.add_argument("--minutes", type=float, default=10.0, help="per tiled log")
    ap.add_argument("--logs", type=int, default=6)
    ap.add_argument("--candidates", type=int, default=50)
    args = ap.parse_args(argv)
    case, spec = api.prepare(CASE)
    with tempfile.TemporaryDirectory() as tmp:
        streams = sorted(batch.find_streams(str(DATA)))
        summary = batch.run_many(
            str(CASE),
            case.digest,
            streams,
            Path(tmp),
            RunOptions(labels="auto"),
            batch.Outputs(save_signals=True),
            batch.local_runner(2),
        )
        runs = []
        for log in summary["per_log"]:  # type: ignore[union-attr]
            folder = Path(log["out_dir"])
            labels_path = batch.sibling_labels(Path(log["stream"]))
            runs.append((load_signals(folder), read_labels(labels_path)[0] if labels_path else []))
    logs = tiled_logs(runs, args.minutes, args.logs)
    hours = sum(len(log.t) for log, _ in logs) * case.monitor.period / 3600
    found, _ = knobs(case, spec)
    started = time.perf_counter()
    results = []
    candidates = 0
    for knob in found:
        sw = sweep(knob, [log for log, _ in logs], [labs for _, labs in logs], args.candidates)
        candidates += len(sw.candidates())
        results.append(tune(sw))
    seconds = time.perf_counter() - started
    print(
        f"tuning {hours:.2f} h of saved signals ({len(logs)} logs), {len(found)} formulas, "
        f"{candidates} candidates (<= {args.candidates} thresholds x durations): "
        f"{seconds:.1f} s (target <= 60 s: {'met' if seconds <= 60 else 'MISSED'})"
    )
    for r in results:
        if r["labels"]:
            o, t = r["original"], r["tuned"]
            print(
                f"  {r['formula']:<5} {r['parameter']:<13} {o['threshold']:g} -> "
                f"{t['threshold']:g}: fitted {pr_text(t)}, held-out {pr_text(r['heldout'])}"
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
