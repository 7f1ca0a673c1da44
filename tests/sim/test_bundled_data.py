"""The bundled reference data (examples/data): present, well-formed, labelled. No SUMO needed."""

from __future__ import annotations

import gzip
import json
from pathlib import Path

import numpy as np
import pytest
import yaml

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "examples" / "data"
INDEX = json.loads((DATA / "index.json").read_text())
NAMES = [e["scenario"] for e in INDEX]
REFERENCE_HAZARDS = {"CSn1", "CSn2", "CSn3"}


def _rows(path: Path) -> list[dict]:
    opener = gzip.open if path.suffix == ".gz" else open
    with opener(path, "rt") as fh:
        return [json.loads(line) for line in fh if line.strip()]


def _labels(name: str) -> list[dict]:
    return _rows(DATA / f"{name}.labels.jsonl")


ORIGINAL = ["highway-tailgating", "highway-tailgated", "urban-grid"]
REALSTACK = ["highway-realstack", "urban-realstack", "highway-close-realstack"]
COVERAGE = {
    "lav": {"fov_deg": 360.0, "range_m": 80.0},
    "tfuse": {"fov_deg": 120.0, "range_m": 70.0},
}


def test_index_lists_six_scenarios_with_files() -> None:
    assert NAMES == ORIGINAL + REALSTACK
    for e in INDEX:
        for key in ("stream", "labels", "ssm_labels"):
            assert (DATA / e[key]).is_file(), e[key]


@pytest.mark.parametrize("name", NAMES)
def test_stream_has_header_and_increasing_frames(name: str) -> None:
    rows = _rows(DATA / f"{name}.jsonl.gz")
    head = rows[0]["header"]
    assert head["format"] == "casewatch-frames"
    assert head["channels"] == ["lav", "tfuse"]
    assert head["meta"]["scenario"] == name
    t = np.array([r["t"] for r in rows[1:]])
    assert np.all(np.diff(t) > 0)
    # 1 to 3 minutes at 0.1 s: duration / 0.1 + 1 frames
    assert 60.0 <= t[-1] - t[0] <= 180.0
    entry = next(e for e in INDEX if e["scenario"] == name)
    assert entry["bytes"] == (DATA / entry["stream"]).stat().st_size <= 2_500_000
    assert len(t) == round((t[-1] - t[0]) / 0.1) + 1


@pytest.mark.parametrize("name", NAMES)
def test_label_files_are_well_formed(name: str) -> None:
    for path in (DATA / f"{name}.labels.jsonl", DATA / f"{name}.ssm-labels.jsonl"):
        for lab in _rows(path):
            assert isinstance(lab["hazard"], str)
            assert 0.0 <= lab["start"] <= lab["end"]


def test_labels_cover_all_three_reference_hazards() -> None:
    found = {lab["hazard"] for name in NAMES for lab in _labels(name)}
    assert found >= REFERENCE_HAZARDS


def test_hazard_ids_exist_in_reference_case() -> None:
    case_file = ROOT / "examples" / "reference-case.yaml"
    if not case_file.exists():
        pytest.fail("examples/reference-case.yaml is missing; labels name its CSn nodes")
    case = yaml.safe_load(case_file.read_text())
    assert set(case) >= REFERENCE_HAZARDS
    assert "localization" in case["CSn1"]["text"].lower()
    assert "tailgating" in case["CSn2"]["text"].lower()
    assert "tailgated" in case["CSn3"]["text"].lower()


@pytest.mark.parametrize("name", NAMES)
def test_localization_labels_are_where_els_var_exceeds_reference_threshold(name: str) -> None:
    """els = 1/(1+dist(ego_lav, ego_tfuse)); els_var = sample variance over 5 ticks; the
    reference hazard is els_var > 0.05. It must fire inside each CSn1 label and nowhere else."""
    frames = _rows(DATA / f"{name}.jsonl.gz")[1:]
    t = np.array([f["t"] for f in frames])
    a = np.array(
        [[f["channels"]["lav"]["ego"]["x"], f["channels"]["lav"]["ego"]["y"]] for f in frames]
    )
    b = np.array(
        [[f["channels"]["tfuse"]["ego"]["x"], f["channels"]["tfuse"]["ego"]["y"]] for f in frames]
    )
    els = 1.0 / (1.0 + np.hypot(*(a - b).T))
    windows = np.lib.stride_tricks.sliding_window_view(els, 5)
    var = windows.var(axis=1, ddof=1)
    t_end = t[4:]  # the window ending at that tick
    inside = np.zeros(len(t_end), dtype=bool)
    labels = [lab for lab in _labels(name) if lab["hazard"] == "CSn1"]
    assert labels
    for lab in labels:
        sel = (t_end >= lab["start"]) & (t_end <= lab["end"] + 0.4)
        assert var[sel].max() > 0.05, lab
        inside |= sel
    assert var[~inside].max() < 0.05


ORIGINAL_COVERAGE = {
    "lav": {"fov_deg": 360.0, "range_m": 60.0},
    "tfuse": {"fov_deg": 200.0, "range_m": 50.0},
}


@pytest.mark.parametrize("name", NAMES)
def test_coverage_header_matches_the_profiles(name: str) -> None:
    head = _rows(DATA / f"{name}.jsonl.gz")[0]["header"]
    params = head["meta"]["channel_params"]
    assert head["coverage"] == (ORIGINAL_COVERAGE if name in ORIGINAL else COVERAGE)
    for ch, cov in head["coverage"].items():
        assert (params[ch]["fov_deg"], params[ch]["range_m"]) == (cov["fov_deg"], cov["range_m"])
    profiles = ("", "") if name in ORIGINAL else ("LIDAR_STACK", "CAMERA_STACK")
    assert (params["lav"]["profile"], params["tfuse"]["profile"]) == profiles


def _headings(plan: np.ndarray) -> np.ndarray:
    """Per plan point, the direction of the nearest segment of motion (> 1 mm) before it, else
    after it; NaN for a plan that does not move."""
    d = np.diff(plan[:, 1:], axis=0)
    seg = np.where(np.hypot(*d.T) > 1e-3, np.arctan2(d[:, 1], d[:, 0]), np.nan)
    out = np.full(len(plan), np.nan)
    for i in range(len(plan)):
        back = seg[:i][~np.isnan(seg[:i])]
        ahead = seg[i:][~np.isnan(seg[i:])]
        out[i] = back[-1] if len(back) else (ahead[0] if len(ahead) else np.nan)
    return out


@pytest.mark.parametrize("name", NAMES)
def test_plans_keep_the_standstill_gap_to_their_own_predicted_lead(name: str) -> None:
    """Each channel's plan stays behind its own constant-velocity prediction of the in-path
    lead: at every plan point the lead (a vehicle track ahead of the ego's front bumper at the
    first point, within 1.75 m of the path and heading its way) predicted at the point's dt is
    either behind the ego at that point or at least the standstill gap (2.0 m, bumper to
    bumper, along the plan's heading) ahead of it, unless the plan has not moved from its first
    point (it started closer than the gap). Checked only where the predicted centre lies within
    1.0 m of the plan point's line (well inside the corridor); 5 cm tolerance for rounding and
    for measuring along the plan's heading rather than the lead's."""
    frames = _rows(DATA / f"{name}.jsonl.gz")
    gap = {
        ch: p["plan_standstill_gap"]
        for ch, p in frames[0]["header"]["meta"]["channel_params"].items()
    }
    checked = 0
    for f in frames[1:]:
        for ch, rep in f["channels"].items():
            plan = np.array(rep["plan"])
            objs = [o for o in rep["objects"] if o["cls"] != "unknown"]  # ghosts: not planned
            head = _headings(plan)
            if len(plan) < 2 or not objs or np.isnan(head).all():
                continue
            le = rep["ego"]["length"]
            o = np.array([[b["x"], b["y"], b["vx"], b["vy"], b["yaw"], b["length"]] for b in objs])
            u0 = np.array([np.cos(head[0]), np.sin(head[0])])
            r0 = o[:, :2] - plan[0, 1:]
            turn0 = np.abs((o[:, 4] - head[0] + np.pi) % (2 * np.pi) - np.pi)
            lead = (
                (r0 @ u0 > le / 2)
                & (np.abs(r0 @ [-u0[1], u0[0]]) <= 1.75)
                & (turn0 <= np.radians(30.0))
            )
            for i in range(1, len(plan)):
                if not lead.any() or np.hypot(*(plan[i, 1:] - plan[0, 1:])) < 1e-3:
                    continue
                u = np.array([np.cos(head[i]), np.sin(head[i])])
                q = o[lead, :2] + o[lead, 2:4] * plan[i, 0] - plan[i, 1:]
                lon, lat = q @ u, q @ [-u[1], u[0]]
                turn = np.abs((o[lead, 4] - head[i] + np.pi) % (2 * np.pi) - np.pi)
                half = (le + o[lead, 5]) / 2
                near = (np.abs(lat) <= 1.0) & (turn <= np.radians(30.0)) & (lon > -half)
                checked += int(near.sum())
                assert np.all(lon[near] - half[near] >= gap[ch] - 0.05), (f["t"], ch, i)
    assert checked > 1000


@pytest.mark.parametrize("name", REALSTACK)
def test_real_stack_drives_have_the_profiles_properties(name: str) -> None:
    """Plans (tfuse every 0.5 s over 3 s; lav every 1 m while moving, two points at a
    standstill), predictions (lav 4.0 s at 0.5 s, tfuse 2.5 s at 0.1 s), and a forward camera
    that reports nothing behind the ego. Spacing: 1 m to 0.1 mm on a straight road; where the
    plan distortion folds the path back on itself near a stop the chord is a few cm short."""
    frames = _rows(DATA / f"{name}.jsonl.gz")[1:]
    steps = []
    for f in frames:
        cam, lid = f["channels"]["tfuse"], f["channels"]["lav"]
        np.testing.assert_allclose(np.array(cam["plan"])[:, 0], 0.5 * np.arange(7), atol=1e-9)
        plan = np.array(lid["plan"])
        assert len(plan) >= 2 and np.all(np.diff(plan[:, 0]) > 0) and plan[-1, 0] <= 5.0
        if f["signals"]["ego_speed"] > 3.0:
            steps.append(np.hypot(*np.diff(plan[:, 1:], axis=0).T))
        for o in lid["objects"]:
            assert [p[0] for p in o["prediction"]] == [0.5 * k for k in range(1, 9)]
        ego = cam["ego"]
        for o in cam["objects"]:
            assert len(o["prediction"]) == 25 and o["prediction"][-1][0] == 2.5
            dx, dy = o["x"] - ego["x"], o["y"] - ego["y"]
            bearing = abs((np.degrees(np.arctan2(dy, dx) - ego["yaw"]) + 180.0) % 360.0 - 180.0)
            r = np.hypot(dx, dy)
            assert bearing <= 60.0 + np.degrees(np.arcsin(min(1.0, 1.0 / r))) and r <= 71.0
    step = np.concatenate(steps)
    assert np.abs(step - 1.0).max() < 0.05
    assert np.mean(np.abs(step - 1.0) < 1e-3) > 0.99


@pytest.mark.parametrize("name", REALSTACK)
def test_real_stack_localisation_difference_is_the_two_ar1_processes(name: str) -> None:
    """Both channels add their own AR(1) offset to the same physical path, so outside the
    faults ego_lav - ego_tfuse = e_lav - e_tfuse: std per axis sqrt(0.06^2 + 0.12^2) = 0.134 m,
    lag-1 correlation (0.7 * 0.06^2 + 0.6 * 0.12^2) / 0.134^2 = 0.62."""
    frames = _rows(DATA / f"{name}.jsonl.gz")[1:]
    t = np.array([f["t"] for f in frames])
    d = np.array(
        [
            [f["channels"]["lav"]["ego"][k] - f["channels"]["tfuse"]["ego"][k] for k in ("x", "y")]
            for f in frames
        ]
    )
    faults = [lab for lab in _labels(name) if lab["hazard"] == "CSn1"]
    assert len(faults) == 1
    before = t < faults[0]["start"] - 0.05
    assert before.sum() > 700
    d = d[before]
    assert np.sqrt((d**2).mean(axis=0)) == pytest.approx([np.hypot(0.06, 0.12)] * 2, rel=0.1)
    r1 = [np.corrcoef(d[:-1, a], d[1:, a])[0, 1] for a in (0, 1)]
    expected = (0.7 * 0.06**2 + 0.6 * 0.12**2) / (0.06**2 + 0.12**2)
    assert r1 == pytest.approx([expected] * 2, abs=0.06)


@pytest.mark.parametrize("name", REALSTACK)
def test_real_stack_drives_are_mostly_unlabelled(name: str) -> None:
    """False alarms are measured on the nominal stretches: most of the drive carries no label,
    and there is an unlabelled stretch of at least 30 s."""
    frames = _rows(DATA / f"{name}.jsonl.gz")[1:]
    t = np.array([f["t"] for f in frames])
    labelled = np.zeros(len(t), dtype=bool)
    for lab in _labels(name):
        labelled |= (t >= lab["start"] - 1e-9) & (t <= lab["end"] + 1e-9)
    assert labelled.mean() < 0.15
    edges = np.flatnonzero(np.diff(np.concatenate([[1], labelled.astype(int), [1]])))
    assert np.diff(edges)[::2].max() * 0.1 >= 30.0
