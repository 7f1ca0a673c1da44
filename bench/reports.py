"""Benchmark: render the reports of a synthetic 1-hour, 10 Hz run and print time and size.

`python -m bench.reports` prints one line per format (render seconds, bytes) and a JSON summary
line, so `make bench` can collect it. The issue's budget is a report under 5 MB for such a run.
"""

from __future__ import annotations

import json
import sys
import tempfile
import time
from pathlib import Path

from casewatch.reports.render import FORMATS, render_reports
from tools.sample import long_run_result

SIZE_BUDGET = 5 * 1024 * 1024


def run(duration: float = 3600.0) -> dict[str, object]:
    """Render every format of a synthetic run of `duration` seconds; returns the figures."""
    started = time.perf_counter()
    result = long_run_result(duration=duration)
    build_s = time.perf_counter() - started
    figures: dict[str, object] = {
        "duration_s": duration,
        "frames": result.stream.frames_read,
        "episodes": len(result.episodes),
        "data_gaps": len(result.data_gaps),
        "result_json_bytes": len(result.model_dump_json()),
        "fixture_s": round(build_s, 3),
    }
    with tempfile.TemporaryDirectory() as tmp:
        for name in FORMATS:
            t0 = time.perf_counter()
            written = render_reports(result, Path(tmp), (name,))
            figures[f"{name}_s"] = round(time.perf_counter() - t0, 3)
            figures[f"{name}_bytes"] = written[name].stat().st_size
    return figures


def main() -> int:
    figures = run()
    print(
        f"reports: 1-hour run at 10 Hz ({figures['frames']} frames, {figures['episodes']} "
        f"episodes, {figures['data_gaps']} data gaps)"
    )
    for name in FORMATS:
        size = int(figures[f"{name}_bytes"])
        print(f"  {name:6s} rendered in {figures[f'{name}_s']:.3f} s, {size / 1e6:.2f} MB")
    html_ok = int(figures["html_bytes"]) < SIZE_BUDGET
    print(f"  html size budget 5 MB: {'ok' if html_ok else 'EXCEEDED'}")
    print(json.dumps({"reports": figures}))
    return 0 if html_ok else 1


if __name__ == "__main__":
    sys.exit(main())
