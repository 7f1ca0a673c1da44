"""Does the live page slow the judge? p99 time per frame with 0 and 20 open pages.

A bundled drive (1201 frames) is judged in process at full speed (the worst case for the
page: every 100 ms broadcast carries ~100 ticks) with `--serve`'s LiveView attached, and the
time of every frame is taken between consecutive `on_tick` calls (reading, metrics, STL,
episodes and status, and the live hook). Configurations: no live view (the hook only takes the
time), a live view with no page, and with 20 pages: 20 event streams read by a child process,
so their reading does not share this process's interpreter lock. The time spent inside the
live view's hook itself is listed too (it does not depend on the number of pages). Each
configuration runs `--repeat` times, interleaved; the table shows the median of the runs'
figures.

Budget (docs/performance.md): p99 <= 2.5 ms per frame, and 20 pages within 10 % of none.
Run: `python -m bench.live [--pages 20] [--repeat 3]`.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from casewatch import api
from casewatch.evaluator.options import RunOptions, RunSinks
from casewatch.evaluator.session import evaluate_stream
from casewatch.live.address import ServeAddress
from casewatch.live.view import LiveView
from casewatch.monitor.warmup import warm_up

REPO = Path(__file__).resolve().parents[1]
CASE = REPO / "examples" / "reference-case.yaml"
DRIVE = REPO / "examples" / "data" / "highway-tailgating.jsonl.gz"

#: The child process holding N event streams open and reading them to their end.
READER = """
import http.client, sys, threading
host, port, n = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
got = [0] * n
def read(k):
    c = http.client.HTTPConnection(host, port, timeout=60)
    c.request("GET", "/events")
    for line in c.getresponse():
        got[k] += len(line)
threads = [threading.Thread(target=read, args=(k,)) for k in range(n)]
for t in threads: t.start()
print("open", flush=True)
for t in threads: t.join()
print(sum(got), flush=True)
"""


def judge(case, spec, pages: int | None) -> dict[str, float]:
    """One run; per-frame times in ms (pages None: no live view at all)."""
    stamps: list[float] = []
    hook: list[float] = []  # seconds inside the live view's on_tick, per frame
    view = None
    reader = None
    received = 0

    def stamp(frame, statuses, evaluator, source) -> None:
        stamps.append(time.perf_counter())

    on_tick, on_event = stamp, None
    if pages is not None:
        view = LiveView(case, spec, str(DRIVE), ServeAddress("127.0.0.1", 0))
        url = view.start()
        host, port = url.split("//")[1].rstrip("/").rsplit(":", 1)
        if pages:
            reader = subprocess.Popen(
                [sys.executable, "-c", READER, host, port, str(pages)],
                stdout=subprocess.PIPE,
                text=True,
            )
            assert reader.stdout is not None and reader.stdout.readline().strip() == "open"
            deadline = time.monotonic() + 10
            while len(view.server.pages) < pages and time.monotonic() < deadline:
                time.sleep(0.05)
        state = view.state

        def on_tick(frame, statuses, evaluator, source) -> None:
            started = time.perf_counter()
            state.on_tick(frame, statuses, evaluator, source)
            stamps.append(time.perf_counter())
            hook.append(stamps[-1] - started)

        on_event = view.on_event(None)
    sinks = RunSinks(on_event=on_event, on_tick=on_tick)
    result = evaluate_stream(case, spec, str(DRIVE), RunOptions(), sinks)
    if view is not None:
        view.finish(result)
    if reader is not None:
        out, _ = reader.communicate(timeout=60)
        received = int(out.split()[-1])
    ms = np.diff(np.asarray(stamps)) * 1e3
    return {
        "p50": float(np.percentile(ms, 50)),
        "p99": float(np.percentile(ms, 99)),
        "max": float(ms.max()),
        "frames": len(stamps),
        "hook_p50_us": float(np.percentile(hook, 50)) * 1e6 if hook else 0.0,
        "hook_p99_us": float(np.percentile(hook, 99)) * 1e6 if hook else 0.0,
        "bytes_per_page": received / pages if pages else 0,
    }


def measure(pages: int = 20, repeat: int = 3) -> dict[str, dict[str, float]]:
    case, spec = api.prepare(str(CASE))
    warm_up()
    judge(case, spec, None)  # the first run of a process pays for caches
    configs = {"no live view": None, "live view, 0 pages": 0, f"live view, {pages} pages": pages}
    runs: dict[str, list[dict[str, float]]] = {name: [] for name in configs}
    for _ in range(repeat):
        for name, n in configs.items():
            runs[name].append(judge(case, spec, n))
    return {
        name: {k: statistics.median(r[k] for r in rs) for k in rs[0]} for name, rs in runs.items()
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pages", type=int, default=20)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--json", type=Path, help="also write the figures here")
    args = parser.parse_args(argv)
    figures = measure(args.pages, args.repeat)
    print(
        f"{'configuration':<24} {'p50 ms':>8} {'p99 ms':>8} {'max ms':>8} "
        f"{'hook p50/p99 us':>16} {'KiB/page':>9}"
    )
    for name, f in figures.items():
        hook = f"{f['hook_p50_us']:.1f} / {f['hook_p99_us']:.1f}"
        print(
            f"{name:<24} {f['p50']:8.3f} {f['p99']:8.3f} {f['max']:8.3f} {hook:>16} "
            f"{f['bytes_per_page'] / 1024:9.0f}"
        )
    if args.json:
        args.json.write_text(json.dumps(figures, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
