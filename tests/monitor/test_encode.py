"""monitor.encode writes frames back as JSON: parsing what it writes gives the same frame."""

from __future__ import annotations

import itertools
import json
import re
from pathlib import Path

import numpy as np

from casewatch.monitor.encode import frame_to_dict, header_to_dict
from casewatch.monitor.frames import Frame
from casewatch.monitor.parse import parse_frame, parse_header
from casewatch.monitor.reader import read_stream

ROOT = Path(__file__).resolve().parents[2]


def assert_same(a: Frame, b: Frame) -> None:
    assert (a.t, a.signals, set(a.channels)) == (b.t, b.signals, set(b.channels))
    for name, x in a.channels.items():
        y = b.channels[name]
        assert (x.ego.x, x.ego.y, x.ego.yaw, x.ego.vx, x.ego.vy, x.ego.half) == (
            y.ego.x,
            y.ego.y,
            y.ego.yaw,
            y.ego.vx,
            y.ego.vy,
            y.ego.half,
        )
        np.testing.assert_array_equal(x.ego.footprint, y.ego.footprint)
        np.testing.assert_array_equal(x.plan, y.plan)
        ox, oy = x.objects, y.objects
        assert (ox.ids, ox.cls) == (oy.ids, oy.cls)
        for field in ("pos", "yaw", "vel", "footprints", "pred", "pred_len", "convex", "half"):
            np.testing.assert_array_equal(getattr(ox, field), getattr(oy, field), err_msg=field)


def test_bundled_frames_survive_a_round_trip_through_json_text() -> None:
    for name in ("urban-realstack", "highway-tailgating"):
        for frame in itertools.islice(read_stream(ROOT / f"examples/data/{name}.jsonl.gz"), 150):
            text = json.dumps(frame_to_dict(frame))  # the exact text a converted stream holds
            assert_same(frame, parse_frame(json.loads(text)))


def test_the_documented_frame_with_polygons_round_trips() -> None:
    doc = (ROOT / "docs" / "streams.md").read_text()
    block = re.search(r'```json\n(\{"t": 12\.3.*?)```', doc, re.S).group(1)
    frame = parse_frame(json.loads(block))
    again = parse_frame(json.loads(json.dumps(frame_to_dict(frame))))
    assert_same(frame, again)
    pedestrian = frame_to_dict(frame)["channels"]["lav"]["objects"][1]
    assert pedestrian["polygon"] == [[0.3, 0.3], [-0.3, 0.3], [-0.3, -0.3], [0.3, -0.3]]
    assert "length" not in pedestrian


def test_header_round_trips() -> None:
    header = read_stream(ROOT / "examples/data/urban-realstack.jsonl.gz")
    next(iter(header))
    again = parse_header(json.loads(json.dumps(header_to_dict(header.header))))
    assert again.channels == header.header.channels and again.period == header.header.period
    assert again.coverage == header.header.coverage and again.meta == header.header.meta
