"""The compiled reader (`monitor.fastparse.fast_frame`) against the careful route
(`parse_frame(decode(line))`): the same Frame, field by field (arrays equal with equal dtypes
and shapes, signs of zeros included), on the reference load, the bundled drives and random
frames; and on broken lines the same defect, kind and message, because the fast route then
hands the line to the careful one."""

from __future__ import annotations

import copy
import gzip
import json
import math
import random
from pathlib import Path
from typing import Any

import numpy as np
import orjson
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import casewatch.monitor.reader as reader_module
from bench.metrics import CHANNELS, reference_load_dicts
from casewatch.monitor.fastparse import fast_frame
from casewatch.monitor.frames import Frame
from casewatch.monitor.parse import FrameDefect, parse_frame
from casewatch.monitor.reader import decode, read_frame, read_stream

ROOT = Path(__file__).resolve().parents[2]
DRIVES = sorted((ROOT / "examples" / "data").glob("**/*.jsonl.gz"))


def assert_same_frame(a: Frame, b: Frame) -> None:
    """Field by field; arrays by value, dtype, shape and the sign of every zero."""
    assert (a.t, type(a.t), a.line) == (b.t, type(b.t), b.line)
    assert math.copysign(1, a.t) == math.copysign(1, b.t)
    assert a.signals == b.signals and a.odd == b.odd and a.world == b.world
    assert list(a.channels) == list(b.channels)
    for name in a.channels:
        ca, cb = a.channels[name], b.channels[name]
        for field in ("x", "y", "yaw", "vx", "vy", "convex", "half"):
            va, vb = getattr(ca.ego, field), getattr(cb.ego, field)
            assert va == vb and type(va) is type(vb), (name, field, va, vb)
            if isinstance(va, float):
                assert math.copysign(1, va) == math.copysign(1, vb), (name, field)
        pairs = [("ego.footprint", ca.ego.footprint, cb.ego.footprint), ("plan", ca.plan, cb.plan)]
        oa, ob = ca.objects, cb.objects
        assert oa.ids == ob.ids and oa.cls == ob.cls, name
        for field in ("pos", "yaw", "vel", "footprints", "pred", "pred_len", "convex", "half"):
            pairs.append((field, getattr(oa, field), getattr(ob, field)))
        for field, x, y in pairs:
            assert x.dtype == y.dtype and x.shape == y.shape, (name, field, x.shape, y.shape)
            assert np.array_equal(x, y, equal_nan=True), (name, field)
            if x.dtype.kind == "f":
                assert np.array_equal(np.signbit(x), np.signbit(y)), (name, field)
            assert x.flags.c_contiguous, (name, field)


def careful(line: str, channels: list[str] | None, number: int = 1) -> Frame | tuple[str, str]:
    """The careful route's frame, or its (kind, message) on a defect."""
    try:
        return parse_frame(decode(line), channels, number)
    except FrameDefect as defect:
        return (defect.kind, defect.message)
    except ValueError as exc:
        return ("malformed-json", str(exc))


def fast_or_careful(
    line: str, channels: list[str] | None, number: int = 1
) -> Frame | tuple[str, str]:
    try:
        return read_frame(line, channels, number)
    except FrameDefect as defect:
        return (defect.kind, defect.message)
    except ValueError as exc:
        return ("malformed-json", str(exc))


def same_outcome(line: str, channels: list[str] | None = None) -> Frame | tuple[str, str]:
    new = fast_or_careful(line, channels, 3)
    old = careful(line, channels, 3)
    if isinstance(old, Frame):
        assert isinstance(new, Frame), (new, line[:300])
        assert_same_frame(new, old)
    else:
        assert new == old, line[:300]
    return old


def test_reference_load_takes_the_fast_route_and_gives_the_same_frames():
    for i, d in enumerate(reference_load_dicts(40, seed=3)):
        for line in (json.dumps(d), orjson.dumps(json.loads(json.dumps(d))).decode()):
            fast = fast_frame(line, CHANNELS, i + 1)
            assert fast is not None
            assert_same_frame(fast, parse_frame(decode(line), CHANNELS, i + 1))


def test_bundled_drives_take_the_fast_route_and_give_the_same_frames():
    """Every 7th frame line of every bundled drive (72 drives, about 3500 lines)."""
    checked = 0
    for path in DRIVES:
        with gzip.open(path, "rt") as fh:
            for number, line in enumerate(fh, start=1):
                if number % 7 and number != 2:
                    continue
                obj = decode(line)
                if "header" in obj:
                    assert fast_frame(line) is None
                    continue
                fast = fast_frame(line, None, number)
                assert fast is not None, (path.name, number)
                assert_same_frame(fast, parse_frame(obj, None, number))
                checked += 1
    assert checked > 3000


# --- random valid frames ------------------------------------------------------------------

FINITE = st.floats(allow_nan=False, allow_infinity=False, min_value=-1e9, max_value=1e9)
NUMBER = st.one_of(
    FINITE,
    st.integers(min_value=-(10**9), max_value=10**9),
    st.sampled_from([0.0, -0.0, 0, 1e-300, -1e-7, 0.1, 1 / 3, 123.4567]),
)
POSITIVE = st.one_of(
    st.floats(min_value=1e-6, max_value=1e3), st.integers(min_value=1, max_value=100)
)
ANY_JSON = st.recursive(
    st.one_of(st.none(), st.booleans(), FINITE, st.text(max_size=5)),
    lambda inner: st.one_of(
        st.lists(inner, max_size=3), st.dictionaries(st.text(max_size=4), inner, max_size=3)
    ),
    max_leaves=6,
)


@st.composite
def trajectory(draw: Any, points: int, magnitude: float = 1e9) -> list[list[Any]]:
    dts = sorted(set(draw(st.lists(st.floats(0, 60), min_size=points, max_size=points))))
    value = st.floats(-magnitude, magnitude) if magnitude else NUMBER
    return [[dt, draw(value), draw(value)] for dt in dts]


@st.composite
def extras(draw: Any) -> dict[str, Any]:
    """Keys the format does not read (kept out of the ones it does)."""
    names = st.text(alphabet="abqrz_", min_size=1, max_size=6)
    return draw(st.dictionaries(names, ANY_JSON, max_size=2))


@st.composite
def box(draw: Any, optional: tuple[str, ...]) -> dict[str, Any]:
    """x, y, yaw, vx, vy and a box; the `optional` keys left out at random."""
    d: dict[str, Any] = {"x": draw(NUMBER), "y": draw(NUMBER)}
    for key in ("yaw", "vx", "vy"):
        if key not in optional or draw(st.booleans()):
            d[key] = draw(NUMBER)
    d["length"] = draw(POSITIVE)
    d["width"] = draw(POSITIVE)
    return d


@st.composite
def objects(draw: Any) -> list[dict[str, Any]]:
    k = draw(st.integers(0, 4))
    points = draw(st.integers(0, 4))
    huge = draw(st.booleans())  # box objects with predictions are not bounded by 1e9
    ids = draw(
        st.lists(
            st.one_of(
                st.integers(-(10**17), 10**17), st.text(alphabet="ab1-_ ", min_size=0, max_size=4)
            ),
            min_size=k,
            max_size=k,
            unique_by=str,
        )
    )
    out = []
    for oid in ids:
        o = {"id": oid, **draw(box(optional=("yaw", "vx", "vy"))), **draw(extras())}
        if huge and draw(st.booleans()):
            o["x"] = draw(st.sampled_from([1e300, -1e300, 1e10, 12345678901.5]))
        if draw(st.booleans()):
            o["cls"] = draw(st.sampled_from(["car", "truck", "", "pedestrian"]))
        variation = draw(st.integers(0, 9))
        if variation == 0:  # no prediction: the careful path (one length or none)
            pass
        elif variation == 1:  # another length
            o["prediction"] = draw(trajectory(points + 1))
        elif variation == 2:  # a polygon footprint
            o.pop("length")
            o.pop("width")
            o["polygon"] = [[1, 0], [0, 1], [-1, 0]]
        else:
            o["prediction"] = draw(trajectory(points, magnitude=0 if huge else 1e9))
            while len(o["prediction"]) < points:  # sorted(set()) may have merged some dt
                o["prediction"].append([61 + len(o["prediction"]), 0.0, 0.0])
        out.append(o)
    return out


@st.composite
def frames(draw: Any) -> dict[str, Any]:
    names = draw(st.lists(st.sampled_from(["lav", "tfuse", "a", "b"]), max_size=3, unique=True))
    channels = {}
    for name in names:
        ch: dict[str, Any] = {"ego": {**draw(box(optional=("vx", "vy"))), **draw(extras())}}
        if draw(st.booleans()):
            ch["plan"] = draw(trajectory(draw(st.integers(0, 5))))
        if draw(st.booleans()):
            ch["objects"] = draw(objects())
        ch.update(draw(extras()))
        channels[name] = ch
    d: dict[str, Any] = {"t": draw(st.one_of(FINITE, st.integers(0, 10**6))), "channels": channels}
    if draw(st.booleans()):
        d["signals"] = draw(
            st.dictionaries(st.sampled_from(["speed_limit", "s", "ego_speed"]), st.none() | NUMBER)
        )
    if draw(st.booleans()):
        d["world"] = {"speed": abs(draw(FINITE)), "indicator": "off"}
    if draw(st.booleans()):
        d["odd"] = {"environment": {"weather": draw(st.sampled_from(["rain", "fog"]))}}
    d.update(draw(extras()))
    keys = list(d)
    draw(st.randoms()).shuffle(keys)  # key order is free in JSON
    return {k: d[k] for k in keys}


def dump(d: dict[str, Any], style: int) -> str:
    if style == 0:
        return json.dumps(d)
    if style == 1:
        return orjson.dumps(d).decode()
    if style == 2:
        return json.dumps(d, separators=(",", ":"))
    return " " + json.dumps(d, indent=1).replace("\n", "\r\n\t") + "  \n"


@given(d=frames(), style=st.integers(0, 3), declared=st.booleans())
@settings(max_examples=600, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_random_frames(d, style, declared):
    same_outcome(dump(d, style), ["lav", "tfuse", "a", "b"] if declared else None)


def test_variations_named_by_the_issue():
    """0 objects, 1 object, no plan, a one-point plan, missing optional fields, extra keys,
    ints for floats, -0.0, 1e300 (an object's, accepted as the careful route accepts it),
    footprints against boxes: each gives the careful route's frame, fast where common."""
    base = reference_load_dicts(1, seed=5)[0]
    ch = base["channels"]["lav"]
    variants = []
    for change in range(9):
        d = copy.deepcopy(base)
        c = d["channels"]["lav"]
        if change == 0:
            c["objects"] = []
        elif change == 1:
            c["objects"] = c["objects"][:1]
        elif change == 2:
            del c["plan"]
        elif change == 3:
            c["plan"] = ch["plan"][:1]
        elif change == 4:
            for o in c["objects"]:
                o.pop("yaw"), o.pop("vx"), o.pop("vy"), o.pop("cls")
            c["ego"].pop("vx"), c["ego"].pop("vy")
        elif change == 5:
            d["meta"] = {"x": [1, {"y": None}]}
            c["extra"] = "yes"
            c["objects"][0]["score"] = 0.9
        elif change == 6:
            c["ego"]["x"] = int(c["ego"]["x"])
            c["objects"][0]["x"] = -0.0
            c["plan"][0] = [0, 1, -0.0]
        elif change == 7:
            c["objects"][0]["x"] = 1e300
        elif change == 8:
            o = c["objects"][0]
            o.pop("length"), o.pop("width")
            o["polygon"] = [[2, 1], [-2, 1], [-2, -1], [2, -1]]
        variants.append((change, json.dumps(d)))
    for change, line in variants:
        frame = same_outcome(line, CHANNELS)
        assert isinstance(frame, Frame), change
        assert (fast_frame(line, CHANNELS) is None) == (change == 8), change


# --- broken lines: the careful route's defect ---------------------------------------------

BAD_VALUES = [
    float("nan"),
    float("inf"),
    "1.5",
    None,
    True,
    [],
    {},
    1e300,
    -1,
    0,
    10**30,
    [[0, 1]],
    [[0, 1, 2, 3]],
]


def paths(value: Any, prefix: tuple = ()) -> list[tuple]:
    out = [prefix]
    if isinstance(value, dict):
        for k, v in value.items():
            out += paths(v, (*prefix, k))
    elif isinstance(value, list):
        for i, v in enumerate(value[:3]):
            out += paths(v, (*prefix, i))
    return out


def mutate(d: dict[str, Any], rng: random.Random) -> dict[str, Any]:
    d = copy.deepcopy(d)
    kind = rng.randrange(6)
    where = rng.choice(paths(d)[1:])
    parent = d
    for key in where[:-1]:
        parent = parent[key]
    last = where[-1]
    if kind <= 2:
        parent[last] = rng.choice(BAD_VALUES)
    elif kind == 3 and isinstance(parent, dict):
        del parent[last]
    elif kind == 4:  # decreasing dt / duplicate id / unknown channel
        c = rng.choice(list(d["channels"].values()))
        option = rng.randrange(3)
        if option == 0 and len(c["plan"]) > 2:
            c["plan"][1][0], c["plan"][2][0] = c["plan"][2][0], c["plan"][1][0]
        elif option == 1 and len(c["objects"]) > 1:
            c["objects"][1]["id"] = str(c["objects"][0]["id"])
        else:
            d["channels"]["radar"] = copy.deepcopy(c)
    else:  # a key given twice in the text: handled below by the caller
        parent[last] = rng.choice(BAD_VALUES[7:])
    return d


def small_frame(seed: int) -> dict[str, Any]:
    d = reference_load_dicts(1, seed=seed)[0]
    for c in d["channels"].values():
        c["objects"] = c["objects"][:3]
        c["plan"] = c["plan"][:4]
        for o in c["objects"]:
            o["prediction"] = o["prediction"][:3]
    return d


def test_random_mutations_give_the_careful_routes_defect():
    rng = random.Random(36)
    kinds: set[str] = set()
    for i in range(1500):
        d = mutate(small_frame(i % 7), rng)
        line = json.dumps(d)
        outcome = same_outcome(line, CHANNELS if i % 2 else None)
        if isinstance(outcome, tuple):
            kinds.add(outcome[0])
    assert {
        "non-finite",
        "wrong-type",
        "missing-field",
        "out-of-range",
        "bad-trajectory",
        "duplicate-id",
        "unknown-channel",
    } <= kinds


def test_text_mutations_never_crash_and_agree():
    """Cut, doubled or replaced characters anywhere in the line (malformed JSON, repeated keys,
    numbers that are not JSON): the careful route's outcome, never a crash of the scanner."""
    rng = random.Random(7)
    base = json.dumps(small_frame(1))
    for i in range(3000):
        p = rng.randrange(len(base))
        op = i % 4
        if op == 0:
            line = base[:p]
        elif op == 1:
            line = base[:p] + base[p] + base[p:]
        elif op == 2:
            line = base[:p] + rng.choice('{}[],:"\\ -+.eE0123456789tnNa\x00\x1f') + base[p + 1 :]
        else:
            q = min(len(base), p + rng.randrange(1, 40))
            line = base[:p] + base[q:]
        same_outcome(line, CHANNELS)


@pytest.mark.parametrize(
    "line",
    [
        '{"t": 0, "t": 1, "channels": {}}',
        '{"t": 0, "channels": {"a": {"ego": {"x": 0, "x": 1, "y": 0, "yaw": 0, "length": 1, '
        '"width": 1}}}}',
        '{"t": 0, "channels": {"a": {"ego": {"x": 0, "y": 0, "yaw": 0, "length": 1, "width": 1}},'
        ' "a": {"ego": {"x": 5, "y": 0, "yaw": 0, "length": 1, "width": 1}}}}',
        '{"t": 0, "channels": {}, "header": {}}',
        '{"\\u0074": 0, "channels": {}}',
        '{"t": 0, "channels": {"\\u0061": {"ego": {"x": 0, "y": 0, "yaw": 0, "length": 1, '
        '"width": 1}}}}',
        '{"t": 0, "channels": {"é": {"ego": {"x": 0, "y": 0, "yaw": 0, "length": 1, "width": 1}}}}',
        '{"t": NaN, "channels": {}}',
        '{"t": 1e400, "channels": {}}',
        '{"t": 12345678901234567890123, "channels": {}}',
        '{"t": -0, "channels": {}}',
        '{"t": 0, "channels": {}, "x": [1, 2}',
        '{"t": 0, "channels": {}, "x": ' + "[" * 300 + "]" * 300 + "}",
        '{"t": 0, "channels": {}} {}',
        "",
        "   \n",
        "[]",
        '{"t": 0, "channels": {"a": {"ego": {"x": 0, "y": 0, "yaw": 0, "length": 1, "width": 1},'
        ' "objects": [{"id": -0, "x": 0, "y": 0, "length": 1, "width": 1, "prediction": []}]}}}',
        '{"t": 0, "channels": {"a": {"ego": {"x": 0, "y": 0, "yaw": 0, "length": 1, "width": 1},'
        ' "objects": [{"id": 1.0, "x": 0, "y": 0, "length": 1, "width": 1, "prediction": []}]}}}',
        '{"t": 0, "channels": {"a": {"ego": {"x": 0, "y": 0, "yaw": 0, "length": 1, "width": 1},'
        ' "objects": [{"id": 123456789012345678901, "x": 0, "y": 0, "length": 1, "width": 1,'
        ' "prediction": []}]}}}',
        '{"t": 0, "channels": {"a": {"ego": {"x": 0, "y": 0, "yaw": 0, "length": 1, "width": 1},'
        ' "objects": [{"id": 1, "cls": null, "x": 0, "y": 0, "length": 1, "width": 1,'
        ' "prediction": null}]}}}',
    ],
)
def test_lines_outside_the_common_shape(line):
    same_outcome(line, None)
    same_outcome(line, ["a"])


def test_the_reader_reads_the_same_frames_and_defects_both_ways(tmp_path, monkeypatch):
    """A stream with a header, good frames, mutated frames, blank lines and a second header:
    the reader's frames, defects and dropouts are those of the careful route alone."""
    rng = random.Random(3)
    lines = [json.dumps({"header": {"channels": list(CHANNELS), "period": 0.1}})]
    for i, d in enumerate(reference_load_dicts(60, seed=2)):
        if i % 3 == 1:
            d = mutate(d, rng)
        if i % 11 == 4:
            del d["channels"]["tfuse"]
        lines.append(json.dumps(d))
        if i % 17 == 5:
            lines.append("   ")
    lines.append(lines[0])
    path = tmp_path / "s.jsonl"
    path.write_text("\n".join(lines) + "\n")

    def read() -> tuple[list[Frame], Any]:
        r = read_stream(path)
        return list(r), r

    fast_frames, fast = read()
    monkeypatch.setattr(reader_module, "fast_frame", lambda *args: None)
    slow_frames, slow = read()
    assert fast.defects == slow.defects and len(slow.defects) > 10
    assert fast.dropouts == slow.dropouts and fast.frames_read == slow.frames_read
    assert len(fast_frames) == len(slow_frames) > 30
    for a, b in zip(fast_frames, slow_frames, strict=True):
        assert_same_frame(a, b)


@pytest.mark.parametrize(
    ("token", "fast"),
    [
        ("0", True),
        ("-5", True),
        ('"07"', True),
        ("123456789012345678", True),
        ("-123456789012345678", True),
        ("1234567890123456789", False),  # 19 digits: orjson's own type rules, careful route
        ("-0", False),  # its int is 0: str() gives '0'
        ("5e0", False),  # a float: wrong-type
        ("5.0", False),
        ("true", False),
        ("01", False),  # not JSON
    ],
)
def test_object_ids(token, fast):
    line = (
        '{"t": 0, "channels": {"a": {"ego": {"x": 0, "y": 0, "yaw": 0, "length": 1, '
        '"width": 1}, "objects": [{"id": ' + token + ', "x": 0, "y": 0, "length": 1, '
        '"width": 1, "prediction": []}]}}}'
    )
    same_outcome(line, ["a"])
    assert (fast_frame(line, ["a"]) is not None) == fast


def test_read_frame_reads_declared_channels_given_once():
    """Channels given as a one-shot iterable still reach the careful route intact."""
    line = (
        '{"t": 0, "channels": {"c": {"ego": {"x": 0, "y": 0, "yaw": 0, "length": 1, "width": 1}}}}'
    )
    with pytest.raises(FrameDefect) as raised:
        read_frame(line, iter(["a", "b"]))
    assert raised.value.kind == "unknown-channel"
    assert raised.value.message == "channels.c: channel not declared (declared: a, b)"
