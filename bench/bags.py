"""How fast bags are read, against how fast the evaluator judges (`make bench`, part 7).

Every bundled drive is written as an MCAP bag, plain and zstd-compressed (as `ros2 bag record
--compression-mode storage` writes), then:

- `read`: frames per second of `read_bag` alone (decoding, aligning, building frames);
- `judge`: frames per second of the evaluator on the same frames from the JSON Lines drive,
  without its reading (metrics, STL, episodes and status): the evaluator's own speed;
- `run`: frames per second of a whole run from the bag.

Target (issue "Real logs"): reading a bag is not the bottleneck, `read` >= `judge`.
Run alone: `python -m bench.bags [--quick]`.
"""

from __future__ import annotations

import argparse
import itertools
import json
import shutil
import time
from pathlib import Path

from casewatch.evaluator.session import RunOptions, evaluate_stream
from casewatch.monitor.bags.mapping import LoadedMapping, TopicMapping
from casewatch.monitor.bags.reader import read_bag
from casewatch.monitor.bags.writer import default_mapping, write_bag
from casewatch.monitor.reader import read_stream

REPO = Path(__file__).resolve().parents[1]
CASE = REPO / "examples" / "reference-case.yaml"
DATA = REPO / "examples" / "data"


def _bag(drive: Path, folder: Path, compress: bool, limit: int | None) -> tuple[Path, Path]:
    reader = read_stream(drive)
    frames = list(itertools.islice(reader, limit))
    signals = sorted({k for f in frames for k in f.signals})
    plain = default_mapping(["lav", "tfuse"], signals, 4.6, 1.9, reader.header.coverage)
    topics = folder / "topics.json"
    bag = folder / ("zstd" if compress else "plain")
    shutil.rmtree(bag, ignore_errors=True)
    folder.mkdir(parents=True, exist_ok=True)
    topics.write_text(json.dumps(plain))  # JSON is YAML: the run reads it as --topics
    write_bag(frames, bag, TopicMapping.model_validate(plain), "mcap", compress=compress)
    return bag, topics


def measure(folder: Path, limit: int | None = None) -> list[dict[str, object]]:
    from casewatch import api

    case, spec = api.prepare(CASE)
    rows = []
    for drive in sorted(DATA.glob("*.jsonl.gz")):
        name = drive.name.removesuffix(".jsonl.gz")
        stream_run = evaluate_stream(case, spec, _limited(drive, folder, limit), RunOptions())
        t = stream_run.timings
        judge_fps = stream_run.stream.frames_read / (t.total_s - t.read_s)
        for compress in (False, True):
            bag, topics = _bag(drive, folder / name, compress, limit)
            mapping = LoadedMapping(TopicMapping.model_validate_json(topics.read_text()), "b")
            started = time.perf_counter()
            reader = read_bag(bag, mapping, ["lav", "tfuse"], case.monitor.period)
            n = sum(1 for _ in reader)
            read_s = time.perf_counter() - started
            run = evaluate_stream(case, spec, bag, RunOptions(topics=topics))
            rows.append(
                {
                    "drive": name,
                    "mcap": "zstd" if compress else "plain",
                    "frames": n,
                    "mib": round(sum(p.stat().st_size for p in bag.glob("*.mcap")) / 2**20, 1),
                    "read_fps": round(n / read_s, 1),
                    "judge_fps": round(judge_fps, 1),
                    "run_fps": run.timings.frames_per_s,
                    "same_episodes": _same(run.episodes, stream_run.episodes),
                }
            )
    return rows


def _same(ours: list, theirs: list) -> bool:
    """The same episodes: node, span and ticks exactly, robustness to 1e-9 (the bag carries
    velocities in the body frame, so they come back rotated twice, to rounding)."""
    return len(ours) == len(theirs) and all(
        (a.node_id, a.start, a.end, a.ticks) == (b.node_id, b.start, b.end, b.ticks)
        and abs(a.worst_robustness - b.worst_robustness) <= 1e-9
        for a, b in zip(ours, theirs, strict=True)
    )


def _limited(drive: Path, folder: Path, limit: int | None) -> Path:
    """The drive itself, or its first `limit` frames as a stream (for --quick)."""
    if limit is None:
        return drive
    from casewatch.monitor.encode import frame_to_dict, header_to_dict

    out = folder / (drive.name.removesuffix(".jsonl.gz") + ".jsonl")
    out.parent.mkdir(parents=True, exist_ok=True)
    reader = read_stream(drive)
    lines = [json.dumps(frame_to_dict(f)) for f in itertools.islice(reader, limit)]
    out.write_text("\n".join([json.dumps(header_to_dict(reader.header)), *lines]) + "\n")
    return out


def print_rows(rows: list[dict[str, object]]) -> None:
    print(
        f"\n{'ROS 2 bag':<26}{'mcap':>6}{'frames':>8}{'MiB':>7}{'read f/s':>10}"
        f"{'judge f/s':>10}{'run f/s':>9}  same episodes"
    )
    for r in rows:
        print(
            f"{r['drive']:<26}{r['mcap']:>6}{r['frames']:>8}{r['mib']:>7}{r['read_fps']:>10}"
            f"{r['judge_fps']:>10}{r['run_fps']:>9}  {'yes' if r['same_episodes'] else 'NO'}"
        )
    slowest = min(r["read_fps"] / r["judge_fps"] for r in rows)  # type: ignore[operator]
    print(
        f"target: reading a bag >= the evaluator's own speed: slowest read/judge ratio "
        f"{slowest:.2f}: {'met' if slowest >= 1 else 'MISSED'}"
    )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m bench.bags",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ap.add_argument("--quick", action="store_true", help="200 frames per drive")
    ap.add_argument("--out", type=Path, default=Path("bench") / "bags")
    args = ap.parse_args(argv)
    rows = measure(args.out, 200 if args.quick else None)
    print_rows(rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
