"""The STL engines side by side (`make bench`, part 8): rtamt tick by tick against numpy over
the whole log, per formula of the reference case, and the whole pipeline with each engine.

    python -m bench.stl [--hours 1] [--quick]

Signals: the metrics of the six bundled drives, computed once and chained end to end (times
shifted) to `--hours` of driving, data gaps (warm-up, dropouts) included. Per formula: rtamt's
online monitor (the evaluator's, fences included) fed every evaluated tick and reset where the
evaluator resets it, against `vector_eval.robustness` over the whole array; both must give the
same value at every tick (largest difference printed). Then `casewatch run` on the bundled
drives with `--stl-engine rtamt`, `numpy` and `both` (frames per second, in process).

Target (issue "Offline STL engine"): numpy >= 50x faster than rtamt per formula-sample, values
identical.
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import numpy as np

from casewatch.evaluator.core import rtamt_monitor
from casewatch.evaluator.session import RunOptions, evaluate_stream
from casewatch.evaluator.signal_store import Columns
from casewatch.evaluator.stl_engines import input_names
from casewatch.evaluator.vector_eval import Segments, evaluated_ticks, robustness
from casewatch.monitor.engine import MetricEngine
from casewatch.monitor.reader import read_stream
from casewatch.spec.parser import parse_rtamt

REPO = Path(__file__).resolve().parents[1]
CASE = REPO / "examples" / "reference-case.yaml"
DATA = REPO / "examples" / "data"


def bundled_columns(spec, case, hours: float) -> Columns:
    """The bundled drives' formula inputs, chained to `hours` of ticks."""
    names = input_names(spec)
    drives: list[tuple[np.ndarray, np.ndarray]] = []
    for path in sorted(DATA.glob("*.jsonl.gz")):
        engine = MetricEngine(case.monitor.metrics, list(case.monitor.channels))
        part = Columns(names)
        for frame in read_stream(path):
            part.add(frame.t, engine.step(frame))
        drives.append((part.t.copy(), np.stack([part.column(n) for n in names], axis=1)))
    out = Columns(names)
    period = spec.period
    target = round(hours * 3600 / period)
    offset = 0.0
    while out.n < target:
        for t, values in drives:
            for i in range(len(t)):
                if out.n >= target:
                    break
                out.add(round(offset + t[i], 6), dict(zip(names, values[i].tolist(), strict=True)))
            offset += float(t[-1]) + 10.0  # a 10 s pause between drives: a gap, as in a fleet
    return out


def per_formula(spec, columns: Columns, max_gap: float) -> list[dict[str, object]]:
    rows = []
    t = columns.t
    for f in spec.formulas:
        ast = parse_rtamt(f.rtamt, spec.period)
        cols = {n: np.ascontiguousarray(columns.column(n)) for n in f.signals}
        robustness(
            ast, {n: c[:50] for n, c in cols.items()}, t[:50], spec.period, max_gap
        )  # compiled kernels loaded before timing
        started = time.perf_counter()
        ours = robustness(ast, cols, t, spec.period, max_gap)
        numpy_s = time.perf_counter() - started
        segments = Segments(t, evaluated_ticks(ast, cols), max_gap)
        index = segments.index
        restart = np.zeros(len(index), dtype=bool)
        restart[segments.starts] = True
        monitor = rtamt_monitor(f, spec.period)
        inputs = [[(n, float(cols[n][i])) for n in f.signals] for i in index.tolist()]
        theirs = np.empty(len(index))
        k = 0
        started = time.perf_counter()
        for j in range(len(index)):
            if restart[j]:
                monitor.reset()
                k = 0
            theirs[j] = monitor.update(k, inputs[j])
            k += 1
        rtamt_s = time.perf_counter() - started
        mine = ours[index]
        finite = np.isfinite(theirs) & np.isfinite(mine)
        same_inf = bool(
            np.array_equal(np.isinf(theirs), np.isinf(mine))
            and np.array_equal(theirs[~finite], mine[~finite])
        )
        diff = float(np.max(np.abs(theirs[finite] - mine[finite]), initial=0.0))
        n = max(len(index), 1)
        rows.append(
            {
                "formula": f.id,
                "rtamt": f.rtamt,
                "samples": len(index),
                "rtamt_us": round(rtamt_s / n * 1e6, 3),
                "numpy_us": round(numpy_s / n * 1e6, 4),
                "speedup": round(rtamt_s / numpy_s, 1) if numpy_s > 0 else math.inf,
                "max_diff": diff,
                "same_infinities": same_inf,
            }
        )
    return rows


def pipeline(case_path: Path) -> list[dict[str, object]]:
    from casewatch import api

    case, spec = api.prepare(case_path)
    rows = []
    drives = sorted(DATA.glob("*.jsonl.gz"))
    for engine in ("rtamt", "numpy", "both"):
        frames = 0
        total = stl = 0.0
        for path in drives:
            r = evaluate_stream(case, spec, path, RunOptions(stl_engine=engine))
            frames += r.stream.frames_read
            total += r.timings.total_s
            stl += r.timings.stl_s
        rows.append(
            {
                "engine": engine,
                "frames": frames,
                "total_s": round(total, 2),
                "stl_s": round(stl, 3),
                "frames_per_s": round(frames / total, 1),
            }
        )
    return rows


def measure(hours: float = 1.0) -> dict[str, object]:
    from casewatch import api

    case, spec = api.prepare(CASE)
    columns = bundled_columns(spec, case, hours)
    return {
        "hours": hours,
        "ticks": columns.n,
        "per_formula": per_formula(spec, columns, case.monitor.metrics.max_gap),
        "pipeline": pipeline(CASE),
    }


def print_results(r: dict) -> None:
    rows = r["per_formula"]
    print(f"\nSTL engines on {r['hours']:g} h of the bundled drives' signals ({r['ticks']} ticks)")
    print(
        f"{'formula':<8}{'samples':>9}{'rtamt us':>10}{'numpy us':>10}{'speed-up':>10}"
        f"{'max diff':>10}  formula"
    )
    for row in rows:
        print(
            f"{row['formula']:<8}{row['samples']:>9}{row['rtamt_us']:>10.3f}"
            f"{row['numpy_us']:>10.4f}{row['speedup']:>9.0f}x{row['max_diff']:>10.1e}  "
            f"{row['rtamt'][:50]}"
        )
    worst = min(row["speedup"] for row in rows)
    identical = all(row["max_diff"] <= 1e-9 and row["same_infinities"] for row in rows)
    print(
        f"target: numpy >= 50x rtamt per formula-sample: slowest {worst:.0f}x: "
        f"{'met' if worst >= 50 else 'MISSED'}; values identical (<= 1e-9): "
        f"{'yes' if identical else 'NO'}"
    )
    print(
        f"\n{'engine':<8}{'frames':>8}{'total s':>9}{'STL s':>8}{'frames/s':>10}  "
        "(casewatch run on the bundled drives)"
    )
    for row in r["pipeline"]:
        print(
            f"{row['engine']:<8}{row['frames']:>8}{row['total_s']:>9}{row['stl_s']:>8}"
            f"{row['frames_per_s']:>10}"
        )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m bench.stl",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ap.add_argument("--hours", type=float, default=1.0)
    ap.add_argument("--quick", action="store_true", help="0.05 h of signals")
    args = ap.parse_args(argv)
    print_results(measure(0.05 if args.quick else args.hours))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
