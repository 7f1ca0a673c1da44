"""The reader's limits: truncated or corrupt compressed streams, over-deep and oversized lines,
frame spacing and absurd times each become one defect, never an exception."""

from __future__ import annotations

import gzip
import io
import json
from pathlib import Path

import pytest

from casewatch.monitor.reader import StreamError, read_stream
from tests.evaluator.streams import frame

CHANNELS = ["lav", "tfuse"]


def lines(count: int) -> list[str]:
    return [json.dumps(frame(i)) for i in range(count)]


def read_all(source, **kw):
    reader = read_stream(source, channels=CHANNELS, **kw)
    frames = list(reader)
    return reader, frames


def gz(tmp_path: Path, data: bytes) -> Path:
    path = tmp_path / "s.jsonl.gz"
    path.write_bytes(data)
    return path


def test_truncated_gzip_is_one_defect_at_the_line_reached(tmp_path):
    whole = gzip.compress(("\n".join(lines(200)) + "\n").encode(), mtime=0)
    reader, frames = read_all(gz(tmp_path, whole[: len(whole) // 2]))
    assert 0 < len(frames) < 200
    (defect,) = reader.defects
    assert defect.kind == "truncated-stream" and "ends before its end marker" in defect.message
    assert defect.line == frames[-1].line + 1
    assert [f.line for f in frames] == list(range(1, len(frames) + 1))


@pytest.mark.parametrize("data", [b"\x1f\x8b\x08\x00\x00", b"\x1f\x8b"])
def test_a_few_gzip_bytes_are_one_defect_on_line_1(tmp_path, data):
    reader, frames = read_all(gz(tmp_path, data))
    assert frames == [] and [(d.line, d.kind) for d in reader.defects] == [(1, "truncated-stream")]


def test_corrupt_gzip_data_is_a_truncated_stream_defect(tmp_path):
    whole = bytearray(gzip.compress(("\n".join(lines(50)) + "\n").encode(), mtime=0))
    whole[len(whole) // 2 : len(whole) // 2 + 16] = b"\xff" * 16
    reader, frames = read_all(gz(tmp_path, bytes(whole)))
    assert len(frames) < 50
    assert [d.kind for d in reader.defects][-1] == "truncated-stream"


def test_truncated_gzip_in_strict_mode_raises_stream_error(tmp_path):
    whole = gzip.compress(("\n".join(lines(100)) + "\n").encode(), mtime=0)
    with pytest.raises(StreamError, match="truncated-stream"):
        read_all(gz(tmp_path, whole[:-30]), strict=True)


@pytest.mark.parametrize(
    "bad",
    [
        "[" * 100_000,
        "{" * 100_000,
        '{"t": 0.5, "channels": {}, "signals": {"x": ' + "[" * 1000 + "]" * 1000 + "}}",
    ],
    ids=["brackets", "braces", "deep-value"],
)
def test_over_deep_line_is_one_defect(bad):
    good = lines(3)
    text = "\n".join([good[0], bad, good[1], good[2]]) + "\n"
    reader, frames = read_all(io.StringIO(text))
    assert [f.line for f in frames] == [1, 3, 4]
    (defect,) = reader.defects
    assert defect.line == 2 and defect.kind in ("malformed-json", "wrong-type")


def test_oversized_line_is_skipped_without_losing_the_next_lines():
    good = lines(3)
    text = "\n".join([good[0], "x" * 50_000, good[1], good[2]]) + "\n"
    reader, frames = read_all(io.StringIO(text))  # under the default limit: just not JSON
    assert [(d.line, d.kind) for d in reader.defects] == [(2, "malformed-json")]
    reader = read_stream(io.StringIO(text), channels=CHANNELS)
    reader.max_line_chars = 20_000
    frames = list(reader)
    assert [f.line for f in frames] == [1, 3, 4]
    assert [(d.line, d.kind) for d in reader.defects] == [(2, "oversized-line")]


def test_frames_closer_than_half_a_period_are_spacing_defects():
    rows = [frame(0), frame(0), frame(1), frame(2)]
    rows[1]["t"] = 1e-7
    rows[3]["t"] = 0.1 + 0.04  # 0.04 s after the previous accepted frame
    text = "".join(json.dumps(r) + "\n" for r in rows)
    reader, frames = read_all(io.StringIO(text), period=0.1)
    assert [f.t for f in frames] == [0.0, 0.1]
    assert [(d.line, d.kind) for d in reader.defects] == [
        (2, "frame-spacing"),
        (4, "frame-spacing"),
    ]
    assert "comes 1e-07 s after the previous frame" in reader.defects[0].message
    # without a period from the caller, the header's applies; with neither nothing is checked
    header = json.dumps({"header": {"channels": CHANNELS, "period": 0.1}})
    reader, frames = read_all(io.StringIO(header + "\n" + text))
    assert [d.kind for d in reader.defects] == ["frame-spacing", "frame-spacing"]
    reader, frames = read_all(io.StringIO(text))
    assert reader.defects == [] and len(frames) == 4


def test_jittered_frames_within_half_a_period_are_fine():
    rows = [frame(i) for i in range(5)]
    for row, t in zip(rows, [0.0, 0.06, 0.2, 0.33, 0.4], strict=True):
        row["t"] = t
    reader, frames = read_all(io.StringIO("".join(json.dumps(r) + "\n" for r in rows)), period=0.1)
    assert reader.defects == [] and len(frames) == 5


def test_absurd_times_are_bad_time_defects():
    rows = [frame(0), frame(1), frame(2)]
    rows[0]["t"], rows[1]["t"] = -1.7e308, 1.7e308
    reader, frames = read_all(io.StringIO("".join(json.dumps(r) + "\n" for r in rows)))
    assert [f.t for f in frames] == [0.2]
    assert [(d.line, d.kind) for d in reader.defects] == [(1, "bad-time"), (2, "bad-time")]
