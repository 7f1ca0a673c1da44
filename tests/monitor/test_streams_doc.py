"""docs/streams.md: its example header and two-channel frame pass the reader unchanged."""

from __future__ import annotations

import io
import json
import re
from pathlib import Path

from casewatch.monitor.parse import DEFECT_KINDS
from casewatch.monitor.reader import read_stream

DOC = Path(__file__).resolve().parents[2] / "docs" / "streams.md"


def test_example_frame_in_the_doc_reads_cleanly():
    blocks = re.findall(r"```json\n(.*?)```", DOC.read_text(), re.S)
    assert len(blocks) == 2  # the header, then the frame
    text = "\n".join(json.dumps(json.loads(b)) for b in blocks)
    reader = read_stream(io.StringIO(text))
    frames = list(reader)
    assert reader.defects == []
    assert reader.header is not None and reader.header.channels == ["lav", "tfuse"]
    (f,) = frames
    assert set(f.channels) == {"lav", "tfuse"}
    assert f.channels["lav"].objects.ids == ["17", "4"]
    assert f.signals["stop_line_distance"] is None


def test_every_defect_kind_is_documented():
    text = DOC.read_text()
    for kind in DEFECT_KINDS:
        assert f"| `{kind}` |" in text
