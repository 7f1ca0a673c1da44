"""parse_frame: the vectorised fast path and the careful path accept the same input and build
the same arrays; type checks that numpy alone would let through."""

from __future__ import annotations

import numpy as np
import pytest

import casewatch.monitor.parse as parse
from casewatch.monitor.parse import FrameDefect, parse_frame
from tests.monitor.builders import channel, ego, frame_dict, obj


def objects_frame(objects):
    return frame_dict(0.0, {"a": channel(ego(), objects=objects)})


SAMPLES = [
    [
        obj(1, 0, 0, 0.3, 4, 2, prediction=[[0, 0, 0], [0.1, 1, 0]]),
        obj("x", 5, 1, -1.0, 2, 1, prediction=[[0, 5, 1], [0.2, 6, 2]], cls="truck"),
    ],
    [obj(1, 0, 0), obj(2, 3, 4, vx=1.5, vy=-2)],
]


@pytest.mark.parametrize("objects", SAMPLES)
def test_fast_and_careful_paths_agree(objects, monkeypatch):
    fast = parse_frame(objects_frame(objects)).channels["a"].objects
    monkeypatch.setattr(parse, "_objects_fast", lambda v: None)
    careful = parse_frame(objects_frame(objects)).channels["a"].objects
    assert fast.ids == careful.ids and fast.cls == careful.cls
    for name in ("pos", "yaw", "vel", "footprints", "pred", "pred_len", "convex", "half"):
        np.testing.assert_array_equal(getattr(fast, name), getattr(careful, name), err_msg=name)


def test_mixed_prediction_lengths_and_polygons_take_the_careful_path():
    objects = [
        obj(1, 0, 0, prediction=[[0, 0, 0]]),
        obj(2, 1, 1),
        {"id": 3, "x": 2, "y": 2, "polygon": [[1, 0], [0, 1], [-1, 0]]},
    ]
    o = parse_frame(objects_frame(objects)).channels["a"].objects
    assert o.pred_len.tolist() == [1, 0, 0]
    assert o.footprints.shape == (3, 4, 2)  # the triangle padded by repeating its last vertex
    assert np.isnan(o.half[2]).all() and o.areas[2] == pytest.approx(1.0)


@pytest.mark.parametrize(
    ("field", "value", "kind"),
    [
        ("x", True, "wrong-type"),
        ("x", "1.5", "wrong-type"),
        ("prediction", [[0, "1.5", 0]], "wrong-type"),
        ("prediction", [[0, True, 0]], "wrong-type"),
        ("prediction", [[0, 1, 0], "abc"], "wrong-type"),
        ("prediction", [[0, 1, 0], [0.1, 1]], "wrong-type"),
        ("prediction", [[0, 1, float("nan")]], "non-finite"),
        ("width", float("inf"), "non-finite"),
        ("prediction", [[0, None, 0]], "non-finite"),
        ("prediction", [[0, 1, 0], [0, 2, 0]], "bad-trajectory"),
        ("length", 0, "bad-footprint"),
    ],
)
def test_fast_path_never_accepts_what_the_careful_path_refuses(field, value, kind):
    bad = obj(2, 1, 1)
    bad[field] = value
    with pytest.raises(FrameDefect) as err:
        parse_frame(objects_frame([obj(1, 0, 0), bad]))
    assert err.value.kind == kind
    assert "channels.a.objects[1]" in err.value.message
