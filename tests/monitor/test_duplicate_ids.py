"""Two objects under one id in one frame are a `duplicate-id` stream defect in every reader
(JSON Lines, ROS 2 bag), naming the frame and the id; the frame's data follows each reader's
defect convention (a stream skips the line, a bag makes that channel a dropout at that tick)."""

from __future__ import annotations

import copy
import io
import itertools
import json
from pathlib import Path

import pytest

from casewatch.monitor.bags.mapping import LoadedMapping, TopicMapping
from casewatch.monitor.bags.reader import read_bag
from casewatch.monitor.bags.writer import default_mapping, write_bag
from casewatch.monitor.parse import DEFECT_KINDS
from casewatch.monitor.reader import StreamError, read_stream

DRIVE = Path(__file__).resolve().parents[2] / "examples" / "data" / "highway-tailgating.jsonl.gz"


def _frame(t: float, objects: list[dict]) -> str:
    ego = {"x": 0.0, "y": 0.0, "yaw": 0.0, "length": 4.6, "width": 1.9}
    return json.dumps({"t": t, "channels": {"lav": {"ego": ego, "objects": objects}}})


def _box(oid, x: float) -> dict:
    return {"id": oid, "x": x, "y": 0.0, "length": 4.5, "width": 1.8}


def _poly(oid, x: float) -> dict:
    return {"id": oid, "x": x, "y": 0.0, "polygon": [[1, 1], [-1, 1], [-1, -1], [1, -1]]}


@pytest.mark.parametrize(
    "objects",
    [
        [_box("7", 20.0), _box("9", 30.0), _box("7", 80.0)],  # the compiled path
        [_box("7", 20.0), _box("9", 30.0), _poly("7", 80.0)],  # the careful path
        [_box(7, 20.0), _box("9", 30.0), _box("7", 80.0)],  # 7 and "7" are one id
    ],
)
def test_a_repeated_id_skips_the_frame_and_names_frame_and_id(objects: list[dict]) -> None:
    text = "\n".join(
        [_frame(0.0, [_box("7", 20.0)]), _frame(0.1, objects), _frame(0.2, [_box("7", 22.0)])]
    )
    reader = read_stream(io.StringIO(text))
    frames = list(reader)
    assert [f.t for f in frames] == [0.0, 0.2]  # the defective frame is skipped, as every one
    (defect,) = reader.defects
    assert defect.kind == "duplicate-id" and defect.kind in DEFECT_KINDS
    assert defect.line == 2
    assert defect.message == (
        "frame t = 0.1: channels.lav.objects[2].id: object id '7' is also "
        "channels.lav.objects[0]'s in this frame (ids are compared as strings)"
    )


def test_distinct_ids_are_no_defect_and_strict_mode_stops_at_a_repeat() -> None:
    fine = _frame(0.0, [_box("7", 20.0), _box(8, 30.0), _poly("9", 40.0)])
    reader = read_stream(io.StringIO(fine))
    assert [f.channels["lav"].objects.ids for f in reader] == [["7", "8", "9"]]
    assert reader.defects == []
    bad = _frame(0.0, [_box("a", 20.0), _box("a", 30.0)])
    with pytest.raises(StreamError, match=r":1: duplicate-id: frame t = 0: .*object id 'a'"):
        list(read_stream(io.StringIO(bad), strict=True))


def test_a_bag_with_a_repeated_uuid_drops_that_channel_at_that_tick(tmp_path: Path) -> None:
    frames = list(itertools.islice(read_stream(DRIVE), 20))
    hit = frames[5]
    objects = hit.channels["lav"].objects
    assert len(objects.ids) >= 2
    twin = copy.copy(objects)
    twin.ids = [objects.ids[0]] * len(objects.ids)  # every object under the first one's id
    hit.channels["lav"].objects = twin
    m = TopicMapping.model_validate(default_mapping(["lav", "tfuse"], [], 4.6, 1.9, period=0.1))
    write_bag(frames, tmp_path / "drive", m, "mcap")
    reader = read_bag(tmp_path / "drive", LoadedMapping(m, "m"), ["lav", "tfuse"], 0.1)
    back = list(reader)
    assert [f.t for f in back] == [f.t for f in frames]  # the frame stays, as bag frames do
    assert "lav" not in back[5].channels and "tfuse" in back[5].channels
    assert all("lav" in f.channels for i, f in enumerate(back) if i != 5)
    assert reader.dropouts == {"lav": 1, "tfuse": 0}
    (defect,) = reader.defects
    assert defect.kind == "duplicate-id" and defect.line == 6
    uuid = objects.ids[0].encode().rjust(16, b"\0").hex()  # as the writer pads it
    assert defect.message == (
        f"tick t = {hit.t:g} s, channel lav: objects[1]: object id {uuid} is also "
        "objects[0]'s in this message"
    )
