"""`casewatch convert` and `casewatch run` on ROS 2 bags, from the command line."""

from __future__ import annotations

import gzip
import itertools
import json
from pathlib import Path

import pytest

from casewatch.cli import main
from casewatch.monitor.bags.mapping import TopicMapping
from casewatch.monitor.bags.writer import default_mapping, write_bag
from casewatch.monitor.encode import frame_to_dict, header_to_dict
from casewatch.monitor.reader import read_stream

REPO = Path(__file__).resolve().parents[2]
CASE = REPO / "examples" / "reference-case.yaml"
DRIVE = REPO / "examples" / "data" / "highway-tailgated.jsonl.gz"


@pytest.fixture(scope="module")
def short_drive(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The first 40 s of a bundled drive (a hazard event and SPI episodes inside), with its
    header: the channels' coverage (tfuse sees 200 degrees out to 50 m) must reach the bag."""
    path = tmp_path_factory.mktemp("drive") / "short.jsonl.gz"
    reader = read_stream(DRIVE)
    frames = list(itertools.islice(reader, 400))
    with gzip.open(path, "wb") as fh:
        fh.write(json.dumps(header_to_dict(reader.header)).encode() + b"\n")
        for f in frames:
            fh.write(json.dumps(frame_to_dict(f)).encode() + b"\n")
    return path


@pytest.fixture(scope="module")
def bag(short_drive: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("bag") / "short"
    assert main(["convert", str(short_drive), "-o", str(out)]) == 0
    return out


def _formulas(result: Path) -> list[tuple]:
    """Per formula: violated and no-data ticks, worst robustness and when (the object SPIs
    depend on the channels' coverage: this tells whether it reached the bag)."""
    data = json.loads(result.read_text())
    return [
        (
            f["id"],
            f["ticks_violated"],
            f["ticks_no_data"],
            round(f["worst_robustness"], 9),
            f["t_worst"],
        )
        for f in data["formulas"]
    ]


def _episodes(result: Path) -> list[tuple]:
    data = json.loads(result.read_text())
    return [
        (e["node_id"], e["start"], e["end"], round(e["worst_robustness"], 9))
        for e in data["episodes"]
    ]


def test_convert_writes_a_bag_and_its_mapping(bag: Path, capsys) -> None:
    assert (bag / "metadata.yaml").is_file() and (bag / "short.mcap").is_file()
    mapping = bag.with_name("short.topics.yaml")
    text = mapping.read_text()
    assert "/lav/localization/kinematic_state" in text and "length: 4.6" in text
    assert "tfuse:\n    fov_deg: 200.0\n    range_m: 50.0" in text
    assert main(["convert", "--list-topics", str(bag)]) == 0
    out = capsys.readouterr().out
    assert (
        "/tfuse/perception/object_recognition/objects  "
        "autoware_perception_msgs/msg/PredictedObjects  (400 messages)" in out
    )


def test_a_bag_is_judged_like_its_stream(bag: Path, short_drive: Path, tmp_path: Path) -> None:
    topics = bag.with_name("short.topics.yaml")
    code_bag = main(
        [
            "run",
            str(CASE),
            str(bag),
            "--topics",
            str(topics),
            "-o",
            str(tmp_path / "bag"),
            "--format",
            "none",
            "--quiet",
        ]
    )
    code_stream = main(
        [
            "run",
            str(CASE),
            str(short_drive),
            "-o",
            str(tmp_path / "stream"),
            "--format",
            "none",
            "--quiet",
        ]
    )
    assert code_bag == code_stream == 1
    ours, theirs = (
        _episodes(tmp_path / "bag" / "result.json"),
        _episodes(tmp_path / "stream" / "result.json"),
    )
    assert ours == theirs and any(e[0].startswith("CSn") for e in ours)
    assert _formulas(tmp_path / "bag" / "result.json") == _formulas(
        tmp_path / "stream" / "result.json"
    )
    result = json.loads((tmp_path / "bag" / "result.json").read_text())
    assert result["stream"]["meta"]["storage"] == "mcap"
    assert result["stream"]["topics"]["/lav/localization/kinematic_state"] == {
        "missing_ticks": 0,
        "late_messages": 0,
    }
    assert len(result["stream"]["digest"]) == 64


def test_bag_to_stream_and_back_gives_the_same_frames(
    bag: Path, short_drive: Path, tmp_path: Path
) -> None:
    out = tmp_path / "back.jsonl.gz"
    topics = bag.with_name("short.topics.yaml")
    assert main(["convert", str(bag / "short.mcap"), "--topics", str(topics), "-o", str(out)]) == 0
    reader = read_stream(out, strict=True)
    back = list(reader)
    assert reader.header.meta["source"] == "rosbag2"
    original = list(read_stream(short_drive))
    assert [f.t for f in back] == [f.t for f in original]
    for a, b in zip(original, back, strict=True):
        for name in a.channels:
            ea, eb = a.channels[name].ego, b.channels[name].ego
            assert (eb.x, eb.y) == (ea.x, ea.y)
            assert eb.vx == pytest.approx(ea.vx, abs=1e-12)
        assert b.signals == a.signals


def test_the_case_can_carry_the_mapping(bag: Path, tmp_path: Path) -> None:
    """monitor.topics as a file next to the case, and written inline."""
    topics = bag.with_name("short.topics.yaml")
    text = CASE.read_text()
    as_file = tmp_path / "case-file.yaml"
    (tmp_path / "my-topics.yaml").write_text(topics.read_text())
    as_file.write_text(
        text.replace("  period: 0.1s\n", "  period: 0.1s\n  topics: my-topics.yaml\n")
    )
    inline = tmp_path / "case-inline.yaml"
    body = "".join(
        "    " + line + "\n"
        for line in topics.read_text().splitlines()
        if line and not line.startswith("#")
    )
    inline.write_text(text.replace("  period: 0.1s\n", "  period: 0.1s\n  topics:\n" + body))
    for case in (as_file, inline):
        out = tmp_path / case.stem
        assert (
            main(["run", str(case), str(bag), "-o", str(out), "--format", "none", "--quiet"]) == 1
        )
        assert json.loads((out / "result.json").read_text())["stream"]["frames_read"] == 400


def test_bags_without_a_mapping_or_with_a_bad_one_exit_2(bag: Path, tmp_path: Path, capsys) -> None:
    out = str(tmp_path / "o")
    assert main(["run", str(CASE), str(bag), "-o", out, "--quiet"]) == 2
    assert "a ROS 2 bag needs a topic mapping" in capsys.readouterr().err
    bad = tmp_path / "bad.yaml"
    bad.write_text(
        "ego: {length: 4.6, width: 1.9}\nchannels:\n  lav: {odometry: /nope, "
        "objects: /nope2}\n  tfuse: {odometry: /a, objects: /b}\n"
    )
    assert main(["run", str(CASE), str(bag), "--topics", str(bad), "-o", out, "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "topic(s) /nope, /nope2, /a, /b from" in err and "Traceback" not in err
    typo = tmp_path / "typo.yaml"
    typo.write_text("ego: {length: 4.6, width: 1.9}\nchanels: {}\n")
    assert main(["run", str(CASE), str(bag), "--topics", str(typo), "-o", out, "--quiet"]) == 2
    assert f"{typo}:1: channels: required here and missing" in capsys.readouterr().err


def test_a_folder_of_bags_and_streams_is_a_fleet(
    bag: Path, short_drive: Path, tmp_path: Path
) -> None:
    fleet = tmp_path / "logs"
    fleet.mkdir()
    (fleet / "a.jsonl.gz").write_bytes(short_drive.read_bytes())
    assert main(["convert", str(short_drive), "-o", str(fleet / "b"), "--storage", "sqlite3"]) == 0
    topics = fleet / "b.topics.yaml"
    code = main(
        [
            "run",
            str(CASE),
            str(fleet),
            "--topics",
            str(topics),
            "-o",
            str(tmp_path / "out"),
            "--format",
            "none",
            "--quiet",
        ]
    )
    assert code == 1
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    logs = {Path(log["stream"]).name: log for log in summary["per_log"]}
    assert set(logs) == {"a.jsonl.gz", "b"}
    assert logs["a.jsonl.gz"]["frames"] == logs["b"]["frames"] == 400
    assert _episodes(tmp_path / "out" / "a" / "result.json") == _episodes(
        tmp_path / "out" / "b" / "result.json"
    )
    # --resume recognises the bag folder by its digest
    assert (
        main(
            [
                "run",
                str(CASE),
                str(fleet),
                "--topics",
                str(topics),
                "-o",
                str(tmp_path / "out"),
                "--format",
                "none",
                "--quiet",
                "--resume",
            ]
        )
        == 1
    )


def test_reports_name_the_topics_behind_dropouts(tmp_path: Path) -> None:
    """tfuse silent for 5 frames: the first is bridged by the message before (100 ms old,
    under the default max_age of 150 ms), the other 4 are dropouts, traced to the topics."""
    reader = read_stream(DRIVE)
    frames = list(itertools.islice(reader, 400))
    for f in frames[50:55]:
        del f.channels["tfuse"]
    mapping = TopicMapping.model_validate(
        default_mapping(["lav", "tfuse"], [], 4.6, 1.9, reader.header.coverage)
    )
    write_bag(frames, tmp_path / "bag", mapping, "mcap")
    topics = tmp_path / "topics.json"
    topics.write_text(mapping.model_dump_json(exclude_none=True))
    code = main(
        [
            "run",
            str(CASE),
            str(tmp_path / "bag"),
            "--topics",
            str(topics),
            "-o",
            str(tmp_path / "out"),
            "--format",
            "md,html",
            "--quiet",
        ]
    )
    assert code in (0, 1)
    result = json.loads((tmp_path / "out" / "result.json").read_text())
    assert result["stream"]["dropouts"] == {"lav": 0, "tfuse": 4}
    assert result["stream"]["topics"]["/tfuse/perception/object_recognition/objects"] == {
        "missing_ticks": 4,
        "late_messages": 0,
    }
    md = (tmp_path / "out" / "report.md").read_text()
    assert "Bag topics missing or stale: `/tfuse/localization/kinematic_state` 4 ticks;" in md
    html = (tmp_path / "out" / "report.html").read_text()
    assert "<code>/tfuse/perception/object_recognition/objects</code> 4" in html


def test_hazard_events_of_a_bag_export_as_scenarios(
    bag: Path, short_drive: Path, tmp_path: Path
) -> None:
    """export-scenarios reads the bag through its mapping: the same events, windows and
    objects as from the stream (object names are the bag's UUIDs)."""
    topics = bag.with_name("short.topics.yaml")
    catalogues = []
    for source, extra in ((bag, ["--topics", str(topics)]), (short_drive, [])):
        out = tmp_path / source.name
        assert (
            main(
                [
                    "run",
                    str(CASE),
                    str(source),
                    *extra,
                    "-o",
                    str(out),
                    "--format",
                    "none",
                    "--quiet",
                    "--scenarios",
                ]
            )
            == 1
        )
        data = json.loads((out / "scenarios" / "scenarios.json").read_text())["scenarios"]
        catalogues.append(
            [(e["node"], e["start"], e["end"], e["channel"], len(e["entities"])) for e in data]
        )
    assert catalogues[0] == catalogues[1] != []
