"""`casewatch annotate` and `run --annotate`: the MCAP read back with the mcap reader.

The small drive (tests.live.drives) judged by the small case: one SPI episode of Sn1 from 2.0
to 3.0 s (announced at 2.0 s), a data gap of Sn1 from 5.0 to 5.5 s (tfuse absent), 100 ticks.
"""

from __future__ import annotations

import json
import sqlite3
from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory

from casewatch.annotate import AnnotateError, RecordingError, annotate
from casewatch.annotate.verdicts import LOG_TOPIC, MARKER_TOPIC, STATUS_TOPIC, tick_statuses
from casewatch.cli import main
from casewatch.evaluator.result import RunResult
from tests.evaluator.streams import write_case
from tests.live.drives import FRAMES, TFUSE_ABSENT, write_rich_stream

NS = 1_000_000_000


@pytest.fixture(scope="module")
def judged(tmp_path_factory) -> tuple[Path, Path, RunResult]:
    """(run folder, stream, result) of the small drive."""
    root = tmp_path_factory.mktemp("annotate")
    case = write_case(root / "case.yaml")
    stream = write_rich_stream(root / "drive.jsonl")
    out = root / "run"
    assert main(["run", str(case), str(stream), "-o", str(out), "--format", "none"]) == 1
    result = RunResult.model_validate_json((out / "result.json").read_text())
    return out, stream, result


def read_mcap(path: Path) -> tuple[dict, dict[str, list]]:
    """(topic -> schema name, topic -> [(log_time, decoded message)])."""
    with open(path, "rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        schemas = {
            c.topic: (summary.schemas[c.schema_id].name, summary.schemas[c.schema_id].encoding)
            for c in summary.channels.values()
        }
        messages: dict[str, list] = {}
        for schema, channel, message in reader.iter_messages():
            if schema is not None and schema.encoding == "protobuf":
                decoded = DecoderFactory().decoder_for(channel.message_encoding, schema)(
                    message.data
                )
            elif channel.message_encoding == "json":
                decoded = json.loads(message.data)
            else:
                decoded = message.data
            messages.setdefault(channel.topic, []).append((message.log_time, decoded))
    return schemas, messages


def test_a_json_lines_drive_gets_its_scene_and_every_verdict_topic(judged, tmp_path):
    run, stream, _ = judged
    done = annotate(run, stream, tmp_path / "drive.mcap")
    schemas, messages = read_mcap(done.path)
    assert schemas == {
        "/casewatch/scene/lav": ("foxglove.SceneUpdate", "protobuf"),
        "/casewatch/scene/tfuse": ("foxglove.SceneUpdate", "protobuf"),
        LOG_TOPIC: ("foxglove.Log", "protobuf"),
        STATUS_TOPIC: ("casewatch.NodeStatus", "jsonschema"),
        MARKER_TOPIC: ("foxglove.SceneUpdate", "protobuf"),
    }
    assert done.copied == 0
    # one scene update per frame a channel is in: tfuse is absent 5.0-5.5 s
    assert len(messages["/casewatch/scene/lav"]) == FRAMES
    assert len(messages["/casewatch/scene/tfuse"]) == FRAMES - TFUSE_ABSENT
    t, first = messages["/casewatch/scene/lav"][0]
    assert t == 0
    ids = sorted(e.id for e in first.entities)
    assert ids == ["ego", "object-7", "object-lead", "plan", "prediction-lead"]
    by_id = {e.id: e for e in first.entities}
    assert by_id["ego"].cubes[0].size.x == pytest.approx(4.5)  # length
    assert by_id["ego"].cubes[0].size.y == pytest.approx(1.8)
    assert by_id["object-lead"].cubes[0].pose.position.x == pytest.approx(30.0)
    assert len(by_id["object-7"].lines[0].points) == 4  # the pedestrian's polygon, closed loop
    assert [(p.x, p.y) for p in by_id["plan"].lines[0].points] == [
        (0.0, 0.0),
        (1.0, 0.0),
        (2.0, 0.0),
        (3.0, 0.0),
    ]
    t, later = messages["/casewatch/scene/tfuse"][25]  # tick 25, t = 2.5 s: tfuse 2 m off
    assert t == 25 * NS // 10
    ego = next(e for e in later.entities if e.id == "ego")
    assert (ego.cubes[0].pose.position.x, ego.cubes[0].pose.position.y) == (25.0, 2.0)


def test_verdict_topics_match_result_json(judged, tmp_path):
    run, stream, result = judged
    _, messages = read_mcap(annotate(run, stream, tmp_path / "v.mcap").path)
    logs = messages[LOG_TOPIC]
    onsets = [
        json.loads(line)
        for line in (run / "events.jsonl").read_text().splitlines()
        if '"episode_open"' in line
    ]
    expected = len(onsets) + len(result.episodes) + len(result.near_misses)
    assert len(logs) == expected + len(result.data_gaps)
    assert [t for t, _ in logs] == sorted(t for t, _ in logs)
    # the hand-computed run: Sn1 announced at 2.0 s, its episode 2.0-3.0 s, a gap 5.0-5.5 s
    assert len(result.episodes) == 1 and result.episodes[0].node_id == "Sn1"
    texts = {(t, log.name, log.level): log.message for t, log in logs}
    assert (2 * NS, "Sn1", 3) in texts  # WARNING at the onset
    assert texts[(3 * NS, "Sn1", 3)].startswith("SPI EPISODE Sn1 2.0-3.0 s")
    assert texts[(5_500_000_000, "Sn1", 2)].startswith("NO DATA Sn1 5.0-5.5 s")
    for t, log in logs:
        assert log.timestamp.seconds * NS + log.timestamp.nanos == t

    status = messages[STATUS_TOPIC]
    times, columns = tick_statuses(result.status)
    assert (
        len(status)
        == sum(
            s.ticks
            for s in next(n for n in result.status if n.node_id == result.case.root_id).timeline
        )
        == FRAMES
    )
    assert [t for t, _ in status] == [round(x * NS) for x in times]
    at = {round(v["t"], 6): v for _, v in status}
    assert at[2.5]["status"]["Sn1"] == "violated" and at[2.5]["severity"]["Sn1"] == 8
    assert at[2.5]["root"] == "undermined"
    assert at[1.0]["status"]["Sn1"] == "satisfied" and at[1.0]["root"] == "satisfied"
    assert at[5.2]["status"]["Sn1"] == "no-data"
    for node in result.status:  # every tick of every timeline, as result.json has them
        assert [v["status"][node.node_id] for _, v in status] == columns[node.node_id]

    markers = messages[MARKER_TOPIC]
    placed = [e for e in result.episodes if e.x is not None]
    assert len(markers) == 1 + len(placed)  # the driven path, then one per episode
    track = markers[0][1].entities[0]
    assert track.id == "casewatch-track" and len(track.lines[0].points) == len(result.track)
    t, update = markers[1]
    marker = update.entities[0]
    assert t == 2 * NS
    assert (marker.spheres[0].pose.position.x, marker.spheres[0].pose.position.y) == (
        placed[0].x,
        placed[0].y,
    )
    assert marker.lifetime.seconds * NS + marker.lifetime.nanos == 1_100_000_000  # 2.0-3.0 s


def convert_to_bag(stream: Path, folder: Path) -> tuple[Path, Path]:
    bag = folder / "bag" / "drive"
    assert main(["convert", str(stream), "-o", str(bag)]) == 0
    return bag, folder / "bag" / "drive.topics.yaml"


def test_a_bag_is_copied_message_for_message(judged, tmp_path):
    _, stream, _ = judged
    bag, topics = convert_to_bag(stream, tmp_path)
    case = write_case(tmp_path / "case.yaml")
    run = tmp_path / "run"
    code = main(
        ["run", str(case), str(bag), "--topics", str(topics), "-o", str(run), "--format", "none"]
    )
    assert code == 1
    done = annotate(run, bag, tmp_path / "annotated.mcap")
    original_schemas, original = read_mcap(next(bag.glob("*.mcap")))
    schemas, messages = read_mcap(done.path)
    assert done.copied == sum(len(m) for m in original.values())
    for topic, items in original.items():
        assert schemas[topic] == original_schemas[topic]
        assert [(t, data) for t, data in messages[topic]] == [(t, data) for t, data in items]
    with open(done.path, "rb") as fh:
        assert make_reader(fh).get_header().profile == "ros2"
    # the bag's run counts t from its first tick: casewatch's topics sit on the bag's clock
    result = RunResult.model_validate_json((run / "result.json").read_text())
    t0 = int(result.stream.meta["t0_unix_ns"])
    assert messages[STATUS_TOPIC][0][0] == t0 + round(result.status[0].timeline[0].start * NS)


def test_refuses_another_recording_and_sqlite_bags(judged, tmp_path):
    run, stream, _ = judged
    other = write_rich_stream(tmp_path / "other.jsonl", frames=50)
    with pytest.raises(AnnotateError, match="is not the stream"):
        annotate(run, other, tmp_path / "x.mcap")
    with pytest.raises(AnnotateError, match="overwrite the recording"):
        annotate(run, stream, stream)
    db3 = tmp_path / "drive.db3"
    sqlite3.connect(db3).close()
    from casewatch.annotate.recording import mcap_files

    with pytest.raises(RecordingError, match="convert a sqlite3 bag"):
        mcap_files(db3)
    assert not (tmp_path / "x.mcap").exists() and not (tmp_path / "x.mcap.part").exists()


def test_cli_annotate_and_run_annotate(judged, tmp_path, capsys):
    run, stream, _ = judged
    assert main(["annotate", str(run), str(stream), "-o", str(tmp_path / "a.mcap")]) == 0
    assert "/casewatch/status 100" in capsys.readouterr().out
    assert main(["annotate", str(run), str(stream), "-o", str(tmp_path / "a.txt")]) == 2
    assert "MCAP file" in capsys.readouterr().err
    other = write_rich_stream(tmp_path / "other.jsonl", frames=50)
    assert main(["annotate", str(run), str(other), "-o", str(tmp_path / "b.mcap")]) == 2
    assert "is not the stream" in capsys.readouterr().err
    case = write_case(tmp_path / "case.yaml")
    out = tmp_path / "run"
    args = ["run", str(case), str(stream), "-o", str(out), "--format", "none", "--quiet"]
    assert main([*args, "--annotate", str(tmp_path / "r.mcap")]) == 1  # the run's own code
    _, messages = read_mcap(tmp_path / "r.mcap")
    assert len(messages[STATUS_TOPIC]) == FRAMES and len(messages[LOG_TOPIC]) == 3
    assert main([*args[:2], "-", *args[3:], "--annotate", str(tmp_path / "s.mcap")]) == 2
    assert "--annotate needs the recording" in capsys.readouterr().err


def test_a_bag_cut_short_is_copied_up_to_the_damage(tmp_path, capsys):
    stream = write_rich_stream(tmp_path / "long.jsonl", frames=300)  # 3 chunks of 1 MiB
    bag, topics = convert_to_bag(stream, tmp_path)
    storage = next(bag.glob("*.mcap"))
    whole_schemas, whole = read_mcap(storage)
    data = storage.read_bytes()
    storage.write_bytes(data[: len(data) * 6 // 10])  # a recorder killed mid-file
    case = write_case(tmp_path / "case.yaml")
    run = tmp_path / "run"
    args = ["run", str(case), str(bag), "--topics", str(topics), "-o", str(run), "--quiet"]
    assert main([*args, "--format", "none"]) == 1  # a damaged log is a finding
    out = tmp_path / "cut.mcap"
    assert main(["annotate", str(run), str(bag), "-o", str(out)]) == 0
    assert "damaged after" in capsys.readouterr().err
    schemas, messages = read_mcap(out)
    copied = {t: m for t, m in messages.items() if not t.startswith("/casewatch/")}
    assert 0 < sum(len(m) for m in copied.values()) < sum(len(m) for m in whole.values())
    for topic, items in copied.items():  # a prefix of each topic's messages, as recorded
        assert schemas[topic] == whole_schemas[topic]
        assert items == whole[topic][: len(items)]
    result = RunResult.model_validate_json((run / "result.json").read_text())
    root = next(n for n in result.status if n.node_id == result.case.root_id)
    assert len(messages[STATUS_TOPIC]) == sum(r.ticks for r in root.timeline)
