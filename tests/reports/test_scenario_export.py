"""OpenSCENARIO export of hazard events: every file valid against the 1.2 XSD and the ASAM
checker, positions equal to the stream's within 1 cm, windows clipped to the stream, an event
with nobody near the ego an ego-only file, and every refusal of the whole export an exit 2."""

from __future__ import annotations

import json
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from casewatch import api
from casewatch.cli import main
from casewatch.monitor.reader import read_stream
from tests.reports.xosc_checks import (
    assert_replays_as_recorded,
    assert_valid_openscenario,
    replay_checks,
)

REPO = Path(__file__).resolve().parents[2]
STREAM = REPO / "examples" / "data" / "highway-tailgating.jsonl.gz"


@pytest.fixture(scope="module")
def exported(tmp_path_factory) -> tuple[Path, Path]:
    run = tmp_path_factory.mktemp("run")
    api.run(REPO / "examples" / "reference-case.yaml", STREAM, out_dir=run, formats=())
    out = tmp_path_factory.mktemp("xosc")
    assert main(["export-scenarios", str(run), str(STREAM), "-o", str(out)]) == 0
    return run, out


def test_one_file_per_hazard_event_traced_back(exported):
    run, out = exported
    result = json.loads((run / "result.json").read_text())
    events = [e for e in result["episodes"] if e["kind"] == "hazard"]
    catalogue = json.loads((out / "scenarios.json").read_text())["scenarios"]
    assert [(c["node"], c["start"]) for c in catalogue] == [
        (e["node_id"], e["start"]) for e in events
    ]
    for c in catalogue:
        assert (out / c["file"]).is_file() and c["entities"][0] == "ego" and len(c["entities"]) > 1
        assert c["ego_only"] is False and c["radius"] == 30.0
        assert c["trace"][0][0] == c["node"] and c["trace"][0][-1] == "G1"
        assert c["stream_digest"] == result["stream"]["digest"]
        header = ET.parse(out / c["file"]).getroot().find("FileHeader")
        assert header.get("revMajor") == "1" and header.get("revMinor") == "2"
        assert "no road network attached" in header.get("description")


def test_every_file_passes_the_xsd_and_the_asam_checker(exported):
    _, out = exported
    files = sorted(out.glob("*.xosc"))
    assert len(files) == 4
    for path in files:
        assert_valid_openscenario(path)


def test_positions_round_trip_within_a_centimetre(exported):
    _, out = exported
    entry = json.loads((out / "scenarios.json").read_text())["scenarios"][0]
    t0 = entry["window"][0]
    root = ET.parse(out / entry["file"]).getroot()
    vertices = {}
    for group in root.iter("ManeuverGroup"):
        actor = group.find("Actors/EntityRef").get("entityRef")
        vertices[actor] = [
            (
                float(v.get("time")),
                float(v.find("Position/WorldPosition").get("x")),
                float(v.find("Position/WorldPosition").get("y")),
            )
            for v in group.iter("Vertex")
        ]
    truth = {}
    for frame in read_stream(STREAM):
        state = frame.channels.get(entry["channel"])
        if state is None or not t0 - 1e-9 <= frame.t <= entry["window"][1] + 1e-9:
            continue
        truth[("ego", round(frame.t - t0, 6))] = (state.ego.x, state.ego.y)
        for k, oid in enumerate(state.objects.ids):
            truth[(f"obj_{oid}", round(frame.t - t0, 6))] = tuple(state.objects.pos[k])
    assert set(vertices) == set(entry["entities"])
    compared = 0
    for actor, points in vertices.items():
        for t, x, y in points:
            tx, ty = truth[(actor, round(t, 6))]
            assert abs(x - tx) <= 0.01 and abs(y - ty) <= 0.01, (actor, t)
            compared += 1
    assert compared > 100


def test_every_file_replays_as_recorded(exported):
    """Sampled as the standard times a FollowTrajectoryAction, entities exist exactly while
    observed and no two overlap where the stream's footprints did not (test_scenario_replay)."""
    _, out = exported
    assert_replays_as_recorded(replay_checks(STREAM, out), samples=1000)


def test_windows_are_clipped_to_the_stream(exported):
    _, out = exported
    catalogue = json.loads((out / "scenarios.json").read_text())["scenarios"]
    # event 4 runs to 119.6 s; 2 s of lead-out would pass the drive's last frame at 120 s
    assert (catalogue[-1]["start"], catalogue[-1]["end"]) == (105.0, 119.6)
    assert catalogue[-1]["window"] == [102.0, 120.0]
    stop = (
        ET.parse(out / catalogue[-1]["file"])
        .getroot()
        .find(".//StopTrigger//SimulationTimeCondition")
    )
    assert stop.get("value") == "18.0"
    assert catalogue[0]["window"] == [15.6, 37.9]


def test_refusals_exit_2(exported, tmp_path, capsys):
    run, _ = exported
    out = str(tmp_path / "x")
    assert main(["export-scenarios", str(run), str(STREAM), "-o", out, "--event", "99"]) == 2
    assert "no hazard event 99" in capsys.readouterr().err
    other = tmp_path / "other.jsonl.gz"
    shutil.copy(REPO / "examples" / "data" / "urban-grid.jsonl.gz", other)
    assert main(["export-scenarios", str(run), str(other), "-o", out]) == 2
    assert "not the stream this run judged" in capsys.readouterr().err
    assert main(["export-scenarios", str(run), str(STREAM), "-o", out, "--channel", "cam"]) == 2
    assert "'cam' is not one of the run's channels" in capsys.readouterr().err
    assert main(["export-scenarios", str(run), str(STREAM), "-o", out, "--radius", "-1"]) == 2
    assert "--radius must be a number >= 0" in capsys.readouterr().err
    assert not (tmp_path / "x").exists()  # a refusal writes nothing


def test_nobody_within_the_radius_is_an_ego_only_file_not_a_refusal(exported, tmp_path, capsys):
    run, _ = exported
    out = tmp_path / "ego-only"
    assert (
        main(["export-scenarios", str(run), str(STREAM), "-o", str(out), "--radius", "0.001"]) == 0
    )
    assert "ego only (nothing within 0.001 m)" in capsys.readouterr().out
    catalogue = json.loads((out / "scenarios.json").read_text())["scenarios"]
    assert len(catalogue) == 4
    for c in catalogue:
        assert c["ego_only"] is True and c["entities"] == ["ego"] and c["objects"] == {}
        assert c["nearest_object_m"] > 0.001
        root = ET.parse(out / c["file"]).getroot()
        assert [o.get("name") for o in root.iter("ScenarioObject")] == ["ego"]
        assert len(list(root.iter("FollowTrajectoryAction"))) == 1


def test_an_opendrive_file_is_referenced_relative_to_the_scenario(
    exported, tmp_path, monkeypatch, capsys
):
    run, _ = exported
    road = tmp_path / "roads" / "highway.xodr"
    road.parent.mkdir()
    road.write_text("<OpenDRIVE/>\n")
    out = tmp_path / "suite" / "with-road"
    monkeypatch.chdir(tmp_path / "roads")  # typed relative to wherever the user stands
    args = ["export-scenarios", str(run), str(STREAM), "-o", str(out), "--event", "1"]
    assert main([*args, "--opendrive", "highway.xodr"]) == 0
    xosc_file = next(out.glob("*.xosc"))
    root = ET.parse(xosc_file).getroot()
    written = root.find("RoadNetwork/LogicFile").get("filepath")
    assert written == "../../roads/highway.xodr"  # from the .xosc's folder, not the cwd
    assert (xosc_file.parent / written).resolve() == road.resolve()
    assert "no road network" not in root.find("FileHeader").get("description")
    catalogue = json.loads((out / "scenarios.json").read_text())["scenarios"]
    assert catalogue[0]["road_network"] == written
    capsys.readouterr()
    assert main([*args, "--opendrive", "missing.xodr"]) == 2
    err = capsys.readouterr().err
    assert "missing.xodr: no such OpenDRIVE file" in err and str(tmp_path / "roads") in err
