"""Write a simulated scenario as casewatch frames (JSON Lines, gzipped) plus its label files.

Frame format: the casewatch frames that `monitor.reader` reads (header line, then one frame per
0.1 s tick with the two channels). Besides the channels, each frame carries ground-truth scalar
`signals` so a case or an analyst can use them directly: `speed_limit`, `ego_speed`, and the
true same-lane gaps `gt_lead_gap`, `gt_lead_time_gap`, `gt_follower_gap`,
`gt_follower_time_gap` (null when there is no such vehicle). They are truth, not what a
channel sees.
"""

from __future__ import annotations

import gzip
import json
import math
import sys
from collections.abc import Iterable, Iterator
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from examples.sim import labels as lab
from examples.sim.channels import EGO_SMOOTHING, ChannelModel
from examples.sim.scenarios import Scenario
from examples.sim.simulate import LANE_CHANGE_DURATION, STEP, GroundTruth, run

FORMAT = "casewatch-frames"
VERSION = 1


def _num(v: float) -> float | None:
    v = float(v)
    return round(v, 3) if math.isfinite(v) else None


def header(sc: Scenario) -> dict[str, Any]:
    """The stream's header line: format, channels, period, the channels' sensing `coverage`
    (per channel: field of view centred on the ego heading and range, from its profile) and the
    generator parameters."""
    head: dict[str, Any] = {
        "format": FORMAT,
        "version": VERSION,
        "channels": [c.name for c in sc.channels],
        "period": STEP,
        "coverage": {c.name: c.coverage() for c in sc.channels},
    }
    head["meta"] = {
        "scenario": sc.name,
        "seed": sc.seed,
        "description": sc.description,
        "generator": "examples.sim (Eclipse SUMO via libsumo)",
        "network": sc.network,
        "duration": sc.duration,
        "channel_params": {c.name: c.meta() for c in sc.channels},
        "faults": [asdict(f) for f in sc.faults],
        # the channels see SUMO's ego path through this Gaussian low-pass (s); SUMO's lane
        # changes take this long (s)
        "ego_smoothing": EGO_SMOOTHING,
        "lane_change_duration": LANE_CHANGE_DURATION,
        "labels": {
            "time_gap_threshold": lab.TIME_GAP_THRESHOLD,
            "min_speed": lab.MIN_SPEED,
            "min_duration": lab.MIN_DURATION,
            "merge_gap": lab.MERGE_GAP,
        },
    }
    return {"header": head}


def frame_count(sc: Scenario, gt: GroundTruth) -> int:
    """The ticks a stream of `sc` holds: t = 0 to the scenario's duration."""
    return int(np.searchsorted(gt.times, sc.duration + 1e-9, side="right"))


def truth_signals(gt: GroundTruth, fol: lab.Following, k: int) -> dict[str, float | None]:
    """The ground-truth scalar `signals` of tick `k` (see the module docstring)."""
    e = gt.ego_index
    return {
        "speed_limit": _num(gt.speed_limit[k]),
        "ego_speed": _num(gt.speed[k, e]),
        "gt_lead_gap": _num(fol.lead_gap[k]),
        "gt_lead_time_gap": _num(fol.lead_time_gap[k]),
        "gt_follower_gap": _num(fol.follower_gap[k]),
        "gt_follower_time_gap": _num(fol.follower_time_gap[k]),
    }


def drive_labels(
    sc: Scenario,
    gt: GroundTruth,
) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """The hazard labels (geometry and injected localisation faults, by start) and the SSM
    conflict labels of a simulated drive."""
    keep = gt.times[gt.times <= sc.duration + 1e-9]
    labels = lab.geometry_labels(gt, sc.duration) + lab.fault_labels(sc, keep)
    labels.sort(key=lambda d: (d["start"], d["hazard"]))
    return labels, lab.ssm_labels(lab.read_ssm(gt.ssm_file), sc.duration)


def frames(sc: Scenario, gt: GroundTruth) -> Iterator[dict[str, Any]]:
    """One frame per tick from t = 0 to the scenario's duration."""
    models = [ChannelModel(gt, params, sc.faults, sc.seed) for params in sc.channels]
    fol = lab.following(gt)
    for k in range(frame_count(sc, gt)):
        yield {
            "t": round(float(gt.times[k]), 3),
            "channels": {m.p.name: m.frame(k) for m in models},
            "signals": truth_signals(gt, fol, k),
        }


def _dump(obj: dict[str, Any]) -> str:
    return json.dumps(obj, separators=(",", ":"), allow_nan=False)


def print_bundle(index: list[dict[str, Any]], seconds: float, out: Path) -> None:
    """The last line of a generator: how many drives, how many bytes, how long, where."""
    total = sum(e["bytes"] for e in index)
    print(f"{len(index)} drives, {total / 1e6:.1f} MB, {seconds:.0f} s -> {out}", file=sys.stderr)


def write_stream(
    path: Path,
    head: dict[str, Any],
    rows: Iterable[dict[str, Any]],
) -> int:
    """Write a gzipped frame stream: the header line `head`, then one line per frame of `rows`
    (compact JSON, no NaN). Returns the number of frames written."""
    count = 0
    # mtime=0 keeps the gzip bytes reproducible for the same content
    with (
        open(path, "wb") as raw,
        gzip.GzipFile(filename="", mode="wb", fileobj=raw, mtime=0, compresslevel=9) as gz,
    ):
        gz.write((_dump(head) + "\n").encode())
        for frame in rows:
            gz.write((_dump(frame) + "\n").encode())
            count += 1
    return count


def write_jsonl(path: Path, rows: list[dict[str, Any]]) -> None:
    path.write_text("".join(_dump(r) + "\n" for r in rows))


@dataclass
class Generated:
    """Paths and counts of one generated scenario."""

    stream: Path
    labels: Path
    ssm_labels: Path
    frames: int
    label_counts: dict[str, int]
    ssm_label_counts: dict[str, int]
    ground_truth: GroundTruth


def _counts(rows: list[dict[str, Any]]) -> dict[str, int]:
    out: dict[str, int] = {}
    for r in rows:
        out[r["hazard"]] = out.get(r["hazard"], 0) + 1
    return dict(sorted(out.items()))


def generate(sc: Scenario, out_dir: Path, work_dir: Path | None = None) -> Generated:
    """Simulate `sc`; write `<name>.jsonl.gz`, `<name>.labels.jsonl`, `<name>.ssm-labels.jsonl`."""
    out_dir.mkdir(parents=True, exist_ok=True)
    gt = run(sc, work_dir)
    stream = out_dir / f"{sc.name}.jsonl.gz"
    count = write_stream(stream, header(sc), frames(sc, gt))
    labels, ssm = drive_labels(sc, gt)
    labels_path = out_dir / f"{sc.name}.labels.jsonl"
    ssm_path = out_dir / f"{sc.name}.ssm-labels.jsonl"
    write_jsonl(labels_path, labels)
    write_jsonl(ssm_path, ssm)
    return Generated(stream, labels_path, ssm_path, count, _counts(labels), _counts(ssm), gt)
