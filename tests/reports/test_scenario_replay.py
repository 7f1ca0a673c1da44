"""Exported scenarios replay as recorded: sampled the way OpenSCENARIO 1.2 defines
FollowTrajectoryAction timing (`xosc_replay`), every entity exists exactly while its channel
observed it, where it observed it, and no two footprints overlap where the stream's did not.

Hand-made drives with known answers first (an object first seen late where the ego was
earlier, one last seen early where the ego comes later, one that blinks out, one real contact),
then events of two bundled drives; `python -m bench.scenario_replay` sweeps every bundled event.
"""

from __future__ import annotations

import io
import json
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from casewatch import api
from casewatch.cli import main
from casewatch.evaluator.result import Episode
from casewatch.monitor.reader import read_stream
from casewatch.reports.scenario_export import EventWindow, ExportError, write_event
from casewatch.scenarios import collect
from tests.reports.xosc_checks import (
    assert_replays_as_recorded,
    assert_valid_openscenario,
    replay_checks,
)
from tests.reports.xosc_replay import (
    Replay,
    check_replay,
    overlapping,
    stream_state,
    wait_at_first_pose,
)

REPO = Path(__file__).resolve().parents[2]
DATA = REPO / "examples" / "data"


def _box(oid: str, x: float, y: float, length: float = 4.0, width: float = 2.0, cls="car"):
    return {"id": oid, "cls": cls, "x": x, "y": y, "length": length, "width": width}


def _drive() -> list[dict]:
    """31 frames, 0.1 s apart; the ego drives along y = 0 at 10 m/s from x = 0 (4 x 2 m)."""
    frames = []
    for i in range(31):
        t = round(0.1 * i, 1)
        objects = []
        if t >= 2.0:  # first seen late, where the ego was at t = 1
            objects.append(_box("late", 10.0, 0.0))
        if t <= 1.0:  # last seen early, where the ego will be at t = 2.5
            objects.append(_box("gone", 25.0, 0.0))
        if t <= 0.5 or t >= 1.5:  # beside the ego, unseen for a second
            objects.append(_box("blink", 10.0 * t, 3.0))
        if 0.5 <= t <= 0.8:  # a real contact: 0.5 m into the ego's box
            objects.append(_box("touch", 10.0 * t + 3.5, 0.0))
        ego = {"x": 10.0 * t, "y": 0.0, "yaw": 0.0, "length": 4.0, "width": 2.0}
        frames.append({"t": t, "channels": {"lav": {"ego": ego, "objects": objects}}})
    return frames


def _export(frames: list[dict], tmp: Path, radius: float = 100.0) -> tuple[dict, EventWindow]:
    tmp.mkdir(parents=True, exist_ok=True)
    text = "\n".join(json.dumps(f) for f in frames)
    episode = Episode(
        formula_id="H",
        node_id="H1",
        kind="hazard",
        start=frames[0]["t"],
        end=frames[-1]["t"],
        ticks=len(frames),
        worst_robustness=-1.0,
        t_worst=frames[0]["t"],
        trace=[],
    )
    window = EventWindow(1, episode, "lav", frames[0]["t"], frames[-1]["t"])
    collect(read_stream(io.StringIO(text), channels=["lav"], period=0.1), [window])
    return write_event(window, tmp, radius, 0.1), window


def _truth(frames: list[dict], t0: float) -> list[tuple[float, dict]]:
    text = "\n".join(json.dumps(f) for f in frames)
    return [
        (round(f.t - t0, 6), stream_state(f.channels["lav"]))
        for f in read_stream(io.StringIO(text), channels=["lav"], period=0.1)
    ]


def test_objects_exist_only_while_observed_with_known_answers(tmp_path: Path) -> None:
    frames = _drive()
    entry, _ = _export(frames, tmp_path)
    replay = Replay(tmp_path / entry["file"])
    e = replay.entities
    assert sorted(e) == ["ego", "obj_blink", "obj_gone", "obj_late", "obj_touch"]
    assert (e["obj_late"].present(1.95), e["obj_late"].present(2.0)) == (False, True)
    assert e["obj_late"].pose(2.5) == (10.0, 0.0, 0.0) and e["obj_late"].present(3.0)
    assert (e["obj_gone"].present(1.0), e["obj_gone"].present(1.0001)) == (True, False)
    assert [e["obj_blink"].present(t) for t in (0.5, 0.55, 1.45, 1.5)] == [True, False, False, True]
    assert e["obj_blink"].pose(2.05) == pytest.approx((20.5, 3.0, 0.0))
    assert e["ego"].pose(1.25) == pytest.approx((12.5, 0.0, 0.0))
    objects = entry["objects"]
    assert objects["obj_late"] | {"spans": 0} == {
        "category": "car",
        "class": "car",
        "first_seen": 2.0,
        "last_seen": 3.0,
        "spans": 0,
    }
    assert [objects[n]["spans"] for n in ("obj_blink", "obj_gone", "obj_late", "obj_touch")] == [
        2,
        1,
        1,
        1,
    ]
    # the only contact of the replay is the stream's own, at 0.5-0.8 s
    contacts = sorted(
        (round(t, 2), pair)
        for t in [i / 20 for i in range(61)]
        for pair in overlapping(replay.footprints(t))
    )
    expected = [0.5, 0.55, 0.6, 0.65, 0.7, 0.75, 0.8]
    assert contacts == [(t, ("ego", "obj_touch")) for t in expected]
    check = check_replay(tmp_path / entry["file"], _truth(frames, 0.0))
    assert check.new_contacts == [] and check.presence_errors == []
    assert check.max_position_error < 1e-9 and check.stream_contacts == 4


def test_frames_without_channel_data_are_bridged_briefly_not_blinked(tmp_path: Path) -> None:
    """A frame the channel has no data for (a dropout, or a line skipped as a defect: here a
    duplicate id) is no sighting of absence: objects move straight on through up to 5 periods
    of it, as the ego does; a longer silence takes them out of the scene."""
    frames = _drive()
    frames[22]["channels"] = {}  # t = 2.2: a dropout of lav
    twin = _box("late", 70.0, 0.0)  # t = 2.5: "late" twice, 60 m apart: the line is a defect
    frames[25]["channels"]["lav"]["objects"].append(twin)
    entry, _ = _export(frames, tmp_path / "short")
    replay = Replay(tmp_path / "short" / entry["file"])
    late = replay.entities["obj_late"]
    assert (
        entry["objects"]["obj_late"]["spans"] == 1 and entry["objects"]["obj_blink"]["spans"] == 2
    )
    assert [late.present(t) for t in (2.2, 2.5)] == [True, True]
    assert late.pose(2.5) == (10.0, 0.0, 0.0)  # never pulled 60 m away
    assert all(p.x.max() == p.x.min() == 10.0 for p in late.paths)
    assert replay.entities["obj_blink"].pose(2.2) == pytest.approx((22.0, 3.0, 0.0))
    assert replay.entities["ego"].pose(2.5) == pytest.approx((25.0, 0.0, 0.0))
    frames = _drive()
    for f in frames[21:28]:  # t = 2.1-2.7: 0.8 s between sightings, beyond 5 periods
        f["channels"] = {}
    entry, _ = _export(frames, tmp_path / "long")
    late = Replay(tmp_path / "long" / entry["file"]).entities["obj_late"]
    assert entry["objects"]["obj_late"]["spans"] == 2
    assert [late.present(t) for t in (2.0, 2.0001, 2.79, 2.8)] == [True, False, False, True]


def test_the_check_finds_the_collisions_of_objects_that_wait_at_their_first_pose(
    tmp_path: Path,
) -> None:
    """Replayed the old way (every object in the scene from the start, waiting at its first
    pose and staying at its last), the same file collides where the stream never did."""
    entry, _ = _export(_drive(), tmp_path)
    replay = wait_at_first_pose(Replay(tmp_path / entry["file"]))
    assert ("ego", "obj_late") in overlapping(replay.footprints(1.0))
    assert ("ego", "obj_gone") in overlapping(replay.footprints(2.5))


def test_an_event_with_nobody_near_is_an_ego_only_scenario(tmp_path: Path) -> None:
    entry, _ = _export(_drive(), tmp_path, radius=0.5)
    assert entry["ego_only"] is True and entry["entities"] == ["ego"]
    assert entry["nearest_object_m"] == 3.0  # blink, 3 m beside the ego's centre
    assert sorted(Replay(tmp_path / entry["file"]).entities) == ["ego"]


def test_a_window_without_a_frame_of_its_channel_cannot_be_written(tmp_path: Path) -> None:
    frames = _drive()
    for f in frames:
        f["channels"] = {}
    with pytest.raises(ExportError) as err:
        _export(frames, tmp_path)
    assert str(err.value) == (
        "hazard event 1 (H1 at 0 s): channel lav has no frame in its window 0-3 s"
    )
    assert list(tmp_path.iterdir()) == []


def test_entity_categories_from_class_and_size(tmp_path: Path) -> None:
    frames = _drive()
    for f in frames:
        f["channels"]["lav"]["objects"] = [
            _box("lorry", 40.0, 10.0, 12.2, 2.5, "car"),  # a 12 m "car": a truck
            _box("walker", 40.0, 20.0, 0.6, 0.6, "pedestrian"),
            _box("blob", 40.0, 30.0, 0.9, 1.3, "unknown"),  # pedestrian-sized
            _box("bike", 40.0, 40.0, 1.8, 0.6, "unknown"),
            _box("coach", 40.0, 50.0, 12.0, 2.5, "bus"),
        ]
    entry, _ = _export(frames, tmp_path)
    root = ET.parse(tmp_path / entry["file"]).getroot()
    kinds = {}
    for obj in root.iter("ScenarioObject"):
        vehicle, person = obj.find("Vehicle"), obj.find("Pedestrian")
        kinds[obj.get("name")] = (
            vehicle.get("vehicleCategory")
            if vehicle is not None
            else person.get("pedestrianCategory")
        )
    assert kinds == {
        "ego": "car",
        "obj_bike": "bicycle",
        "obj_blob": "pedestrian",
        "obj_coach": "bus",
        "obj_lorry": "truck",
        "obj_walker": "pedestrian",
    }
    assert {n: o["category"] for n, o in entry["objects"].items()}["obj_lorry"] == "truck"
    assert_valid_openscenario(tmp_path / entry["file"])  # pedestrians and all categories


def test_hand_made_files_are_valid_openscenario(tmp_path: Path) -> None:
    frames = _drive()
    entry, _ = _export(frames, tmp_path / "drive")  # late, early, blinking, contact
    assert_valid_openscenario(tmp_path / "drive" / entry["file"])
    entry, _ = _export(frames[:1], tmp_path / "one-frame")  # a window of one frame
    path = tmp_path / "one-frame" / entry["file"]
    assert_valid_openscenario(path)
    root = ET.parse(path).getroot()
    assert root.find("Storyboard/Story") is None  # nobody moves: Init alone
    replay = Replay(path)
    assert replay.footprints(0.0).keys() == {"ego", "obj_blink", "obj_gone"}


def test_numbers_are_written_cleanly(tmp_path: Path) -> None:
    frames = _drive()
    for i, f in enumerate(frames):  # times and positions as floating point sums make them
        f["t"] = 0.30000000000000004 + 0.1 * i
        f["channels"]["lav"]["ego"]["x"] = 0.1 * 3 * i - 1e-12
        f["channels"]["lav"]["ego"]["yaw"] = -1e-12
    entry, _ = _export(frames, tmp_path)
    text = (tmp_path / entry["file"]).read_text()
    numbers = re.findall(r'="(-?\d[\d.e+-]*)"', text)
    assert len(numbers) > 500
    assert "-0.0" not in numbers and all(re.fullmatch(r"-?\d+(\.\d{1,6})?", n) for n in numbers)
    assert 'time="0.0"' in text and 'time="3.0"' in text and 'value="3.0"' in text


# -- a bundled drive (tests/reports/test_scenario_export.py checks highway-tailgating's replays;
# `python -m bench.scenario_replay` sweeps every bundled drive) ----------------------------------


@pytest.fixture(scope="module")
def close_highway(tmp_path_factory) -> tuple[Path, Path]:
    stream = DATA / "highway-close-realstack.jsonl.gz"
    run = tmp_path_factory.mktemp("run")
    api.run(REPO / "examples" / "reference-case.yaml", stream, out_dir=run, formats=())
    out = tmp_path_factory.mktemp("xosc")
    assert main(["export-scenarios", str(run), str(stream), "-o", str(out)]) == 0
    return stream, out


def test_the_close_highway_replays_as_recorded(close_highway) -> None:
    checks = replay_checks(*close_highway)
    assert [(c["node"], c["start"], c["ego_only"]) for c, _ in checks] == [
        ("CSn2", 63.6, False),
        ("CSn2", 103.3, False),
        ("CSn1", 114.0, True),  # a localisation hazard: nobody within 30 m of the ego
    ]
    assert checks[2][0]["nearest_object_m"] == pytest.approx(31.87, abs=0.01)
    # 2n - 1 instants for the n frames of each window: 203, 78 and 70 frames (lav, no dropout)
    assert_replays_as_recorded(checks, samples=405 + 155 + 139)
    objects = [o for c, _ in checks for o in c["objects"].values()]
    late_or_blinking = [o for o in objects if o["first_seen"] > 0 or o["spans"] > 1]
    assert objects and late_or_blinking  # the add/delete logic was exercised, not bypassed
