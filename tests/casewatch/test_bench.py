"""The benchmark's 8-hour replay is a valid stream: shifted times, no defects."""

from __future__ import annotations

import itertools

from bench.suite import build_replay
from casewatch.monitor.reader import read_stream


def test_replay_files_cover_the_hours_with_increasing_times(tmp_path):
    # 0.1 h = 3600 frames at 0.1 s, in 2 files of 1800: longer than any bundled drive, so
    # the replay must chain drives end to end with shifted times.
    files, frames = build_replay(0.1, 2, tmp_path)
    assert frames == 3600 and len(files) == 2
    last_t = -1.0
    total = 0
    for path in files:
        reader = read_stream(path, channels=["lav", "tfuse"])
        times = [frame.t for frame in reader]
        assert reader.defects == []
        assert times[0] > last_t and all(b > a for a, b in itertools.pairwise(times))
        last_t = times[-1]
        total += len(times)
    assert total == 3600
