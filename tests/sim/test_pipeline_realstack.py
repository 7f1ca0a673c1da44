"""End to end with SUMO: the 20-second highway run with the real-stack profiles.

The properties of the profiles are checked on what the stream holds: plan spacing (0.5 s for
tfuse, about 1 m for lav while moving), prediction horizons (4.0 s / 2.5 s), AR(1) localisation
noise, the forward camera's coverage, the header's `coverage` key, and determinism.
"""

from __future__ import annotations

import gzip
import json

import numpy as np
import pytest

pytest.importorskip("libsumo", reason="SUMO not installed: pip install -e .[sim]")
pytest.importorskip("sumolib", reason="SUMO not installed: pip install -e .[sim]")

from casewatch.monitor.reader import read_stream
from examples.sim.channels import CAMERA_STACK, LIDAR_STACK, ego_motion
from examples.sim.frames import Generated, generate
from examples.sim.scenarios import HIGHWAY_SHORT_REALSTACK as SC

pytestmark = pytest.mark.sim


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> tuple[Generated, Generated]:
    base = tmp_path_factory.mktemp("realstack")
    return (generate(SC, base / "a", base / "work-a"), generate(SC, base / "b", base / "work-b"))


@pytest.fixture(scope="module")
def short(runs: tuple[Generated, Generated]) -> Generated:
    return runs[0]


def _rows(g: Generated) -> list[dict]:
    with gzip.open(g.stream, "rt") as fh:
        return [json.loads(line) for line in fh]


def test_generation_is_deterministic(runs: tuple[Generated, Generated]) -> None:
    a, b = runs
    assert a.stream.read_bytes() == b.stream.read_bytes()
    assert a.labels.read_bytes() == b.labels.read_bytes()
    assert a.ssm_labels.read_bytes() == b.ssm_labels.read_bytes()
    # gzip header: mtime 0
    assert a.stream.read_bytes()[4:8] == b"\0\0\0\0"


def test_header_coverage_and_reader(short: Generated) -> None:
    head = _rows(short)[0]["header"]
    assert head["coverage"] == {
        "lav": {"fov_deg": 360.0, "range_m": 80.0},
        "tfuse": {"fov_deg": 120.0, "range_m": 70.0},
    }
    assert head["meta"]["channel_params"]["lav"]["profile"] == "LIDAR_STACK"
    reader = read_stream(short.stream)
    assert sum(1 for _ in reader) == 201
    assert reader.defects == []
    assert reader.channels == ["lav", "tfuse"]


def test_camera_plan_every_half_second_and_lidar_plan_every_metre(short: Generated) -> None:
    frames = _rows(short)[1:]
    moving = 0
    for f in frames:
        cam = np.array(f["channels"]["tfuse"]["plan"])
        np.testing.assert_allclose(cam[:, 0], 0.5 * np.arange(7), atol=1e-9)
        lid = np.array(f["channels"]["lav"]["plan"])
        dt = np.diff(lid[:, 0])
        assert np.all(dt > 0) and lid[0, 0] == 0.0 and lid[-1, 0] <= 5.0
        if f["signals"]["ego_speed"] > 3.0:
            step = np.hypot(*np.diff(lid[:, 1:], axis=0).T)
            # straight highway: 1 m to the 0.1 mm the stream is written with
            np.testing.assert_allclose(step, 1.0, atol=1e-3)
            # the points reach 5 s less than one spacing's travel time
            assert lid[-1, 0] > 5.0 - 1.0 / f["signals"]["ego_speed"] - 0.05
            moving += 1
    assert moving == len(frames)


def test_prediction_horizons(short: Generated) -> None:
    counted = {"lav": 0, "tfuse": 0}
    for f in _rows(short)[1:]:
        for ch, step, horizon in (("lav", 0.5, 4.0), ("tfuse", 0.1, 2.5)):
            for o in f["channels"][ch]["objects"]:
                dts = np.array(o["prediction"])[:, 0]
                np.testing.assert_allclose(dts, step * np.arange(1, round(horizon / step) + 1))
                counted[ch] += 1
    assert counted["lav"] > 200 and counted["tfuse"] > 100


def test_localisation_offsets_are_ar1_with_the_configured_values(short: Generated) -> None:
    """The reported ego minus the ego's physical (smoothed SUMO) path, outside the injected
    fault: std per axis and lag-1 correlation of the profiles, within the sampling error of
    200 correlated ticks (about 4 standard errors)."""
    frames = _rows(short)[1:]
    motion = ego_motion(short.ground_truth)
    t = np.array([f["t"] for f in frames])
    fault = next(x for x in SC.faults)
    for ch, params in (("lav", LIDAR_STACK), ("tfuse", CAMERA_STACK)):
        ego = np.array(
            [[f["channels"][ch]["ego"]["x"], f["channels"][ch]["ego"]["y"]] for f in frames]
        )
        off = ego - np.column_stack([motion.x[: len(t)], motion.y[: len(t)]])
        if fault.channel == ch:
            keep = (t < fault.start - 0.05) | (t > fault.end + 0.05)
            assert np.hypot(*off[~keep].T).max() > 3.0  # the fault is there
            off = off[t < fault.start - 0.05]  # one contiguous stretch for the lag-1 estimate
        assert np.sqrt((off**2).mean()) == pytest.approx(params.loc_sigma, rel=0.25)
        r1 = np.mean([np.corrcoef(off[:-1, a], off[1:, a])[0, 1] for a in (0, 1)])
        assert r1 == pytest.approx(params.loc_phi, abs=0.15)


def test_forward_camera_reports_nothing_behind_or_beyond_range(short: Generated) -> None:
    """Visibility is decided on the truth (exactly +-60 deg, 70 m; see test_realstack). In the
    stream the object and the ego pose carry their errors (track error, the smoothed ego path
    against SUMO's, heading noise), so the reported bearing may pass 60 deg by what about 1 m
    across the line of sight makes at that range."""
    seen = 0
    for f in _rows(short)[1:]:
        ego = f["channels"]["tfuse"]["ego"]
        for o in f["channels"]["tfuse"]["objects"]:
            dx, dy = o["x"] - ego["x"], o["y"] - ego["y"]
            r = np.hypot(dx, dy)
            bearing = abs((np.degrees(np.arctan2(dy, dx) - ego["yaw"]) + 180.0) % 360.0 - 180.0)
            assert bearing <= 60.0 + np.degrees(np.arcsin(min(1.0, 1.0 / r))), (f["t"], o)
            assert r <= 70.0 + 1.0, (f["t"], o)
            seen += 1
    assert seen > 100
