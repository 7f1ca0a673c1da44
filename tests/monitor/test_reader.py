"""The JSON Lines reader: every defect kind with its line, strict mode, gzip, stdin, dropouts."""

from __future__ import annotations

import gzip
import io
import json
import sys

import pytest

from casewatch.monitor.parse import DEFECT_KINDS
from casewatch.monitor.reader import StreamError, read_stream
from tests.monitor.builders import channel, ego, frame_dict, obj

HEADER = {
    "header": {
        "format": "casewatch-frames",
        "version": 1,
        "channels": ["lav", "tfuse"],
        "period": 0.1,
        "meta": {"scenario": "unit"},
    }
}


def good(t: float, **drop: bool) -> dict:
    chans = {
        "lav": channel(
            ego(0, 0),
            plan=[[0, 0, 0], [0.1, 1, 0]],
            objects=[obj(7, 10, 0, prediction=[[0, 10, 0], [0.1, 11, 0]])],
        ),
        "tfuse": channel(ego(0.1, 0), objects=[obj("7", 10.2, 0)]),
    }
    for name in drop:
        del chans[name]
    return frame_dict(t, chans, {"speed_limit": 13.9})


def bad(t: float, path: list, value: object) -> str:
    """A good frame with one field replaced (or deleted when value is ...)."""
    d = good(t)
    node = d
    for key in path[:-1]:
        node = node[key]
    if value is ...:
        del node[path[-1]]
    else:
        node[path[-1]] = value
    return json.dumps(d)


LINES = [
    json.dumps(HEADER),  # 1
    json.dumps(good(0.0)),  # 2
    '{"t": 0.1, "channels": {',  # 3
    bad(0.1, ["channels", "lav", "ego"], ...),  # 4
    bad(0.1, ["channels", "lav", "objects", 0, "x"], float("nan")),  # 5
    json.dumps(good(0.1) | {"channels": good(0.1)["channels"] | {"x": channel(ego())}}),  # 6
    json.dumps(good(0.0)),  # 7
    bad(0.1, ["channels", "tfuse", "ego", "x"], "ten"),  # 8
    bad(0.1, ["channels", "lav", "plan"], [[0, 0, 0], [0, 1, 0]]),  # 9
    bad(0.1, ["channels", "lav", "ego", "polygon"], [[1, 1], [-1, 1], [0, -1]]),  # 10
    json.dumps(HEADER),  # 11
    "",  # 12 blank
    json.dumps(good(0.2, tfuse=True)),  # 13
]
EXPECTED = [
    (3, "malformed-json"),
    (4, "missing-field"),
    (5, "non-finite"),
    (6, "unknown-channel"),
    (7, "non-increasing-t"),
    (8, "wrong-type"),
    (9, "bad-trajectory"),
    (10, "bad-footprint"),
    (11, "bad-header"),
]


@pytest.fixture
def stream_file(tmp_path):
    p = tmp_path / "s.jsonl"
    p.write_text("\n".join(LINES) + "\n")
    return p


def check(reader):
    frames = list(reader)
    assert [f.t for f in frames] == [0.0, 0.2]
    assert [f.line for f in frames] == [2, 13]
    assert [(d.line, d.kind) for d in reader.defects] == EXPECTED
    assert {d.kind for d in reader.defects} <= set(DEFECT_KINDS)
    assert reader.dropouts == {"lav": 0, "tfuse": 1}
    assert reader.header is not None and reader.header.meta == {"scenario": "unit"}
    f = frames[0]
    assert f.channels["lav"].objects.ids == ["7"] and f.channels["tfuse"].objects.ids == ["7"]
    assert f.signals == {"speed_limit": 13.9}
    return frames


def test_every_defect_kind_with_its_line(stream_file):
    reader = read_stream(stream_file)
    check(reader)
    msgs = {d.kind: d.message for d in reader.defects}
    assert "channels.lav: missing required field 'ego'" in msgs["missing-field"]
    assert "channels.lav.objects[0].x" in msgs["non-finite"]
    assert "channels.x" in msgs["unknown-channel"] and "lav, tfuse" in msgs["unknown-channel"]
    assert "t = 0 does not increase strictly (previous frame t = 0)" in msgs["non-increasing-t"]
    assert "channels.tfuse.ego.x: expected a number" in msgs["wrong-type"]
    assert "channels.lav.plan[1]: dt 0 does not increase" in msgs["bad-trajectory"]
    assert "not both" in msgs["bad-footprint"]
    assert reader.defects[0].format().startswith(f"{stream_file}:3: malformed-json: ")


def test_strict_raises_on_the_first_defect(stream_file):
    reader = read_stream(stream_file, strict=True)
    it = iter(reader)
    assert next(it).t == 0.0
    with pytest.raises(StreamError) as err:
        next(it)
    assert str(err.value).startswith(f"{stream_file}:3: malformed-json: not valid JSON")
    assert err.value.defect.line == 3


def test_gzip_file(tmp_path):
    p = tmp_path / "s.jsonl.gz"
    with gzip.open(p, "wt") as fh:
        fh.write("\n".join(LINES) + "\n")
    check(read_stream(p))


def test_stdin_and_open_streams(monkeypatch):
    monkeypatch.setattr(sys, "stdin", io.StringIO("\n".join(LINES)))
    reader = read_stream("-")
    check(reader)
    assert reader.defects[0].source == "<stdin>"
    check(read_stream(io.BytesIO("\n".join(LINES).encode())))


def test_declared_channels_without_header():
    text = "\n".join([json.dumps(good(0.0)), json.dumps(good(0.1, lav=True))])
    reader = read_stream(io.StringIO(text), channels=["lav", "tfuse", "extra"])
    assert len(list(reader)) == 2
    assert reader.header is None
    assert reader.dropouts == {"lav": 1, "tfuse": 0, "extra": 2}
    # without header or declaration the first frame's channels are the set
    reader = read_stream(io.StringIO(text + "\n" + json.dumps(good(0.2))))
    frames = list(reader)
    assert reader.channels == ["lav", "tfuse"] and len(frames) == 3
    # a header naming an undeclared channel is reported on line 1
    reader = read_stream(io.StringIO(json.dumps(HEADER)), channels=["lav"])
    list(reader)
    assert [(d.line, d.kind) for d in reader.defects] == [(1, "unknown-channel")]


@pytest.mark.parametrize(
    ("path", "value", "kind", "text"),
    [
        (["t"], ..., "missing-field", "frame: missing required field 't'"),
        (["t"], True, "wrong-type", "frame.t: expected a number"),
        (
            ["channels", "lav", "objects", 0, "prediction"],
            [[0, 1, float("inf")]],
            "non-finite",
            "objects[0].prediction[0]",
        ),
        (
            ["channels", "lav", "objects", 0, "prediction"],
            [[-0.1, 1, 1]],
            "bad-trajectory",
            "dt -0.1 is negative",
        ),
        (["channels", "lav", "objects", 0, "id"], None, "wrong-type", "objects[0].id"),
        (["channels", "lav", "objects", 0, "length"], ..., "missing-field", "'length'"),
        (["channels", "lav", "ego", "width"], -1, "bad-footprint", "must be > 0"),
        (["channels", "lav", "plan"], [[0, 1]], "wrong-type", "[dt, x, y] points"),
        # JSON booleans are not numbers, although numpy would read true as 1.0
        (["channels", "lav", "plan"], [[0, True, 1]], "wrong-type", "numbers only"),
        (["channels", "lav", "plan"], [[0, 1, 1], 5], "wrong-type", "lav.plan: expected"),
        (["channels", "lav", "plan"], [[0, 1, 1], [0.1, None, 1]], "non-finite", "plan[1]"),
        (["channels", "lav", "plan"], [[0, 1, 1], "abc"], "wrong-type", "numbers only"),
        (
            ["channels", "lav", "objects", 0, "prediction"],
            [[0, 1, 1], [0.1, False, 1]],
            "wrong-type",
            "objects[0].prediction: expected a list of [dt, x, y] points (numbers only)",
        ),
        (["channels", "lav", "ego", "yaw"], None, "non-finite", "ego.yaw: null"),
        (["signals", "speed_limit"], "fast", "wrong-type", "signals.speed_limit"),
        (["channels", "lav", "ego", "polygon"], [[0, 0], [1, 0]], "bad-footprint", "at least 3"),
    ],
)
def test_field_defects(path, value, kind, text):
    d = json.loads(bad(0.0, path, value))
    if path[-1] == "polygon":
        for k in ("length", "width"):
            del d["channels"]["lav"]["ego"][k]
    reader = read_stream(io.StringIO(json.dumps(d)))
    assert list(reader) == []
    assert [(x.line, x.kind) for x in reader.defects] == [(1, kind)]
    assert text in reader.defects[0].message


def test_optional_fields_default_and_ids_normalise():
    line = json.dumps(
        {
            "t": 0,
            "channels": {
                "a": {
                    "ego": {
                        "x": 1,
                        "y": 2,
                        "yaw": 0,
                        "polygon": [[1, 1], [-1, 1], [-1, -1], [1, -1]],
                    },
                    "objects": [{"id": 5, "x": 3, "y": 4, "length": 2, "width": 1}],
                }
            },
        }
    )
    (f,) = list(read_stream(io.StringIO(line)))
    s = f.channels["a"]
    assert (s.ego.vx, s.ego.vy, s.ego.half) == (0.0, 0.0, None)
    assert s.plan.shape == (0, 3)
    o = s.objects
    assert o.ids == ["5"] and o.cls == ["unknown"] and o.yaw.tolist() == [0.0]
    assert o.pred_len.tolist() == [0] and o.areas.tolist() == [2.0]


def test_reader_iterates_once(stream_file):
    reader = read_stream(stream_file)
    list(reader)
    with pytest.raises(RuntimeError):
        list(reader)


def test_real_stdin_plain_and_gzip():
    import subprocess

    data = ("\n".join(LINES) + "\n").encode()
    code = (
        "from casewatch.monitor.reader import read_stream\n"
        "r = read_stream('-')\n"
        "print([f.t for f in r], [(d.line, d.kind) for d in r.defects], r.dropouts)"
    )
    for payload in (data, gzip.compress(data)):
        run = subprocess.run(
            [sys.executable, "-c", code], input=payload, capture_output=True, check=True
        )
        assert run.stdout.decode().strip() == (f"[0.0, 0.2] {EXPECTED} {{'lav': 0, 'tfuse': 1}}")
