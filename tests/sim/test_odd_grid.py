"""The ODD grid generator (examples/sim/odd_grid.py) and its bundled drives
(examples/data/odd-grid). No SUMO needed."""

from __future__ import annotations

import gzip
import json
from pathlib import Path

import numpy as np
import pytest

from examples.sim.odd_grid import (
    CHANNELS,
    CONDITION_EFFECTS,
    DEFAULT_RUNS,
    GAP_CAP,
    GRID_CAMERA,
    GRID_LIDAR,
    ChannelEffect,
    apply_effect,
    cell_name,
    cell_scenario,
    cells,
    effects,
    is_degraded,
    odd_header,
    odd_meta,
    odd_truth,
    run_seed,
)
from monitor import situation
from monitor.reader import read_stream

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "examples" / "data" / "odd-grid"
INDEX = json.loads((DATA / "index.json").read_text())
DRIVES = INDEX["drives"]
SIGNALS = {"lane_offset", "lane_width", "gt_lead_gap", "gt_lead_speed"}


def _rows(path: Path) -> list[dict]:
    with gzip.open(path, "rt") as fh:
        return [json.loads(line) for line in fh if line.strip()]


# --- the condition -> effect table ------------------------------------------------------------


def test_clear_day_changes_nothing() -> None:
    assert effects("clear", "day") == {"lidar": ChannelEffect(), "camera": ChannelEffect()}
    assert apply_effect(GRID_CAMERA, ChannelEffect()) == GRID_CAMERA


def test_effects_by_hand() -> None:
    """Factors multiply (own entries, then the interaction), the shorter range cap wins."""
    assert effects("rain", "day") == {"camera": ChannelEffect(2.5, 1.5, None),
                                      "lidar": ChannelEffect(1.2, 1.5, None)}
    assert effects("clear", "night") == {"camera": ChannelEffect(1.8, 1.5, None),
                                         "lidar": ChannelEffect()}
    # rain (2.5, 1.5) x night (1.8, 1.5) x rain+night (3.0, 4.0)
    rn = effects("rain", "night")["camera"]
    assert (rn.noise, rn.miss, rn.range_m) == pytest.approx((13.5, 9.0, None))
    assert effects("rain", "night")["lidar"] == ChannelEffect(1.2, 1.5, None)
    # fog (10, 5, 35 m) x night (1.8, 1.5)
    fn = effects("fog", "night")["camera"]
    assert (fn.noise, fn.miss, fn.range_m) == pytest.approx((18.0, 7.5, 35.0))
    assert effects("fog", "day")["lidar"] == ChannelEffect(1.5, 1.5, 70.0)
    assert ChannelEffect(range_m=50.0).then(ChannelEffect(range_m=35.0)).range_m == 35.0


def test_table_names_only_known_conditions_and_channels() -> None:
    names = {c.name for c in CHANNELS}
    assert names == {"lidar", "camera"}
    for key, per_channel in CONDITION_EFFECTS.items():
        for part in key.split("+"):
            assert part in {"clear", "rain", "fog", "day", "night"}, key
        assert set(per_channel) <= names, key
    with pytest.raises(ValueError):
        effects("snow", "day")


def test_applied_effect_changes_noise_miss_and_range() -> None:
    fog = apply_effect(GRID_CAMERA, effects("fog", "day")["camera"])
    assert fog.range_m == 35.0 and GRID_CAMERA.range_m == 70.0
    assert fog.pos_sigma == pytest.approx(10.0 * GRID_CAMERA.pos_sigma)
    assert fog.pos_white == pytest.approx(10.0 * GRID_CAMERA.pos_white)
    assert fog.p_miss == pytest.approx(5.0 * GRID_CAMERA.p_miss)
    assert fog.coverage() == {"fov_deg": 120.0, "range_m": 35.0}
    lidar = apply_effect(GRID_LIDAR, effects("fog", "day")["lidar"])
    assert lidar.range_m == 70.0 and lidar.fov_deg == 360.0
    assert apply_effect(GRID_LIDAR, ChannelEffect(miss=1e6)).p_miss == 0.5


def test_degraded_cells() -> None:
    degraded = {(r, w, li) for r, w, li in cells() if is_degraded(w, li)}
    assert len(cells()) == 12
    assert degraded == {(r, w, li) for r in ("highway", "urban")
                        for w, li in (("fog", "day"), ("fog", "night"), ("rain", "night"))}
    # the camera is hit much harder in every degraded cell than in any other
    worst_ok = max(effects(w, li)["camera"].noise for _, w, li in cells()
                   if not is_degraded(w, li))
    best_bad = min(effects(w, li)["camera"].noise for _, w, li in cells() if is_degraded(w, li))
    assert best_bad >= 4.0 * worst_ok


# --- the layered meta, the seeds, the scenarios ---------------------------------------------


def test_odd_meta_for_a_cell() -> None:
    assert odd_meta("highway", "fog", "night") == {
        "road": {"type": "highway", "lanes": 3},
        "infrastructure": {"markings": "visible"},
        "temporary": {"roadworks": False},
        "traffic": {"density": "medium"},
        "environment": {"weather": "fog", "light": "night"},
        "connectivity": {"v2x": "none"},
    }
    assert odd_meta("urban", "clear", "day")["road"] == {"type": "urban", "lanes": 2}
    for road, w, li in cells():
        for layer in odd_meta(road, w, li).values():
            assert all(isinstance(v, str | int | float | bool) for v in layer.values())
    with pytest.raises(ValueError):
        odd_meta("rural", "clear", "day")


def test_odd_truth_carries_the_applied_effects() -> None:
    truth = odd_truth("rain", "night")
    assert truth["degraded"] is True and truth["degraded_channels"] == ["camera"]
    assert truth["channel_effects"]["camera"] == pytest.approx(
        {"noise": 13.5, "miss": 9.0, "range_m": None})
    assert odd_truth("rain", "day")["degraded"] is False
    assert odd_truth("rain", "day")["degraded_channels"] == []


def test_run_seeds_are_deterministic_and_distinct() -> None:
    seeds = {run_seed(1, c, r) for c in range(12) for r in range(4)}
    assert len(seeds) == 48
    assert run_seed(1, 3, 2) == run_seed(1, 3, 2) != run_seed(2, 3, 2)
    assert all(0 <= s < 2**31 for s in seeds)


def test_cell_scenario_carries_the_cell() -> None:
    sc = cell_scenario("urban", "fog", "day", seed=123, duration=20.0)
    assert sc.name == "odd-urban-fog-day" and sc.network == "grid"
    assert sc.seed == 123 and sc.duration == 20.0 and sc.faults == ()
    assert [c.name for c in sc.channels] == ["lidar", "camera"]
    assert sc.channels[1].range_m == 35.0
    hw = cell_scenario("highway", "clear", "day", seed=5)
    assert hw.network == "highway" and hw.channels == CHANNELS
    # the scripted vehicles differ from seed to seed
    assert hw.vehicles != cell_scenario("highway", "clear", "day", seed=6).vehicles


def test_header_meta_without_sumo() -> None:
    sc = cell_scenario("highway", "rain", "night", seed=9)
    head = odd_header(sc, "highway", "rain", "night", 2)["header"]
    meta = head["meta"]
    assert head["channels"] == ["lidar", "camera"]
    assert meta["scenario"] == "odd-highway-rain-night" and meta["seed"] == 9
    assert meta["agent"] == "stack-A" and meta["run"] == 2
    assert meta["odd"] == odd_meta("highway", "rain", "night")
    assert meta["odd_truth"] == odd_truth("rain", "night")
    assert GAP_CAP == situation.GAP_CAP


# --- the bundled grid -----------------------------------------------------------------------


def test_index_matches_the_files() -> None:
    files = sorted(p.name for p in DATA.glob("*.jsonl.gz"))
    assert sorted(e["stream"] for e in DRIVES) == files
    assert INDEX["runs"] == DEFAULT_RUNS and len(DRIVES) == 12 * INDEX["runs"]
    per_cell: dict[str, int] = {}
    for e in DRIVES:
        road = e["odd"]["road.type"]
        weather, light = e["odd"]["environment.weather"], e["odd"]["environment.light"]
        assert e["scenario"] == cell_name(road, weather, light)
        assert e["stream"] == f"{e['scenario']}-r{e['run']}.jsonl.gz"
        assert e["degraded"] == is_degraded(weather, light)
        assert e["seed"] == run_seed(INDEX["seed"], cells().index((road, weather, light)),
                                     e["run"])
        assert e["bytes"] == (DATA / e["stream"]).stat().st_size
        per_cell[e["scenario"]] = per_cell.get(e["scenario"], 0) + 1
    assert sorted(per_cell) == sorted(cell_name(*c) for c in cells())
    assert set(per_cell.values()) == {INDEX["runs"]}


def test_bundle_is_small() -> None:
    assert sum(p.stat().st_size for p in DATA.iterdir()) <= 8_000_000


@pytest.mark.parametrize("entry", DRIVES, ids=[e["stream"] for e in DRIVES])
def test_bundled_drive(entry: dict) -> None:
    rows = _rows(DATA / entry["stream"])
    head = rows[0]["header"]
    meta = head["meta"]
    road = entry["odd"]["road.type"]
    weather, light = entry["odd"]["environment.weather"], entry["odd"]["environment.light"]
    assert head["channels"] == ["lidar", "camera"]
    assert meta["scenario"] == entry["scenario"] and meta["seed"] == entry["seed"]
    assert meta["agent"] == "stack-A" and meta["run"] == entry["run"]
    assert meta["odd"] == odd_meta(road, weather, light)
    assert meta["odd_truth"]["degraded"] is entry["degraded"]
    assert meta["odd_truth"] == json.loads(json.dumps(odd_truth(weather, light)))
    assert head["coverage"]["camera"]["range_m"] == (35.0 if weather == "fog" else 70.0)
    frames = rows[1:]
    assert len(frames) == entry["frames"]
    for f in frames:
        assert set(f["signals"]) == SIGNALS
    sig = {k: np.array([f["signals"][k] for f in frames], dtype=float) for k in SIGNALS}
    assert not any(np.isnan(v).any() for v in sig.values())
    assert np.all((sig["lane_width"] > 2.5) & (sig["lane_width"] < 4.5))
    assert np.all(np.abs(sig["lane_offset"]) < sig["lane_width"] / 2)
    assert np.all((sig["gt_lead_gap"] >= 0.0) & (sig["gt_lead_gap"] <= GAP_CAP))
    assert np.all(sig["gt_lead_speed"][sig["gt_lead_gap"] >= GAP_CAP] == 0.0)
    # a leader ahead within 60 m most of the time
    assert np.mean(sig["gt_lead_gap"] < 60.0) > 0.5


def test_bundled_drives_read_without_defects() -> None:
    for e in DRIVES[:: INDEX["runs"]]:  # one drive per cell
        reader = read_stream(str(DATA / e["stream"]), channels=["lidar", "camera"], period=0.1)
        assert sum(1 for _ in reader) == e["frames"]
        assert reader.defects == [] and reader.header is not None
        assert reader.header.meta["odd"]["environment"]["weather"] == \
            e["odd"]["environment.weather"]
