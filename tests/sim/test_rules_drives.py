"""The traffic-rule drives (examples/sim/rules_drives.py) and their bundle
(examples/data/rules). No SUMO needed, except for the regeneration check at the end."""

from __future__ import annotations

import gzip
import json
import math
from itertools import pairwise
from pathlib import Path

import pytest

from casewatch.monitor.world import KEYS, parse_world
from examples.sim.rules_drives import AGENTS, RULES, SCENARIOS

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "examples" / "data" / "rules"
INDEX = json.loads((DATA / "index.json").read_text())
DRIVES = INDEX["drives"]
LIGHT_STATES = {"red", "yellow", "green", "off"}
MARKINGS = {"broken", "solid", "double_solid"}
INDICATOR = {"left", "right", "off"}
PARTIES = {"vehicle", "pedestrian", "two_wheeler", "object"}
WORLD_KEYS = set(KEYS)  # what casewatch's reader knows (monitor/world.py)


def _rows(path: Path) -> list[dict]:
    with gzip.open(path, "rt") as fh:
        return [json.loads(line) for line in fh if line.strip()]


def _labels(name: str) -> list[dict]:
    return [json.loads(x) for x in (DATA / name).read_text().splitlines() if x.strip()]


def _num(v: object) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)


def test_index_matches_files() -> None:
    assert len(DRIVES) == len(AGENTS) * len(SCENARIOS)
    pairs = {(d["scenario"], d["agent"]) for d in DRIVES}
    assert pairs == {(s.name, a.name) for s in SCENARIOS for a in AGENTS}
    listed = {d["stream"] for d in DRIVES} | {d["labels"] for d in DRIVES}
    listed |= {"index.json", "rules.net.xml"}
    assert {p.name for p in DATA.iterdir()} == listed
    for d in DRIVES:
        assert (DATA / d["stream"]).stat().st_size == d["bytes"]
        counts = {r: 0 for r in RULES}
        for lab in _labels(d["labels"]):
            counts[lab["hazard"]] += 1
        assert counts == d["label_counts"]
    assert INDEX["label_totals"] == {r: sum(d["label_counts"][r] for d in DRIVES) for r in RULES}
    assert sum(d["bytes"] for d in DRIVES) < 6e6


def test_every_rule_has_two_labels() -> None:
    for rule in RULES:
        assert INDEX["label_totals"][rule] >= 2, rule


def test_careful_driver_breaks_no_rule_except_being_hit() -> None:
    for d in DRIVES:
        if d["agent"] == "careful":
            broken = {r for r, n in d["label_counts"].items() if n}
            assert broken <= {"CSn_collision_victim"}, (d["stream"], broken)


@pytest.mark.parametrize("drive", DRIVES, ids=lambda d: d["stream"])
def test_header_and_world(drive: dict) -> None:
    rows = _rows(DATA / drive["stream"])
    meta = rows[0]["header"]["meta"]
    assert meta["agent"] == drive["agent"] and meta["scenario"] == drive["scenario"]
    assert isinstance(meta["seed"], int)
    env = meta["odd"]["environment"]
    assert env["weather"] in {"clear", "fog", "rain"} and env["light"] in {"day", "night"}
    frames = rows[1:]
    assert len(frames) == drive["frames"]
    for f in frames:
        w = f["world"]
        assert set(w) <= WORLD_KEYS
        parse_world(w)  # casewatch reads it (raises on anything malformed)
        assert _num(w["speed"]) and w["speed"] >= 0
        assert _num(w["speed_limit"]) and w["speed_limit"] > 0
        if "traffic_light" in w:
            assert w["traffic_light"]["state"] in LIGHT_STATES
            assert _num(w["traffic_light"]["distance"])
            assert w["traffic_light"]["distance"] <= 100.0
        if "stop_sign" in w:
            assert _num(w["stop_sign"]["distance"]) and w["stop_sign"]["distance"] <= 100.0
        assert w.get("marking") is None or w["marking"] in MARKINGS
        # the side of every marking crossing, and none without one
        assert w.get("crossing") == (None if w.get("marking") is None else w["crossing"])
        assert w.get("marking") is None or w["crossing"] in {"left", "right"}
        assert w["indicator"] in INDICATOR
        assert set(w["lights"]) == {"low_beam", "fog"}
        assert all(isinstance(v, bool) for v in w["lights"].values())
        for c in w["collisions"]:
            assert set(c) == {"id", "with", "ego_at_fault"}
            assert isinstance(c["id"], str) and c["with"] in PARTIES
            assert isinstance(c["ego_at_fault"], bool)
        r = w["route"]
        assert _num(r["progress"]) and _num(r["length"]) and r["length"] > 0
        assert 0 <= r["progress"] <= r["length"] + 1e-6
        assert set(f["channels"]) == {"lidar", "camera"}


@pytest.mark.parametrize("drive", DRIVES, ids=lambda d: d["stream"])
def test_labels_on_grid_within_drive(drive: dict) -> None:
    for lab in _labels(drive["labels"]):
        assert lab["hazard"] in RULES
        for key in ("start", "end"):
            assert abs(lab[key] * 10 - round(lab[key] * 10)) < 1e-6
            assert 0.0 <= lab[key] <= drive["duration"] + 1e-9
        assert lab["start"] <= lab["end"]


def test_near_misses_are_in_the_bundle() -> None:
    """A light turning red right after the ego crossed, a stop with standstill, a broken-line
    change with the indicator pointing its way, the ego hit by another: present and not
    labelled."""
    red_after = stop_ok = signalled = victim = 0
    for d in DRIVES:
        frames = _rows(DATA / d["stream"])[1:]
        for a, b in pairwise(frames):
            ta, tb = a["world"].get("traffic_light"), b["world"].get("traffic_light")
            if (
                ta
                and tb
                and ta["distance"] <= 0 < ta["distance"] + 2.5
                and ta["state"] == "yellow"
                and tb["state"] == "red"
            ):
                red_after += 1
            if (
                a["world"].get("marking") == "broken"
                and a["world"]["indicator"] == a["world"]["crossing"]
            ):
                signalled += 1
        for f in frames:
            s = f["world"].get("stop_sign")
            if s and 0 < s["distance"] <= 5 and f["world"]["speed"] < 0.1:
                stop_ok += 1
        victim += any(not c["ego_at_fault"] for f in frames for c in f["world"]["collisions"])
    assert red_after >= 2 and stop_ok >= 1 and signalled >= 1 and victim >= 2


def test_one_drive_regenerates_identically(tmp_path: Path) -> None:
    pytest.importorskip("libsumo", reason="SUMO not installed: pip install -e .[sim]")
    pytest.importorskip("sumolib", reason="SUMO not installed: pip install -e .[sim]")
    from examples.sim.rules_drives import main

    assert (
        main(["--seed", str(INDEX["seed"]), "--out", str(tmp_path), "--only", "night-fog-sloppy"])
        == 0
    )
    for name in ("night-fog-sloppy.jsonl.gz", "night-fog-sloppy.labels.jsonl"):
        assert (tmp_path / name).read_bytes() == (DATA / name).read_bytes()
