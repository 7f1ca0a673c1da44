"""The bundled streams pass casewatch's own reader with zero defects."""

from __future__ import annotations

from pathlib import Path

import pytest

from casewatch.monitor.reader import read_stream

DATA = Path(__file__).resolve().parents[2] / "examples" / "data"


@pytest.mark.parametrize("path", sorted(DATA.glob("*.jsonl.gz")), ids=lambda p: p.name)
def test_bundled_stream_reads_without_defects(path: Path) -> None:
    reader = read_stream(path)
    frames = sum(1 for _ in reader)
    assert reader.defects == []
    assert frames >= 600
    assert reader.channels == ["lav", "tfuse"]
    assert all(n == 0 for n in reader.dropouts.values())
