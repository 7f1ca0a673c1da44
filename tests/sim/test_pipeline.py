"""End to end with SUMO: a 20-second highway run, checked against SUMO's own measures."""

from __future__ import annotations

import gzip
import json

import numpy as np
import pytest

pytest.importorskip("libsumo", reason="SUMO not installed: pip install -e .[sim]")
pytest.importorskip("sumolib", reason="SUMO not installed: pip install -e .[sim]")

from casewatch.monitor.reader import read_stream
from examples.sim import labels as lab
from examples.sim.frames import Generated, generate
from examples.sim.scenarios import HIGHWAY_SHORT

pytestmark = pytest.mark.sim


@pytest.fixture(scope="module")
def short(tmp_path_factory: pytest.TempPathFactory) -> Generated:
    base = tmp_path_factory.mktemp("sim")
    return generate(HIGHWAY_SHORT, base / "out", base / "work")


def _frames(g: Generated) -> list[dict]:
    with gzip.open(g.stream, "rt") as fh:
        return [json.loads(line) for line in fh][1:]


def test_twenty_second_scenario_runs_end_to_end(short: Generated) -> None:
    frames = _frames(short)
    # 0.0 .. 20.0 s every 0.1 s = 201 frames
    assert short.frames == len(frames) == 201
    assert frames[0]["t"] == 0.0 and frames[-1]["t"] == 20.0
    assert set(frames[100]["channels"]) == {"lav", "tfuse"}
    labels = [json.loads(x) for x in short.labels.read_text().splitlines()]
    # the scenario tailgates from 3 s and injects a tfuse fault on [10.0, 11.6)
    assert {x["hazard"] for x in labels} >= {"CSn1", "CSn2"}
    fault = next(x for x in labels if x["hazard"] == "CSn1")
    assert (fault["start"], fault["end"]) == (10.0, 11.5)


def test_frames_pass_the_reader_with_zero_defects(short: Generated) -> None:
    reader = read_stream(short.stream)
    assert sum(1 for _ in reader) == 201
    assert reader.defects == []


def test_true_lead_gap_matches_sumo_leader_gap(short: Generated) -> None:
    """getLeader's gap runs from the ego's front + minGap to the leader's back, so the bumper
    gap is leaderGap + minGap; the frames' gt_lead_gap comes from the converted centres."""
    gt = short.ground_truth
    frames = _frames(short)
    fol = lab.following(gt)
    compared = 0
    for k, f in enumerate(frames):
        ours = f["signals"]["gt_lead_gap"]
        sumo = gt.sumo_leader[k]
        if ours is None or sumo is None or gt.ids[fol.lead[k]] != sumo:
            continue
        assert abs(ours - (gt.sumo_leader_gap[k] + gt.ego_min_gap[k])) <= 0.1, f["t"]
        compared += 1
    assert compared >= 150


def test_tailgating_labels_agree_with_sumo_time_gap(short: Generated) -> None:
    """SUMO's SSM TGAP (bumper gap / ego speed) under the same threshold, minimum speed and
    interval rules gives the same CSn2 intervals, to within one tick at each end."""
    gt = short.ground_truth
    log = lab.read_ssm(gt.ssm_file)
    keep = log.times <= HIGHWAY_SHORT.duration + 1e-9
    t = log.times[keep]
    np.testing.assert_allclose(t, gt.times[: len(t)], atol=1e-6)
    speed = gt.speed[: len(t), gt.ego_index]
    with np.errstate(invalid="ignore"):
        mask = (log.tgap[keep] < lab.TIME_GAP_THRESHOLD) & (speed > lab.MIN_SPEED)
    sumo = lab.intervals(t, mask)
    ours = [
        (x["start"], x["end"])
        for x in lab.geometry_labels(gt, HIGHWAY_SHORT.duration)
        if x["hazard"] == lab.HAZARD_TAILGATING
    ]
    assert len(ours) == len(sumo) >= 1
    for (a, b), (c, d) in zip(ours, sumo, strict=True):
        assert abs(a - c) <= 0.1 + 1e-9 and abs(b - d) <= 0.1 + 1e-9
