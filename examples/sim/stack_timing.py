"""Re-record drives as ROS 2 bags with a real stack's timing, and judge them (docs/bags.md).

    python -m examples.sim.stack_timing examples/data/*.jsonl.gz --out out/stack-timing
    python -m examples.sim.stack_timing out/heldout/s303/*.jsonl.gz --seed 7

`casewatch convert` stamps every message on its frame's tick, which makes a bag that reads
back exactly. Real stacks do not tick with the monitor: their clock has its own phase against
the monitor's grid, each topic is stamped a little apart, stamps jitter, and messages reach
the recorder late (perception latency), so the recording order is not the stamp order. This
writes each drive's frames with, drawn from `--seed`: a phase of 5-95 ms of the stacks' clock
against the grid; per channel an offset of up to +-10 ms and per topic up to +-5 ms (stacks
sample at different instants); a jitter of up to +-3 ms; and a recording delay of 20-250 ms
(objects) or 1-20 ms (odometry, plan). Each message describes its own stamp: the ego and the
objects are moved there with their velocities, plans and predictions are re-timed from it.
It then judges the bag and the stream with the case and prints per drive: frames, dropouts
beyond the stream's own, defects, and how many episodes of the stream the bag reproduced
(same node, spans within a tick of each other, after shifting the bag's times by its first
tick's phase) and the reverse.

What it shows: alignment on header stamps (default `max_age` 1.5 periods) builds every tick
from the message of its period whatever the phase, the jitter and the delays, and the poses
brought to the tick make two stacks sampled at different instants comparable: the verdicts
stand. They are not identical to the stream's: constant velocity over up to 1.5 periods is
not the simulator's motion, and a prediction re-timed by a few milliseconds is resampled.
"""

from __future__ import annotations

import argparse
import shutil
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import yaml
from rosbags.rosbag2 import StoragePlugin, Writer

from casewatch import api
from casewatch.evaluator.session import RunOptions, evaluate_stream
from casewatch.monitor.bags.types import OBJECTS, ODOMETRY, TRAJECTORY
from casewatch.monitor.bags.writer import DEFAULT_T0_NS, MessageBuilder, default_mapping
from casewatch.monitor.frames import ChannelState
from casewatch.monitor.reader import read_stream

ROOT = Path(__file__).resolve().parents[2]
CASE = ROOT / "examples" / "reference-case.yaml"
MS = 1_000_000


def record(stream: Path, out: Path, seed: int, at_tick: bool = True) -> Path:
    """Write `stream` as a bag folder `out` with stack timing; returns the mapping file."""
    rng = np.random.default_rng(seed)
    reader = read_stream(stream)
    frames = list(reader)
    header = reader.header
    channels = list(header.channels) if header and header.channels else list(frames[0].channels)
    signals = sorted({k for f in frames for k in f.signals})
    plain = default_mapping(channels, signals, 4.6, 1.9, header.coverage if header else None)
    if not at_tick:
        plain["poses_at_tick"] = False
    build = MessageBuilder()
    store = build.store
    phase = int(rng.uniform(5, 95) * MS)
    skew = {c: rng.uniform(-10, 10) for c in channels}
    # per channel and role: (stamp offset from the tick, recording delay range in ms)
    timing = {
        (c, role): (
            phase + int((skew[c] + rng.uniform(-5, 5)) * MS),
            (20, 250) if role == "objects" else (1, 20),
        )
        for c in channels
        for role in ("odometry", "objects", "plan")
    }
    messages: list[tuple[int, str, str, bytes]] = []
    for frame in frames:
        tick = DEFAULT_T0_NS + round(frame.t * 1e9)
        for c, state in frame.channels.items():
            topics = plain["channels"][c]
            for role, msgtype in (
                ("odometry", ODOMETRY),
                ("objects", OBJECTS),
                ("plan", TRAJECTORY),
            ):
                if role == "plan" and not len(state.plan):
                    continue
                offset, (lo, hi) = timing[(c, role)]
                offset += int(rng.uniform(-3, 3) * MS)
                stamp = tick + offset
                log = stamp + int(rng.uniform(lo, hi) * MS)
                moved = at_instant(state, offset / 1e9)
                msg = (
                    build.odometry(stamp, moved)
                    if role == "odometry"
                    else build.objects(stamp, moved.objects)
                    if role == "objects"
                    else build.trajectory(stamp, moved.plan)
                )
                messages.append((log, topics[role], msgtype, store.serialize_cdr(msg, msgtype)))
        for name, value in frame.signals.items():
            if value is not None:
                raw = store.serialize_cdr(build.scalar(value), "std_msgs/msg/Float64")
                messages.append((tick + phase, plain["signals"][name], "std_msgs/msg/Float64", raw))
    messages.sort(key=lambda m: m[0])  # the recorder writes in arrival order
    shutil.rmtree(out, ignore_errors=True)
    writer = Writer(out, version=9, storage_plugin=StoragePlugin.MCAP)
    writer.open()
    conns: dict[str, object] = {}
    for log, topic, msgtype, raw in messages:
        if topic not in conns:
            conns[topic] = writer.add_connection(topic, msgtype, typestore=store)
        writer.write(conns[topic], log, raw)
    writer.close()
    mapping = out.with_name(out.name + ".topics.yaml")
    mapping.write_text(yaml.safe_dump(plain, sort_keys=False), encoding="utf-8")
    return mapping


def _later(traj: np.ndarray, dt: float) -> np.ndarray:
    """`[dt, x, y]` points counted from `dt` seconds later; the ones then past dropped."""
    out = traj.copy()
    out[:, 0] -= dt
    return out[out[:, 0] >= 0]


def at_instant(state: ChannelState, dt: float) -> ChannelState:
    """What the channel reports `dt` seconds after its frame (dt may be negative), for a
    message stamped then: poses moved at constant velocity, trajectories re-timed."""
    ego = replace(state.ego, x=state.ego.x + state.ego.vx * dt, y=state.ego.y + state.ego.vy * dt)
    objs = state.objects
    if len(objs):
        preds = [_later(objs.pred[i, : objs.pred_len[i]], dt) for i in range(len(objs))]
        lens = np.array([len(p) for p in preds], dtype=np.int64)
        pred = np.zeros((len(objs), max(int(lens.max()), 0), 3))
        for i, p in enumerate(preds):
            if len(p):
                pred[i, : len(p)] = p
                pred[i, len(p) :] = p[-1]
        objs = replace(objs, pos=objs.pos + objs.vel * dt, pred=pred, pred_len=lens)
    return ChannelState(ego=ego, plan=_later(state.plan, dt), objects=objs)


def _overlap(a, others, shift: float, slack: float = 0.1 + 1e-9) -> bool:
    """An episode of `others` (times + `shift`) of the same node within a tick of `a`."""
    return any(
        b.node_id == a.node_id
        and b.start + shift <= a.end + slack
        and a.start <= b.end + shift + slack
        for b in others
    )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m examples.sim.stack_timing",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ap.add_argument("streams", nargs="+", type=Path)
    ap.add_argument("--out", type=Path, default=Path("out") / "stack-timing")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument(
        "--as-stamped",
        action="store_true",
        help="judge with poses_at_tick: false (to see what moving them buys)",
    )
    args = ap.parse_args(argv)
    case, spec = api.prepare(CASE)
    print(
        f"{'drive':<34}{'frames':>7}{'dropouts':>9}{'defects':>8}  episodes: stream in bag, "
        "bag in stream"
    )
    for k, stream in enumerate(args.streams):
        name = stream.name.removesuffix(".gz").removesuffix(".jsonl")
        bag = args.out / name
        bag.parent.mkdir(parents=True, exist_ok=True)
        mapping = record(stream, bag, args.seed * 1000 + k, at_tick=not args.as_stamped)
        ours = evaluate_stream(case, spec, bag, RunOptions(topics=mapping))
        theirs = evaluate_stream(case, spec, stream, RunOptions())
        shift = (int(ours.stream.meta["t0_unix_ns"]) - DEFAULT_T0_NS) / 1e9  # bag t -> stream t
        found = sum(_overlap(e, ours.episodes, shift) for e in theirs.episodes)
        back = sum(_overlap(e, theirs.episodes, -shift) for e in ours.episodes)
        drops = sum(ours.stream.dropouts.values()) - sum(theirs.stream.dropouts.values())
        print(
            f"{stream.parent.name + '/' + name:<34}{ours.stream.frames_read:>7}{drops:>9}"
            f"{ours.stream.defect_count:>8}  {found}/{len(theirs.episodes)}, "
            f"{back}/{len(ours.episodes)}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
