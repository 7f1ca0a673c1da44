"""Where the time goes, both paths (`make bench`, part 11): the six bundled drives judged in
process by the live path (rtamt tick by tick) and by the whole-log path (numpy over the whole
log, the default for a file), after a warm-up pass, `--repeat` times interleaved; per stage
the median milliseconds per frame from `result.json`'s `timings`, and the CPU time per frame
of the whole call.

    python -m bench.stages [--repeat 3]

Stages: read (gzip, JSON decoding, validation, arrays), metrics (`MetricEngine.step`), STL
(rtamt updates, or the numpy engine over the whole log), episodes, gaps and status (and, on
the whole-log path, their replay from the precomputed robustness). The rest of a call
(opening the source, assembling the result) is `other`.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

from casewatch import api
from casewatch.evaluator.options import RunOptions
from casewatch.evaluator.session import evaluate_stream

REPO = Path(__file__).resolve().parents[1]
CASE = REPO / "examples" / "reference-case.yaml"
DATA = REPO / "examples" / "data"

#: The paths judged, by the engine option that picks them.
PATHS = {"live": "rtamt", "whole-log": "numpy"}
STAGES = ("read", "metrics", "stl", "episodes_status", "other", "total", "cpu")


def _judge_all(case, spec, engine: str) -> dict[str, float]:
    """Seconds per stage over every bundled drive, and the frames judged."""
    sums = dict.fromkeys(STAGES, 0.0)
    frames = 0
    for path in sorted(DATA.glob("*.jsonl.gz")):
        cpu = time.process_time()
        result = evaluate_stream(case, spec, path, RunOptions(stl_engine=engine))
        sums["cpu"] += time.process_time() - cpu
        t = result.timings
        frames += result.stream.frames_read
        sums["read"] += t.read_s
        sums["metrics"] += t.metrics_s
        sums["stl"] += t.stl_s
        sums["episodes_status"] += t.episodes_status_s
        sums["total"] += t.total_s
    sums["other"] = sums["total"] - sum(sums[s] for s in STAGES[:4])
    sums["frames"] = frames
    return sums


def measure(repeat: int = 3) -> dict[str, object]:
    """Median ms per frame of each stage of each path (runs interleaved, after a warm-up)."""
    case, spec = api.prepare(CASE)
    for engine in PATHS.values():  # warm-up: kernels compiled or loaded, caches filled
        evaluate_stream(
            case, spec, sorted(DATA.glob("*.jsonl.gz"))[0], RunOptions(stl_engine=engine)
        )
    runs: dict[str, list[dict[str, float]]] = {path: [] for path in PATHS}
    for _ in range(repeat):
        for path, engine in PATHS.items():
            runs[path].append(_judge_all(case, spec, engine))
    frames = int(runs["live"][0]["frames"])
    table = {
        path: {
            stage: round(statistics.median(r[stage] for r in rs) / frames * 1e3, 4)
            for stage in STAGES
        }
        for path, rs in runs.items()
    }
    return {"frames": frames, "repeat": repeat, "ms_per_frame": table}


def print_results(r: dict) -> None:
    table = r["ms_per_frame"]
    print(
        f"\nWhere the time goes: {r['frames']} frames of the bundled drives, in process, "
        f"ms per frame (median of {r['repeat']})"
    )
    print(f"{'stage':<18}" + "".join(f"{path:>12}{'share':>8}" for path in table))
    for stage in STAGES:
        cells = ""
        for path in table:
            v = table[path][stage]
            share = v / table[path]["total"] * 100 if stage not in ("total", "cpu") else None
            cells += f"{v:>12.3f}" + (f"{share:>7.0f}%" if share is not None else f"{'':>8}")
        print(f"{stage:<18}{cells}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeat", type=int, default=3, help="runs of each path (medians)")
    args = ap.parse_args(argv)
    print_results(measure(args.repeat))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
