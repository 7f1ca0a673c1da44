"""Labels (examples/sim/labels.py): interval rules, geometry on a hand-built truth, SSM parsing."""

from __future__ import annotations

from itertools import pairwise
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from examples.sim.labels import following, geometry_labels, intervals, read_ssm, ssm_labels
from examples.sim.simulate import GroundTruth


def test_runs_merge_across_short_gaps_and_short_runs_drop() -> None:
    t = np.round(np.arange(0, 6.0, 0.1), 1)
    mask = np.zeros(len(t), dtype=bool)
    mask[(t >= 1.0) & (t <= 1.5)] = True  # 0.5 s
    mask[(t >= 2.0) & (t <= 2.6)] = True  # 0.4 s after the first: merges -> [1.0, 2.6]
    mask[(t >= 4.0) & (t <= 4.5)] = True  # alone and 0.5 s long: dropped
    assert intervals(t, mask) == [(1.0, 2.6)]
    # with no minimum duration the short run stays, and a gap of exactly 1.4 s does not merge
    assert intervals(t, mask, min_duration=0.0) == [(1.0, 2.6), (4.0, 4.5)]


def test_empty_mask_gives_no_interval() -> None:
    assert intervals(np.arange(5) * 0.1, np.zeros(5, dtype=bool)) == []


@settings(max_examples=60, deadline=None)
@given(st.lists(st.booleans(), min_size=1, max_size=200))
def test_intervals_are_sorted_disjoint_and_bounded_by_true_ticks(bits: list[bool]) -> None:
    t = np.arange(len(bits)) * 0.1
    mask = np.array(bits)
    out = intervals(t, mask)
    for a, b in out:
        assert b - a >= 1.0 - 1e-9
        ia, ib = round(a / 0.1), round(b / 0.1)
        assert mask[ia] and mask[ib]
    for (_, b), (c, _) in pairwise(out):
        assert c - b >= 1.0 - 1e-9


def _truth(ahead_x: float, behind_x: float) -> GroundTruth:
    """Ego at x = 10 t driving east at 10 m/s, one car ahead and one behind in the same lane,
    all 4.5 m long; 61 ticks of 0.1 s."""
    t = np.round(np.arange(61) * 0.1, 1)
    x = np.array([0.0, ahead_x, behind_x])[None, :] + 10.0 * t[:, None]
    n = x.shape
    return GroundTruth(
        scenario="hand",
        times=t,
        ids=["ego", "ahead", "behind"],
        cls=["car"] * 3,
        length=np.full(3, 4.5),
        width=np.full(3, 1.8),
        min_gap=np.full(n, 2.5),
        x=x,
        y=np.zeros(n),
        yaw=np.zeros(n),
        speed=np.full(n, 10.0),
        lane=np.zeros(n, dtype=int),
        lane_pos=x + 2.25,
        lane_ids=["hw_1"],
        speed_limit=np.full(len(t), 33.3),
        sumo_leader=[None] * len(t),
        sumo_leader_gap=np.full(len(t), np.nan),
        ego_min_gap=np.full(len(t), 2.5),
        ssm_file=Path("unused"),
        ego_index=0,
    )


def test_following_gaps_from_centres() -> None:
    fol = following(_truth(20.0, -15.0))
    # lead: 20 m centre to centre - (4.5 + 4.5) / 2 = 15.5 m; at 10 m/s: 1.55 s
    np.testing.assert_allclose(fol.lead_gap, 15.5)
    np.testing.assert_allclose(fol.lead_time_gap, 1.55)
    # follower: 15 - 4.5 = 10.5 m; at its 10 m/s: 1.05 s
    np.testing.assert_allclose(fol.follower_gap, 10.5)
    np.testing.assert_allclose(fol.follower_time_gap, 1.05)


def test_geometry_labels_flag_close_following_both_ways() -> None:
    # lead gap 10 - 4.5 = 5.5 m -> 0.55 s; follower gap 8 - 4.5 = 3.5 m -> 0.35 s: both < 1 s
    labels = geometry_labels(_truth(10.0, -8.0), duration=6.0)
    assert [(x["hazard"], x["start"], x["end"]) for x in labels] == [
        ("CSn2", 0.0, 6.0),
        ("CSn3", 0.0, 6.0),
    ]
    assert labels[0]["vehicles"] == ["ahead"] and labels[1]["min_time_gap"] == 0.35
    # 1.55 s and 1.05 s: nothing
    assert geometry_labels(_truth(20.0, -15.0), duration=6.0) == []


SSM_XML = """<SSMLog>
  <conflict begin="1.00" end="2.00" ego="ego" foe="lead">
    <timeSpan values="1.00 1.10 1.20 1.30 1.40 1.50"/>
    <typeSpan values="2 2 2 2 2 2"/>
    <TTCSpan values="NA 3.50 2.90 2.50 2.80 3.20"/>
    <DRACSpan values="NA 0.50 0.80 1.20 0.90 0.40"/>
    <minTTC time="1.30" position="0,0" type="2" value="2.50"/>
  </conflict>
  <conflict begin="4.00" end="5.00" ego="ego" foe="x">
    <timeSpan values="4.00 4.10"/>
    <typeSpan values="10 10"/>
    <TTCSpan values="NA NA"/>
    <DRACSpan values="3.50 2.00"/>
    <PET time="4.50" position="0,0" type="17" value="1.20"/>
  </conflict>
  <globalMeasures ego="ego">
    <timeSpan values="0.00 0.10"/>
    <SGAPSpan values="NA 12.00"/>
    <TGAPSpan values="NA 0.80"/>
  </globalMeasures>
</SSMLog>
"""


def test_ssm_conflicts_become_labels(tmp_path: Path) -> None:
    path = tmp_path / "ssm.xml"
    path.write_text(SSM_XML)
    log = read_ssm(path)
    np.testing.assert_allclose(log.tgap, [np.nan, 0.8])
    labels = ssm_labels(log, duration=10.0)
    # conflict 1: TTC < 3 at 1.2, 1.3, 1.4 -> [1.2, 1.4], type 2 (ego follows) -> CSn2
    # conflict 2: DRAC > 3 at 4.0 -> [4.0, 4.0] crossing; PET 1.2 < 2 at 4.5 -> point label
    assert [(x["hazard"], x["start"], x["end"]) for x in labels] == [
        ("CSn2", 1.2, 1.4),
        ("ssm-conflict", 4.0, 4.0),
        ("ssm-conflict", 4.5, 4.5),
    ]
    assert labels[0]["min_ttc"] == 2.5 and labels[1]["max_drac"] == 3.5
    assert labels[2]["pet"] == 1.2


def test_unreadable_ssm_file_names_the_file(tmp_path: Path) -> None:
    path = tmp_path / "broken.xml"
    path.write_text("<SSMLog><conflict>")
    with pytest.raises(ValueError, match=r"broken\.xml: cannot read SUMO SSM output"):
        read_ssm(path)


def test_following_continues_across_an_edge_boundary() -> None:
    """The lead passes onto the next edge (lane `e2_0`) two seconds before the ego does: it is
    still the ego's lead (the ego later drives through its position on that lane), with the gap
    measured along the ego's path; the same for the follower left behind on `e1_0`."""
    gt = _truth(20.0, -15.0)
    front = gt.x + 2.25
    on_e2 = front >= 50.0
    gt.lane = np.where(on_e2, 1, 0)
    gt.lane_pos = np.where(on_e2, front - 50.0, front)
    gt.lane_ids = ["e1_0", "e2_0"]
    fol = following(gt)
    assert (gt.lane[:, 1] != gt.lane[:, 0]).any() and (gt.lane[:, 2] != gt.lane[:, 0]).any()
    # the ego's future ends at 6 s: the lead is found while the ego reaches its position
    reach = gt.x[:, 1] + 2.25 <= gt.x[-1, 0] + 2.25
    np.testing.assert_allclose(fol.lead_gap[reach], 15.5, atol=1e-9)
    np.testing.assert_allclose(fol.follower_gap, 10.5, atol=1e-9)
