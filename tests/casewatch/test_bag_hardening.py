"""Issue 31: damaged bags, topic mappings and `convert` arguments that used to crash (exit 3)
or never stop; each is now unusable input (exit 2) with a message naming what is wrong."""

from __future__ import annotations

import json
import struct
from pathlib import Path

import pytest

from casewatch.cli import main
from tests.evaluator.streams import write_case, write_stream


@pytest.fixture(scope="module")
def small_bag(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, Path]:
    """The small end-to-end stream as an MCAP bag: (case, bag folder, topic mapping)."""
    folder = tmp_path_factory.mktemp("bag")
    stream = write_stream(folder / "s.jsonl")
    bag = folder / "small"
    assert main(["convert", str(stream), "-o", str(bag)]) == 0
    return write_case(folder / "case.yaml"), bag, folder / "small.topics.yaml"


def run(case: Path, bag: Path, topics: Path, out: Path) -> int:
    return main(
        [
            "run",
            str(case),
            str(bag),
            "--topics",
            str(topics),
            "-o",
            str(out),
            "--format",
            "none",
            "--quiet",
        ]
    )


@pytest.mark.parametrize(
    ("edit", "expected"),
    [
        (lambda t: t.replace("  width: 1.8", "  width: [1.8"), ":5:9: CW003: YAML syntax error"),
        (lambda t: t + "ego: {length: 1, width: 1}\n", "CW005: duplicate key 'ego'"),
        (
            lambda t: t.replace("max_age: 0.1", "max_age: 0"),
            ": max_age: a message age limit must be longer than zero",
        ),
        (
            lambda t: t.replace("max_age: 0.1", "max_age: " + "9" * 401),
            ": max_age: a duration longer than a day",
        ),
    ],
)
def test_a_bad_topic_mapping_names_its_line(small_bag, tmp_path, capsys, edit, expected):
    case, bag, topics = small_bag
    bad = tmp_path / "topics.yaml"
    bad.write_text(edit(topics.read_text()))
    assert run(case, bag, bad, tmp_path / "o") == 2
    assert (
        main(["convert", str(bag), "--topics", str(bad), "-o", str(tmp_path / "f.jsonl.gz")]) == 2
    )
    err = capsys.readouterr().err
    assert err.count(f"{bad}:") == 2 and err.count(expected) == 2, err
    assert "internal error" not in err


def _damaged(data: bytes, how: str) -> bytes:
    if how == "magic-only":
        return data[:8]
    if how == "garbage-after-magic":
        return data[:8] + bytes(range(256)) * 20
    if how == "huge-record-length":  # the first record's length field
        return data[:9] + struct.pack("<Q", 2**63 - 1) + data[17:]
    raise ValueError(how)


@pytest.mark.parametrize("how", ["magic-only", "garbage-after-magic", "huge-record-length"])
def test_a_damaged_mcap_is_unusable_input_for_run_and_list_topics(small_bag, tmp_path, capsys, how):
    case, bag, topics = small_bag
    damaged = tmp_path / "d.mcap"
    damaged.write_bytes(_damaged((bag / "small.mcap").read_bytes(), how))
    assert run(case, damaged, topics, tmp_path / "o") == 2
    assert main(["convert", "--list-topics", str(damaged)]) == 2
    err = capsys.readouterr().err
    assert "the MCAP file is cut short before it names topic(s)" in err
    assert f"{damaged}: the bag is cut short or damaged before it records any topic" in err
    assert "internal error" not in err


def test_list_topics_reads_a_cut_mcap_up_to_the_cut(small_bag, tmp_path, capsys):
    _, bag, _ = small_bag
    data = (bag / "small.mcap").read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) - 200])  # the summary and the end magic are gone
    assert main(["convert", "--list-topics", str(cut)]) == 0
    captured = capsys.readouterr()
    assert "cut short or damaged; the topics and message counts up to the break" in captured.err
    listed = {line.split()[0]: line.split()[-2] for line in captured.out.splitlines()}
    assert listed["/lav/localization/kinematic_state"] == "(100"
    assert listed["/casewatch/signals/speed"] == "(100" and len(listed) == 7


def test_an_mcap_without_channels_is_not_an_empty_success(tmp_path, capsys):
    from mcap.writer import Writer

    empty = tmp_path / "empty.mcap"
    with open(empty, "wb") as fh:
        writer = Writer(fh)
        writer.start(profile="ros2", library="test")
        writer.finish()
    assert main(["convert", "--list-topics", str(empty)]) == 2
    assert "the bag holds no topic (no channel is recorded in it)" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("args", "expected"),
    [
        (
            ["--period", "-0.1"],
            "--period -0.1: expected the seconds between frames, from 0.001 to 60",
        ),
        (["--period", "nan"], "--period nan: expected"),
        (["--ego-size", "-1", "nan"], "--ego-size LENGTH -1.0: expected metres"),
        (["--ego-size", "4.5", "inf"], "--ego-size WIDTH inf: expected metres"),
    ],
)
def test_convert_refuses_numbers_out_of_range_before_writing(tmp_path, capsys, args, expected):
    stream = write_stream(tmp_path / "s.jsonl")
    out = tmp_path / "bag"
    assert main(["convert", str(stream), "-o", str(out), *args]) == 2
    assert expected in capsys.readouterr().err and not out.exists()


def test_a_convert_crash_leaves_no_folder_at_the_output_path(tmp_path, capsys, monkeypatch):
    case, stream = write_case(tmp_path / "case.yaml"), write_stream(tmp_path / "s.jsonl")
    bag = tmp_path / "bag"
    assert main(["convert", str(stream), "-o", str(bag)]) == 0
    out = tmp_path / "frames.jsonl.gz"

    def boom(*args, **kwargs):
        raise RuntimeError("forced")

    monkeypatch.setattr("casewatch.commands.convert.open_source", boom)
    topics = str(tmp_path / "bag.topics.yaml")
    assert main(["convert", str(bag), "--topics", topics, "-o", str(out)]) == 3
    assert not out.exists() and (tmp_path / "casewatch-crash.log").is_file()
    monkeypatch.undo()
    assert main(["convert", str(bag), "--topics", topics, "--case", str(case), "-o", str(out)]) == 0
    assert out.is_file()


def _retyped(
    source: Path, target: Path, old: str, new: str, definition: str, encoding: str | None = None
) -> None:
    """`source` rewritten with the message type `old` renamed `new` (and its definition
    replaced), as a recorder of another Autoware generation would have written it."""
    from mcap.reader import make_reader
    from mcap.writer import Writer

    with open(source, "rb") as fh, open(target, "wb") as out:
        writer = Writer(out)
        writer.start(profile="ros2", library="test")
        reader = make_reader(fh)
        summary = reader.get_summary()
        assert summary is not None
        schemas: dict[int, int] = {}
        for schema in summary.schemas.values():
            name, data, kind = schema.name, schema.data, schema.encoding
            if name == old:
                name, data, kind = new, definition.encode(), encoding or kind
            schemas[schema.id] = writer.register_schema(name, kind, data)
        channels = {
            c.id: writer.register_channel(c.topic, c.message_encoding, schemas[c.schema_id])
            for c in summary.channels.values()
        }
        for _schema, channel, message in reader.iter_messages():
            writer.add_message(
                channels[channel.id], message.log_time, message.data, message.publish_time
            )
        writer.finish()


@pytest.mark.parametrize(
    ("new", "expected"),
    [
        (
            "autoware_perception_msgs/msg/TrackedObjects",
            "carries autoware_perception_msgs/msg/TrackedObjects; "
            "as the objects of a channel it must carry "
            "autoware_perception_msgs/msg/PredictedObjects",
        ),
        (
            "autoware_auto_perception_msgs/msg/PredictedObjects",
            "must carry autoware_perception_msgs/msg/PredictedObjects (the older autoware_auto_* "
            "messages are not read",
        ),
    ],
)
def test_objects_of_another_type_are_named_not_dumped(small_bag, tmp_path, capsys, new, expected):
    case, bag, topics = small_bag
    other = tmp_path / "other.mcap"
    _retyped(
        bag / "small.mcap",
        other,
        "autoware_perception_msgs/msg/PredictedObjects",
        new,
        "this definition { does not parse",
    )
    assert run(case, other, topics, tmp_path / "o") == 2
    err = capsys.readouterr().err
    assert expected in err and "cannot be parsed" not in err


def test_idl_definitions_with_include_lines_are_read(small_bag, tmp_path):
    """rosbag2 writes `ros2idl` definitions with `#include` lines, which rosbags' IDL parser
    refuses: the signal topic as such a definition is read like the original."""
    case, bag, topics = small_bag
    idl = (
        "=" * 80 + '\nIDL: std_msgs/msg/Float64\n#include "std_msgs/msg/Empty.idl"\n\n'
        "module std_msgs {\n  module msg {\n    struct Float64 {\n      double data;\n"
        "    };\n  };\n};\n"
    )
    other = tmp_path / "idl.mcap"
    _retyped(
        bag / "small.mcap", other, "std_msgs/msg/Float64", "std_msgs/msg/Float64", idl, "ros2idl"
    )
    assert run(case, other, topics, tmp_path / "o") == 1  # the stream's els episode
    result = json.loads((tmp_path / "o" / "result.json").read_text())
    hazard = next(f for f in result["formulas"] if f["id"] == "CSn1")
    assert result["stream"]["defects"] == [] and hazard["ticks_evaluated"] == 100
