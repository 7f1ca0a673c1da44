"""A drive re-recorded with a real stack's timing (phase, skew, jitter, late arrival) is
judged like the drive: examples/sim/stack_timing.py on the first 40 s of a bundled drive."""

from __future__ import annotations

import gzip
import itertools
import json
from pathlib import Path

import numpy as np

from casewatch import api
from casewatch.evaluator.session import RunOptions, evaluate_stream
from casewatch.monitor.bags.writer import DEFAULT_T0_NS
from casewatch.monitor.encode import frame_to_dict, header_to_dict
from casewatch.monitor.reader import read_stream
from examples.sim.stack_timing import _overlap, at_instant, record
from tests.monitor.bagkit import ego_state

REPO = Path(__file__).resolve().parents[2]


def test_at_instant_moves_poses_and_retimes_trajectories() -> None:
    state = ego_state(10.0, vx=20.0)
    state.plan = np.array([[0.0, 10.0, 0.0], [0.5, 20.0, 0.0], [1.0, 30.0, 0.0]])
    later = at_instant(state, 0.25)
    assert later.ego.x == 15.0
    assert later.plan.tolist() == [[0.25, 20.0, 0.0], [0.75, 30.0, 0.0]]


def test_stack_timing_keeps_the_verdicts(tmp_path: Path) -> None:
    reader = read_stream(REPO / "examples/data/urban-realstack.jsonl.gz")
    frames = list(itertools.islice(reader, 500))
    short = tmp_path / "short.jsonl.gz"
    with gzip.open(short, "wb") as fh:
        fh.write(json.dumps(header_to_dict(reader.header)).encode() + b"\n")
        for f in frames:
            fh.write(json.dumps(frame_to_dict(f)).encode() + b"\n")
    mapping = record(short, tmp_path / "bag", seed=3)
    case, spec = api.prepare(REPO / "examples/reference-case.yaml")
    ours = evaluate_stream(case, spec, tmp_path / "bag", RunOptions(topics=mapping))
    theirs = evaluate_stream(case, spec, short, RunOptions())
    assert ours.stream.defect_count == 0 and sum(ours.stream.dropouts.values()) == 0
    assert abs(ours.stream.frames_read - 500) <= 1
    shift = (int(ours.stream.meta["t0_unix_ns"]) - DEFAULT_T0_NS) / 1e9
    assert 0 < shift <= 0.1
    assert theirs.episodes
    assert all(_overlap(e, ours.episodes, shift) for e in theirs.episodes)
    assert all(_overlap(e, theirs.episodes, -shift) for e in ours.episodes)
