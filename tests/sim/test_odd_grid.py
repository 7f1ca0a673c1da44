"""The ODD grid generator (examples/sim/odd_grid.py) and its bundled drives
(examples/data/odd-grid). No SUMO needed."""

from __future__ import annotations

import gzip
import json
from pathlib import Path

import numpy as np
import pytest

from casewatch.monitor import situation
from casewatch.monitor.reader import read_stream
from examples.sim.odd_grid import (
    ATTEMPTS,
    CHANNELS,
    CONDITION_EFFECTS,
    DEFAULT_RUNS,
    GAP_CAP,
    GRID_CAMERA,
    GRID_LIDAR,
    LEVEL_DRAW,
    ChannelEffect,
    apply_effect,
    cell_name,
    cell_scenario,
    cells,
    draw_intensity,
    effects,
    is_degraded,
    level_of,
    odd_header,
    odd_meta,
    odd_truth,
    run_seed,
)

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "examples" / "data" / "odd-grid"
INDEX = json.loads((DATA / "index.json").read_text())
DRIVES = INDEX["drives"]
SIGNALS = {"lane_offset", "lane_width", "gt_lead_gap", "gt_lead_speed"}


def _rows(path: Path) -> list[dict]:
    with gzip.open(path, "rt") as fh:
        return [json.loads(line) for line in fh if line.strip()]


# --- the condition -> effect table ------------------------------------------------------------

#: The cells the generator degrades (on purpose: docs/odd-grid.md)
DEGRADED_CELLS = {("rain", "medium", "night")} | {
    (w, lv, li)
    for w, lv in (("rain", "heavy"), ("fog", "medium"), ("fog", "heavy"))
    for li in ("day", "sunset", "night")
}


def test_a_clear_day_changes_nothing() -> None:
    assert effects("cloudy", 0.0, "day") == {"lidar": ChannelEffect(), "camera": ChannelEffect()}
    assert apply_effect(GRID_CAMERA, ChannelEffect()) == GRID_CAMERA


def test_effects_by_hand() -> None:
    """Ramps interpolate linearly between their anchors; factors multiply (own entries, then
    the interaction), the shorter range cap wins."""
    # rain 50: camera noise between (40, 2.0) and (60, 2.5), miss 1 + 2 * 0.5; lidar 1 + 0.3 *
    # 0.5 and 1 + 0.5 * 0.5
    assert effects("rain", 50.0, "day") == {
        "camera": ChannelEffect(2.25, 2.0, None),
        "lidar": ChannelEffect(1.15, 1.25, None),
    }
    # x night (1.8, 1.5) x rain+night at 50 (2.8 + 0.2 * 10 / 60 = 2.833; 4.0)
    rn = effects("rain", 50.0, "night")["camera"]
    assert (rn.noise, rn.miss, rn.range_m) == pytest.approx(
        (2.25 * 1.8 * 2.833, 12.0, None), abs=1e-4
    )
    assert effects("rain", 50.0, "night")["lidar"] == ChannelEffect(1.15, 1.25, None)
    # fog 90: camera noise between (80, 14) and (100, 18), miss 4 + 2 * 50 / 60, range between
    # (80, 25) and (100, 20); lidar 1 + 0.6 * 0.9, 1 + 0.5 * 0.9, 200 - 130 * 0.9
    fog = effects("fog", 90.0, "day")
    assert (fog["camera"].noise, fog["camera"].miss, fog["camera"].range_m) == pytest.approx(
        (16.0, 5.667, 22.5)
    )
    assert (fog["lidar"].noise, fog["lidar"].miss, fog["lidar"].range_m) == pytest.approx(
        (1.54, 1.45, 83.0)
    )
    # light fog: a cap beyond the camera's own 70 m
    assert effects("fog", 10.0, "day")["camera"] == ChannelEffect(1.4, 1.2, 148.0)
    # cloud cover: 1 + 0.3 * 0.5; at sunset x 1.4 (miss 1.2)
    assert effects("cloudy", 50.0, "sunset")["camera"] == ChannelEffect(1.61, 1.2, None)
    assert effects("cloudy", 50.0, "night")["lidar"] == ChannelEffect()
    assert ChannelEffect(range_m=50.0).then(ChannelEffect(range_m=35.0)).range_m == 35.0


def test_table_names_only_known_conditions_and_channels() -> None:
    names = {c.name for c in CHANNELS}
    assert names == {"lidar", "camera"}
    for key, per_channel in CONDITION_EFFECTS.items():
        for part in key.split("+"):
            assert part in {"cloudy", "rain", "fog", "day", "sunset", "night"}, key
        assert set(per_channel) <= names, key
    with pytest.raises(ValueError):
        effects("snow", 0.0, "day")
    with pytest.raises(ValueError):
        effects("rain", 101.0, "day")


def test_the_studys_bins() -> None:
    assert [level_of(x) for x in (0.0, 30.0, 30.1, 70.0, 70.1, 100.0)] == [
        "light",
        "light",
        "medium",
        "medium",
        "heavy",
        "heavy",
    ]
    for level, (lo, hi) in LEVEL_DRAW.items():
        assert level_of(lo) == level_of(hi) == level
        drawn = draw_intensity(level, 123)
        assert lo <= drawn <= hi and drawn == draw_intensity(level, 123)


def test_applied_effect_changes_noise_miss_and_range() -> None:
    eff = effects("fog", 50.0, "day")  # camera noise 9, miss 4 + 2 * 10 / 60, range 37.5
    fog = apply_effect(GRID_CAMERA, eff["camera"])
    assert fog.range_m == 37.5 and GRID_CAMERA.range_m == 70.0
    assert fog.pos_sigma == pytest.approx(9.0 * GRID_CAMERA.pos_sigma)
    assert fog.pos_white == pytest.approx(9.0 * GRID_CAMERA.pos_white)
    assert fog.p_miss == pytest.approx(4.333 * GRID_CAMERA.p_miss)
    assert fog.coverage() == {"fov_deg": 120.0, "range_m": 37.5}
    lidar = apply_effect(GRID_LIDAR, eff["lidar"])
    assert lidar.range_m == 80.0 and lidar.fov_deg == 360.0  # 135 m cap, beyond its 80 m
    assert apply_effect(GRID_LIDAR, ChannelEffect(miss=1e6)).p_miss == 0.5


def test_degraded_cells() -> None:
    assert len(cells()) == 27
    for w, lv, li in cells():
        lo, hi = LEVEL_DRAW[lv]
        # the whole draw range of a level is on one side of the thresholds
        assert (
            is_degraded(w, lo, li) == is_degraded(w, hi, li) == ((w, lv, li) in DEGRADED_CELLS)
        ), (w, lv, li)
    # the thresholds: noise 6, range 45 m
    assert not is_degraded("rain", 60.0, "day")  # noise 2.5
    assert is_degraded("rain", 80.0, "day")  # noise 9
    assert is_degraded("fog", 40.0, "day")  # range 40 m (noise 8)
    # the camera is hit much harder in every degraded cell than in any other
    worst_ok = max(
        effects(w, LEVEL_DRAW[lv][1], li)["camera"].noise
        for w, lv, li in cells()
        if (w, lv, li) not in DEGRADED_CELLS
    )
    best_bad = min(
        effects(w, LEVEL_DRAW[lv][0], li)["camera"].noise
        for w, lv, li in cells()
        if (w, lv, li) in DEGRADED_CELLS
    )
    assert best_bad >= 2.0 * worst_ok


# --- the layered meta, the seeds, the scenarios ---------------------------------------------


def test_odd_meta_for_a_drive() -> None:
    assert odd_meta("fog", 83.5, "sunset") == {
        "road": {"type": "highway", "lanes": 3},
        "infrastructure": {"markings": "visible"},
        "temporary": {"roadworks": False},
        "traffic": {"density": "medium"},
        "environment": {"weather": "fog", "intensity": 83.5, "light": "sunset"},
        "connectivity": {"v2x": "none"},
    }
    with pytest.raises(ValueError):
        odd_meta("clear", 0.0, "day")


def test_odd_truth_carries_the_applied_effects() -> None:
    truth = odd_truth("rain", 50.0, "night")
    assert truth["degraded"] is True and truth["degraded_channels"] == ["camera"]
    assert truth["channel_effects"]["camera"] == pytest.approx(
        {"noise": 11.4737, "miss": 12.0, "range_m": None}
    )
    assert odd_truth("rain", 50.0, "day")["degraded"] is False
    assert odd_truth("rain", 50.0, "day")["degraded_channels"] == []


def test_run_seeds_are_deterministic_and_distinct() -> None:
    seeds = {run_seed(1, c, r, a) for c in range(27) for r in range(2) for a in range(ATTEMPTS)}
    assert len(seeds) == 27 * 2 * ATTEMPTS
    assert run_seed(1, 3, 1) == run_seed(1, 3, 1, 0) != run_seed(2, 3, 1)
    assert all(0 <= s < 2**31 for s in seeds)


def test_cell_scenario_carries_the_cell() -> None:
    sc, intensity = cell_scenario("fog", "medium", "day", seed=123, duration=20.0)
    assert sc.name == "odd-fog-medium-day" and sc.network == "highway"
    assert sc.seed == 123 and sc.duration == 20.0 and sc.faults == ()
    assert intensity == draw_intensity("medium", 123) and 40.0 <= intensity <= 60.0
    assert [c.name for c in sc.channels] == ["lidar", "camera"]
    assert sc.channels[1].range_m == effects("fog", intensity, "day")["camera"].range_m
    assert sc.channels[1].range_m <= 40.0
    hw, _ = cell_scenario("cloudy", "light", "day", seed=5)
    assert hw.channels[0] == GRID_LIDAR and hw.channels[1].range_m == 70.0
    # the scripted vehicles differ from seed to seed
    assert hw.vehicles != cell_scenario("cloudy", "light", "day", seed=6)[0].vehicles


def test_header_meta_without_sumo() -> None:
    sc, intensity = cell_scenario("rain", "medium", "night", seed=9)
    head = odd_header(sc, "rain", intensity, "night", 1)["header"]
    meta = head["meta"]
    assert head["channels"] == ["lidar", "camera"]
    assert meta["scenario"] == "odd-rain-medium-night" and meta["seed"] == 9
    assert meta["agent"] == "stack-A" and meta["run"] == 1
    assert meta["odd"] == odd_meta("rain", intensity, "night")
    assert meta["odd_truth"] == odd_truth("rain", intensity, "night")
    assert GAP_CAP == situation.GAP_CAP


# --- the bundled grid -----------------------------------------------------------------------


def _conditions(e: dict) -> tuple[str, float, str]:
    odd = e["odd"]
    return odd["environment.weather"], odd["environment.intensity"], odd["environment.light"]


def test_index_matches_the_files() -> None:
    files = sorted(p.name for p in DATA.glob("*.jsonl.gz"))
    assert sorted(e["stream"] for e in DRIVES) == files
    assert INDEX["runs"] == DEFAULT_RUNS and len(DRIVES) == 27 * INDEX["runs"]
    per_cell: dict[str, int] = {}
    for e in DRIVES:
        weather, intensity, light = _conditions(e)
        level = level_of(intensity)
        assert e["odd"]["road.type"] == "highway" and e["level"] == level
        assert LEVEL_DRAW[level][0] <= intensity <= LEVEL_DRAW[level][1]
        assert e["scenario"] == cell_name(weather, level, light)
        assert e["stream"] == f"{e['scenario']}-r{e['run']}.jsonl.gz"
        assert (
            e["degraded"]
            == is_degraded(weather, intensity, light)
            == ((weather, level, light) in DEGRADED_CELLS)
        )
        ci = cells().index((weather, level, light))
        assert e["seed"] in {run_seed(INDEX["seed"], ci, e["run"], a) for a in range(ATTEMPTS)}
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
    weather, intensity, light = _conditions(entry)
    assert head["channels"] == ["lidar", "camera"]
    assert meta["scenario"] == entry["scenario"] and meta["seed"] == entry["seed"]
    assert meta["agent"] == "stack-A" and meta["run"] == entry["run"]
    assert meta["odd"] == odd_meta(weather, intensity, light)
    assert meta["odd_truth"]["degraded"] is entry["degraded"]
    assert meta["odd_truth"] == json.loads(json.dumps(odd_truth(weather, intensity, light)))
    cap = effects(weather, intensity, light)["camera"].range_m
    assert head["coverage"]["camera"]["range_m"] == min(70.0, cap or 70.0)
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
        assert (
            reader.header.meta["odd"]["environment"]["weather"] == e["odd"]["environment.weather"]
        )


def test_one_drive_regenerates_identically(tmp_path: Path) -> None:
    pytest.importorskip("libsumo", reason="SUMO not installed: pip install -e .[sim]")
    from examples.sim.odd_grid import write_drive

    (entry,) = [e for e in DRIVES if e["stream"] == "odd-rain-medium-night-r1.jsonl.gz"]
    weather, _, light = _conditions(entry)
    again = write_drive(
        weather,
        entry["level"],
        light,
        entry["run"],
        entry["seed"],
        INDEX["duration"],
        tmp_path,
        tmp_path / "work",
    )
    assert again == entry
    assert (tmp_path / entry["stream"]).read_bytes() == (DATA / entry["stream"]).read_bytes()
