"""`fast_frame`'s Python around the compiled pass (issue 36, per-frame glue): a line whose only
loose value is `signals` is read without the dict of extras, and the header, the ego values and
the strings are read through memoryviews of the buffer. Held to the careful route
(`parse_frame`) field by field on random `signals` values of every JSON kind, beside the other
loose values (`odd`, `world`, unknown keys), and on the bundled drives' lines."""

from __future__ import annotations

import gzip
import json
from pathlib import Path
from typing import Any

from hypothesis import given, settings
from hypothesis import strategies as st

from casewatch.monitor.fastparse import fast_frame
from casewatch.monitor.frames import Frame
from tests.monitor.test_fast_parse import assert_same_frame, careful

ROOT = Path(__file__).resolve().parents[2]
CHANNELS = ["lav", "tfuse"]

scalar = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-(2**63), 2**63),
    st.floats(allow_nan=False, allow_infinity=False),
    st.text(max_size=4),
)
#: `signals` as a line may hold it: usually numbers or null, sometimes anything JSON
signals = st.one_of(
    st.dictionaries(
        st.sampled_from(["speed_limit", "ego_speed", "s"]), st.none() | st.floats(-1e6, 1e6)
    ),
    st.dictionaries(st.text(max_size=3), scalar, max_size=4),
    st.dictionaries(st.text(max_size=3), st.lists(scalar, max_size=2), max_size=2),
    scalar,
    st.lists(scalar, max_size=3),
)


def _line(**extra: Any) -> str:
    channel = {
        "ego": {"x": 1.5, "y": -2.0, "yaw": 0.1, "vx": 3.0, "length": 4.6, "width": 1.9},
        "plan": [[0.0, 1.5, -2.0], [0.5, 3.0, -2.0]],
        "objects": [
            {
                "id": 7,
                "x": 10.0,
                "y": 1.0,
                "length": 4.0,
                "width": 2.0,
                "prediction": [[0.0, 10.0, 1.0], [1.0, 12.0, 1.0]],
            }
        ],
    }
    return json.dumps({"t": 0.25, "channels": {"lav": channel, "tfuse": channel}, **extra})


def _same(line: str) -> None:
    want = careful(line, CHANNELS)
    got = fast_frame(line, frozenset(CHANNELS), 1)
    if got is None:  # the careful route reads it (or names its defect)
        return
    assert isinstance(want, Frame), (line, want)
    assert_same_frame(got, want)
    assert all(type(v) is float or v is None for v in got.signals.values())


@given(value=signals)
@settings(max_examples=300, deadline=None)
def test_signals_alone_read_as_the_careful_route_reads_them(value):
    _same(_line(signals=value))


@given(
    value=signals,
    world=st.booleans(),
    odd=st.booleans(),
    unknown=st.booleans(),
)
@settings(max_examples=200, deadline=None)
def test_signals_beside_other_loose_values(value, world, odd, unknown):
    extra: dict[str, Any] = {"signals": value}
    if world:
        extra["world"] = {"speed_limit": 13.9}
    if odd:
        extra["odd"] = {"environment": {"weather": "fog"}}
    if unknown:
        extra["note"] = [1, {"a": None}]
    _same(_line(**extra))


def test_a_float_signals_line_takes_the_fast_route_with_its_own_values():
    frame = fast_frame(_line(signals={"speed_limit": 13.9, "s": None}), None, 3)
    assert frame is not None and frame.line == 3
    assert frame.signals == {"speed_limit": 13.9, "s": None}
    assert frame.odd is None and frame.world is None
    assert list(frame.channels) == CHANNELS
    ego = frame.channels["tfuse"].ego
    assert (ego.x, ego.y, ego.yaw, ego.vx, ego.vy, ego.half) == (
        1.5,
        -2.0,
        0.1,
        3.0,
        0.0,
        (2.3, 0.95),
    )
    assert frame.channels["lav"].objects.ids == ["7"]
    assert frame.channels["lav"].objects.cls == ["unknown"]


def test_no_signals_and_an_unknown_channel():
    frame = fast_frame(_line(), None, 1)
    assert frame is not None and frame.signals == {}
    assert fast_frame(_line(), frozenset(["lav"]), 1) is None  # tfuse is not declared
    assert fast_frame(_line(), ["lav", "tfuse", "x"], 1) is not None  # any iterable of names


def test_every_bundled_line_as_the_careful_route_reads_it():
    for path in sorted((ROOT / "examples" / "data").glob("*.jsonl.gz"))[:2]:
        with gzip.open(path, "rt") as fh:
            lines = [line for line in fh if '"header"' not in line[:12]][:300]
        for number, line in enumerate(lines, 1):
            want = careful(line, CHANNELS, number)
            got = fast_frame(line.encode(), frozenset(CHANNELS), number)
            assert got is not None and isinstance(want, Frame)
            assert_same_frame(got, want)


def test_the_engine_passes_a_frames_signals_through_as_before():
    """`MetricEngine.step` tests whether any of the frame's signals is already a name of the
    tick (`out.keys().isdisjoint(signals)`, the cheap way round): when none is, all are
    copied; when one is, a metric keeps its value and a world input without one takes it."""
    from casewatch.monitor.engine import MetricEngine
    from casewatch.safety_case.model import MetricParams

    def step(signals: dict[str, float | None]) -> dict[str, float | None]:
        frame = fast_frame(_line(signals=signals), None, 1)
        assert frame is not None
        return MetricEngine(MetricParams(), CHANNELS).step(frame)

    out = step({"gap": 2.5, "s": None})
    assert out["gap"] == 2.5 and out["s"] is None
    out = step({"gap": 2.5, "els": 7.0, "speed_limit": 13.9})
    assert out["gap"] == 2.5 and out["els"] != 7.0  # a metric's own value stands
    assert out["speed_limit"] == 13.9  # a world input the frame's `world` left without value
