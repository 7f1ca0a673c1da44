"""`make bench`: the benchmark suite. Prints a table and writes `out/bench/results.json`.

1. Online latency per frame at reference load (2 channels, 40 objects with 30-point
   predictions, 50-point plans) through the reference case's full set of formulas: p50, p99
   and max in ms, split into reading (decoding and validating the JSON line), metrics, STL
   update, episodes/status, and total.
2. rtamt update cost per formula, as the evaluator uses it.
3. Offline throughput on the bundled data and on an 8-hour equivalent (the bundled scenarios
   replayed end to end with shifted times into 4 files): the live path (rtamt tick by tick;
   single process: the files piped into standard input as one live stream) and the whole-log
   path (numpy STL over each file), single process and with `--jobs 2`, each `--repeat` times
   interleaved (medians), with the whole-log path's speed-up over the live path in the same
   run and the peak RSS of the single-process runs.
4. Report rendering time and size for a 1-hour run.
5. Kernel start-up: compiling every numba metric kernel in a fresh cache (a machine's first
   run) and loading them from the cache (every later process); `casewatch --help`'s time and
   whether it imports anything heavy.
3b. The same replay on a Dask LocalCluster (`--engine dask`) of 1 and 2 workers: the speed-up
   (goal >= 1.8x) and the overhead against `--jobs 2` (goal <= 10 %), when dask is installed.
3c. The same replay on a real `dask scheduler` and 1 and 2 `dask worker` processes on loopback
   (`bench/dask_cluster.py`): speed-up, overhead against `--jobs 2` measured alongside, and a
   `--resume` run's rate over the hours it judged (reused logs not counted).
7. ROS 2 bags: every bundled drive as an MCAP bag (plain and zstd), frames per second of
   reading it against the evaluator's own speed on the same drive (`bench/bags.py`;
   target: reading >= judging).
8. STL engines: rtamt tick by tick against numpy over the whole log, per formula of the
   reference case on 1 hour of signals (target >= 50x, identical values), and `casewatch run`
   on the bundled drives with each engine (`bench/stl.py`).
9. The live page (`bench/live.py`): p50/p99 per frame with no live view, with the page served
   to 0 and to 20 open pages (many pages must not slow the judge).
10. Scenario export (`bench/scenario_replay.py`): every bundled hazard event exported and its
   file replayed as the standard times FollowTrajectoryAction: no contact the stream did not
   have, entities present exactly while observed; a non-zero exit when any file is unfaithful.
11. Where the time goes (`bench/stages.py`): the bundled drives judged in process by both
   paths, ms per frame per stage (read, metrics, STL, episodes and status), medians.
6. Threshold tuning (`casewatch tune`) on 1 hour of saved signals, 17 formulas x 50 candidate
   thresholds (and durations): `python -m bench.tuning`; target <= 60 s.

Targets (issue 36): live p99 <= 1.0 ms per frame at reference load, decoding included;
whole-log 8-hour replay >= 1000x real time with --jobs 2 and >= 500x in one process; peak RSS
of the 8-hour run <= 1 GiB; kernels ready in <= 5 s on a first run; `casewatch --help` < 0.3 s
importing nothing heavy. Options: `--quick` for a short smoke run, `--hours`, `--repeat`.
"""

from __future__ import annotations

import argparse
import gzip
import json
import os
import platform
import re
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from bench.metrics import reference_load_dicts
from casewatch import api
from casewatch.evaluator.core import Evaluator
from casewatch.evaluator.session import peak_rss_mib
from casewatch.monitor.engine import MetricEngine
from casewatch.monitor.reader import read_frame

REPO = Path(__file__).resolve().parent.parent
CASE = REPO / "examples" / "reference-case.yaml"
DATA = REPO / "examples" / "data"
BENCH = Path("out") / "bench"
T_FIELD = re.compile(rb'^\{"t":\s*([-0-9.eE+]+)')


def _ms(values: list[float]) -> dict[str, float]:
    a = np.asarray(values) * 1e3
    return {
        "p50": round(float(np.percentile(a, 50)), 4),
        "p99": round(float(np.percentile(a, 99)), 4),
        "max": round(float(a.max()), 4),
        "mean": round(float(a.mean()), 4),
    }


def online_latency(frames: int, warmup: int = 30) -> dict[str, object]:
    """Per-frame cost of the live path on the reference load: decoding and validating the
    frame's JSON line (`monitor.reader.read_frame`: the compiled reader, or orjson and
    `parse_frame` for a line of another shape, as the live reader does), metrics, STL (rtamt),
    episodes/status, and their total."""
    case, spec = api.prepare(CASE)
    engine = MetricEngine(case.monitor.metrics, list(case.monitor.channels))
    evaluator = Evaluator(case, spec)
    lines = [json.dumps(d) for d in reference_load_dicts(frames + warmup, seed=1)]
    channels = list(case.monitor.channels)
    parts: dict[str, list[float]] = {
        "read": [],
        "metrics": [],
        "stl": [],
        "episodes_status": [],
        "total": [],
    }
    for i, line in enumerate(lines):
        t0 = time.perf_counter()
        frame = read_frame(line, channels, i + 1)
        t1 = time.perf_counter()
        values = engine.step(frame)
        t2 = time.perf_counter()
        stl_before = evaluator.stl_seconds
        evaluator.step(frame.t, values)
        t3 = time.perf_counter()
        if i < warmup:
            continue
        stl = evaluator.stl_seconds - stl_before
        parts["read"].append(t1 - t0)
        parts["metrics"].append(t2 - t1)
        parts["stl"].append(stl)
        parts["episodes_status"].append(t3 - t2 - stl)
        parts["total"].append(t3 - t0)
    return {
        "frames": frames,
        "formulas": len(spec.formulas),
        **{k: _ms(v) for k, v in parts.items()},
    }


def rtamt_cost(updates: int = 2000) -> list[dict[str, object]]:
    """Mean cost of one `update` per compiled formula of the reference case (µs)."""
    from casewatch.spec.emit import build_rtamt_monitor

    _, spec = api.prepare(CASE)
    rng = np.random.default_rng(0)
    rows = []
    for formula in spec.formulas:
        monitor = build_rtamt_monitor(formula, spec.period)
        values = rng.uniform(0, 1, size=(updates, len(formula.signals)))
        start = time.perf_counter()
        for i in range(updates):
            monitor.update(i, list(zip(formula.signals, values[i].tolist(), strict=True)))
        cost = (time.perf_counter() - start) / updates * 1e6
        rows.append(
            {"formula": formula.id, "rtamt": formula.rtamt, "us_per_update": round(cost, 2)}
        )
    return rows


_WARM_UP = (
    "import time; t = time.perf_counter(); "
    "from casewatch.monitor.warmup import warm_up; warm_up(); print(time.perf_counter() - t)"
)


def kernel_start_up() -> dict[str, float]:
    """Seconds to import the engine and get its kernels ready (`warm_up`), each in a fresh
    interpreter with its own numba cache (NUMBA_CACHE_DIR):

    - `cold_cache_s`: an empty cache, a machine's first run without the install step;
    - `install_step_s`: the install step (`casewatch warm-up`, as `make venv` runs it) in
      another empty cache, and `first_run_s` the first run after it, from that cache: the
      issue's "first run on a fresh machine" for an installed casewatch;
    - `warm_cache_s`: a later run (the cold run's cache, filled by it).
    """
    out: dict[str, float] = {}

    def ready(cache: str) -> float:
        done = subprocess.run(
            [sys.executable, "-c", _WARM_UP],
            env={**os.environ, "NUMBA_CACHE_DIR": cache},
            cwd=REPO,
            capture_output=True,
            text=True,
            check=True,
        )
        return round(float(done.stdout.strip().splitlines()[-1]), 2)

    with tempfile.TemporaryDirectory() as cold, tempfile.TemporaryDirectory() as installed:
        out["cold_cache_s"] = ready(cold)
        out["warm_cache_s"] = ready(cold)
        start = time.perf_counter()
        subprocess.run(
            [sys.executable, "-m", "casewatch", "warm-up", "--quiet"],
            env={**os.environ, "NUMBA_CACHE_DIR": installed},
            cwd=REPO,
            check=True,
        )
        out["install_step_s"] = round(time.perf_counter() - start, 2)
        out["first_run_s"] = ready(installed)
    print(
        f"kernels ready: {out['cold_cache_s']:.1f} s with an empty cache (no install step); "
        f"install step (casewatch warm-up) {out['install_step_s']:.1f} s, the first run after "
        f"it {out['first_run_s']:.2f} s; a later run {out['warm_cache_s']:.2f} s",
        flush=True,
    )
    return out


def bundled_streams() -> list[Path]:
    from casewatch.batch import find_streams

    return find_streams(str(DATA))


def build_replay(hours: float, files: int, folder: Path) -> tuple[list[Path], int]:
    """Replay the bundled scenarios end to end, shifting times, into `files` gzip files that
    together cover `hours` of driving. Returns the files and the frame count."""
    folder.mkdir(parents=True, exist_ok=True)
    sources: list[tuple[bytes, list[tuple[float, bytes]]]] = []
    for path in bundled_streams():
        with gzip.open(path, "rb") if path.suffix == ".gz" else open(path, "rb") as fh:
            lines = fh.read().splitlines()
        header = lines[0] if lines[0].startswith(b'{"header"') else b""
        body = []
        for line in lines[1:] if header else lines:
            m = T_FIELD.match(line)
            if m:
                body.append((float(m.group(1)), line[m.end() :]))
        sources.append((header, body))
    period = 0.1
    total_frames = round(hours * 3600 / period)
    per_file = total_frames // files
    out: list[Path] = []
    t_next = 0.0
    written = 0
    source = 0
    for index in range(files):
        path = folder / f"replay-{index:02d}.jsonl.gz"
        with gzip.open(path, "wb", compresslevel=1) as fh:
            header = sources[0][0]
            if header:
                fh.write(header + b"\n")
            count = 0
            while count < per_file:
                _, body = sources[source % len(sources)]
                source += 1
                t0 = body[0][0]
                chunk = []
                for t, rest in body[: per_file - count]:
                    chunk.append(b'{"t": %.3f' % (t_next + t - t0) + rest)
                count += len(chunk)
                t_next += (body[len(chunk) - 1][0] - t0) + 1.0  # a 1 s pause between drives
                fh.write(b"\n".join(chunk) + b"\n")
        written += count
        out.append(path)
    return out, written


def run_cli(args: list[str], stdin_files: list[Path] | None = None) -> tuple[float, float, int]:
    """Run `casewatch ARGS` in a child process: wall seconds, its peak RSS (MiB), exit code.

    With `stdin_files`, their decompressed frames are piped in as one live stream (headers
    after the first dropped), so the run never sees a file and must stream. The peak RSS is the
    child's own `VmHWM`, polled while it runs (getrusage would include this parent's memory,
    counted at fork time).
    """
    cmd = [sys.executable, "-m", "casewatch", *args]
    peak = 0.0

    def poll() -> None:
        nonlocal peak
        while proc.poll() is None:
            peak = max(peak, peak_rss_mib(proc.pid) or 0.0)
            time.sleep(0.1)

    with tempfile.TemporaryFile() as err:
        start = time.perf_counter()
        proc = subprocess.Popen(
            cmd,
            stdin=subprocess.PIPE if stdin_files else None,
            stdout=subprocess.DEVNULL,
            stderr=err,
        )
        watcher = threading.Thread(target=poll, daemon=True)
        watcher.start()
        if stdin_files:
            assert proc.stdin is not None
            for index, path in enumerate(stdin_files):
                with gzip.open(path, "rb") as fh:
                    first = fh.readline()
                    if index == 0 or not first.startswith(b'{"header"'):
                        proc.stdin.write(first)
                    while chunk := fh.read(1 << 20):
                        proc.stdin.write(chunk)
            proc.stdin.close()
        code = proc.wait()
        wall = time.perf_counter() - start
        watcher.join()
        if code not in (0, 1):
            err.seek(0)
            raise RuntimeError(f"casewatch {' '.join(args)} failed: {err.read().decode()[-2000:]}")
    return wall, peak, code


def offline(
    streams: list[Path], frames: int, hours: float, jobs: int, out: Path, engine: str = "processes"
) -> dict:
    args = [
        "run",
        str(CASE),
        *map(str, streams),
        "-o",
        str(out),
        "--jobs",
        str(jobs),
        "--format",
        "none",
        "--quiet",
        "--engine",
        engine,
    ]
    wall, _, _ = run_cli(args)
    return {
        "jobs": jobs,
        "frames": frames,
        "hours": round(hours, 4),
        "wall_s": round(wall, 2),
        "frames_per_s": round(frames / wall, 1),
        "x_real_time": round(hours * 3600 / wall, 1),
    }


#: The replay's runs, in the order each repetition makes them: (path, jobs).
REPLAY_RUNS = (("live", 1), ("whole-log", 1), ("live", 2), ("whole-log", 2))


def replay_paths(replay: list[Path], frames: int, hours: float, repeat: int) -> list[dict]:
    """The replay judged by the live path (rtamt tick by tick: one process reads the 4 files
    piped into standard input as one live stream; with --jobs 2, the 4 files) and by the
    whole-log path (`--stl-engine numpy`, the 4 files), single process and with --jobs 2.
    Each run is repeated `repeat` times, the four interleaved so that a noisy minute on the
    shared machine hits every row alike; rows hold the medians and every run's wall time."""
    walls: dict[tuple[str, int], list[float]] = {run: [] for run in REPLAY_RUNS}
    peaks: dict[tuple[str, int], list[float]] = {run: [] for run in REPLAY_RUNS}
    for _ in range(repeat):
        for path, jobs in REPLAY_RUNS:
            out = BENCH / f"replay-{path}-j{jobs}"
            common = ["-o", str(out), "--format", "none", "--quiet"]
            if path == "live" and jobs == 1:
                args = ["run", str(CASE), "-", *common, "--stl-engine", "rtamt"]
                wall, peak, _ = run_cli(args, stdin_files=replay)
            else:
                engine = "rtamt" if path == "live" else "numpy"
                files = list(map(str, replay))
                args = ["run", str(CASE), *files, *common, "--jobs", str(jobs)]
                wall, peak, _ = run_cli([*args, "--stl-engine", engine])
            walls[(path, jobs)].append(wall)
            peaks[(path, jobs)].append(peak)
    rows = []
    for path, jobs in REPLAY_RUNS:
        wall = statistics.median(walls[(path, jobs)])
        rows.append(
            {
                "path": path,
                "jobs": jobs,
                "frames": frames,
                "hours": hours,
                "runs_wall_s": [round(w, 2) for w in walls[(path, jobs)]],
                "wall_s": round(wall, 2),
                "frames_per_s": round(frames / wall, 1),
                "x_real_time": round(hours * 3600 / wall, 1),
                # with --jobs 2 this is the parent's alone (the workers are its children)
                "peak_rss_mib": round(statistics.median(peaks[(path, jobs)]), 1),
            }
        )
    for row in rows:
        live = next(r for r in rows if r["path"] == "live" and r["jobs"] == row["jobs"])
        row["speed_vs_live"] = round(live["wall_s"] / row["wall_s"], 2)
    return rows


_HELP = (
    "import sys, time; t = time.perf_counter()\n"
    "from casewatch.cli import main\n"
    "try:\n    main(['--help'])\nexcept SystemExit:\n    pass\n"
    "heavy = [m for m in ('numpy', 'numba', 'shapely', 'rtamt', 'pydantic', 'orjson') "
    "if m in sys.modules]\n"
    "print(time.perf_counter() - t, ','.join(heavy), file=sys.stderr)"
)


def help_start_up(repeat: int = 5) -> dict[str, object]:
    """`casewatch --help`: the median wall time of a fresh interpreter running it (process
    start included), and which heavy libraries it imported (target: none)."""
    walls: list[float] = []
    heavy = ""
    for _ in range(repeat):
        start = time.perf_counter()
        done = subprocess.run(
            [sys.executable, "-c", _HELP], cwd=REPO, capture_output=True, text=True, check=True
        )
        walls.append(time.perf_counter() - start)
        heavy = done.stderr.split()[1] if len(done.stderr.split()) > 1 else ""
    return {"wall_s": round(statistics.median(walls), 3), "heavy_imports": heavy}


def count_frames(streams: list[Path]) -> tuple[int, float]:
    frames, seconds = 0, 0.0
    for path in streams:
        with gzip.open(path, "rb") if path.suffix == ".gz" else open(path, "rb") as fh:
            n = sum(1 for line in fh if line.startswith(b'{"t"'))
        frames += n
        seconds += n * 0.1
    return frames, seconds / 3600


def machine() -> dict[str, object]:
    cpu = "unknown"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {
        "cpu": cpu,
        "cores": os.cpu_count(),
        "python": platform.python_version(),
        "platform": platform.platform(),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m bench",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ap.add_argument("--quick", action="store_true", help="short run (smoke test of the suite)")
    ap.add_argument("--hours", type=float, default=8.0, help="length of the replay run")
    ap.add_argument(
        "--repeat", type=int, default=3, help="runs of each replay configuration (medians)"
    )
    args = ap.parse_args(argv)
    hours = 0.05 if args.quick else args.hours
    BENCH.mkdir(exist_ok=True)
    results: dict[str, object] = {"machine": machine()}

    print("1. online latency at reference load ...", flush=True)
    online = online_latency(100 if args.quick else 1000)
    results["online"] = online
    print("2. rtamt update cost per formula ...", flush=True)
    results["rtamt"] = rtamt_cost(200 if args.quick else 2000)

    print("3. offline throughput ...", flush=True)
    streams = bundled_streams()
    frames, bundled_hours = count_frames(streams)
    results["offline_bundled"] = [
        offline(streams, frames, bundled_hours, jobs, BENCH / f"bundled-j{jobs}") for jobs in (1, 2)
    ]
    replay, replay_frames = build_replay(hours, 4, BENCH / "replay")
    repeat = 1 if args.quick else args.repeat
    results["offline_replay"] = replay_paths(replay, replay_frames, hours, repeat)
    try:
        import distributed  # noqa: F401

        print("3b. the replay on a Dask LocalCluster of 1 and 2 workers ...", flush=True)
        results["dask_replay"] = [
            offline(replay, replay_frames, hours, n, BENCH / f"replay-dask{n}", "dask")
            for n in (1, 2)
        ]
        print("3c. the replay on a real Dask scheduler and workers (loopback) ...", flush=True)
        from bench.dask_cluster import measure as cluster_bench

        results["dask_cluster"] = cluster_bench(replay, hours, repeat, BENCH / "dask-cluster")
    except ImportError:
        results["dask_replay"] = []

    print("4. report rendering ...", flush=True)
    from bench.reports import run as report_bench

    results["report"] = report_bench(duration=360.0 if args.quick else 3600.0)

    print("5. kernel start-up and casewatch --help ...", flush=True)
    results["kernels"] = kernel_start_up()
    results["help"] = help_start_up()

    print("7. ROS 2 bags: reading against judging ...", flush=True)
    from bench.bags import measure as bag_bench

    results["bags"] = bag_bench(BENCH / "bags", 200 if args.quick else None)

    print("8. STL engines: rtamt against numpy ...", flush=True)
    from bench.stl import measure as stl_bench

    results["stl_engines"] = stl_bench(0.05 if args.quick else 1.0)

    print("11. where the time goes, both paths, in process ...", flush=True)
    from bench.stages import measure as stages_bench

    results["stages"] = stages_bench(1 if args.quick else 3)

    (BENCH / "results.json").write_text(json.dumps(results, indent=1))
    print_table(results)
    from bench.bags import print_rows as print_bag_rows

    print_bag_rows(results["bags"])
    from bench.stl import print_results as print_stl

    print_stl(results["stl_engines"])
    from bench.stages import print_results as print_stages

    print_stages(results["stages"])
    print(f"\nwritten: {BENCH / 'results.json'}")
    dask = results.get("dask_replay") or []
    if len(dask) == 2:
        speedup = dask[0]["wall_s"] / dask[1]["wall_s"]
        jobs2 = results["offline_replay"][3]["wall_s"]  # --jobs 2, the default path for files
        overhead = dask[1]["wall_s"] / jobs2 - 1
        print(
            f"\nDask LocalCluster, {hours:g} h replay: 1 worker {dask[0]['wall_s']:.1f} s, "
            f"2 workers {dask[1]['wall_s']:.1f} s: speed-up {speedup:.2f}x (goal >= 1.8x: "
            f"{'met' if speedup >= 1.8 else 'MISSED'}); against --jobs 2 ({jobs2:.1f} s): "
            f"{overhead:+.1%} (goal <= +10 %: {'met' if overhead <= 0.10 else 'MISSED'})"
        )
    if results.get("dask_cluster"):
        from bench.dask_cluster import report as cluster_report

        print(cluster_report(results["dask_cluster"]))
    print("\n9. the live page: p50/p99 per frame with no view, 0 and 20 pages open ...", flush=True)
    from bench.live import main as live_bench

    live_bench(["--repeat", "1" if args.quick else "3", "--json", str(BENCH / "live.json")])
    print("\n10. scenario export: every bundled hazard event exported and replayed ...", flush=True)
    from bench.scenario_replay import main as scenario_bench

    unfaithful = scenario_bench()
    print("\n6. threshold tuning on 1 hour of saved signals ...", flush=True)
    from bench.tuning import main as tuning_bench

    return tuning_bench(["--minutes", "1"] if args.quick else []) or unfaithful


def print_table(r: dict) -> None:
    m = r["machine"]
    print(f"\nmachine: {m['cpu']}, {m['cores']} cores, Python {m['python']}")
    o = r["online"]
    print(
        f"\nonline latency per frame, reference load, {o['formulas']} formulas "
        f"({o['frames']} frames)"
    )
    print(f"{'part':<18}{'p50 ms':>9}{'p99 ms':>9}{'max ms':>9}")
    for part in ("read", "metrics", "stl", "episodes_status", "total"):
        v = o[part]
        print(f"{part:<18}{v['p50']:>9.3f}{v['p99']:>9.3f}{v['max']:>9.3f}")
    p99 = o["total"]["p99"]
    print(f"target: total p99 <= 1.0 ms, decoding included: {_verdict(p99 <= 1.0)}")
    print("\nrtamt update cost per formula (µs)")
    for row in r["rtamt"]:
        print(f"  {row['formula']:<6}{row['us_per_update']:>8.1f}  {row['rtamt'][:70]}")
    print(
        f"\n{'run':<22}{'jobs':>5}{'frames':>10}{'hours':>8}{'wall s':>9}"
        f"{'frames/s':>10}{'x real':>9}{'RSS MiB':>9}{'vs live':>9}"
    )
    for name in ("offline_bundled", "offline_replay"):
        for row in r[name]:
            label = f"{name[8:]} {row.get('path', '')}".strip()
            ratio = f"{row['speed_vs_live']:.2f}x" if "speed_vs_live" in row else ""
            print(
                f"{label:<22}{row['jobs']:>5}{row['frames']:>10}{row['hours']:>8.3f}"
                f"{row['wall_s']:>9.1f}{row['frames_per_s']:>10.0f}{row['x_real_time']:>9.0f}"
                f"{row.get('peak_rss_mib', ''):>9}{ratio:>9}"
            )
    rows = {(row["path"], row["jobs"]): row for row in r["offline_replay"]}
    single, jobs2 = rows[("whole-log", 1)], rows[("whole-log", 2)]
    runs = len(single["runs_wall_s"])
    print(f"(replay rows: medians of {runs} interleaved runs)")
    print(
        f"target: whole-log, --jobs 2 >= 1000x real time: {_verdict(jobs2['x_real_time'] >= 1000)}"
    )
    print(f"target: whole-log, one process >= 500x: {_verdict(single['x_real_time'] >= 500)}")
    rss = single["peak_rss_mib"]
    print(f"target: peak RSS of the whole-log run <= 1024 MiB: {_verdict(rss <= 1024)}")
    rep = r["report"]
    print(
        f"\nreport for a {rep['duration_s'] / 3600:g} h run ({rep['episodes']} episodes): "
        f"HTML {rep['html_s']:.3f} s, {rep['html_bytes'] / 1e6:.2f} MB; "
        f"Markdown {rep['md_s']:.3f} s; JUnit {rep['junit_s']:.3f} s"
    )
    print(f"target: 1-hour HTML report < 5 MB: {'met' if rep['html_bytes'] < 5e6 else 'MISSED'}")
    k = r["kernels"]
    print(
        f"\nkernels (import + warm-up): {k['cold_cache_s']:.1f} s with an empty numba cache (a "
        f"machine's first run without the install step); the install step (casewatch warm-up) "
        f"{k['install_step_s']:.1f} s, then the first run {k['first_run_s']:.2f} s; a later run "
        f"{k['warm_cache_s']:.2f} s"
    )
    print(
        "target: kernels ready in <= 5 s on the first run after installing: "
        f"{_verdict(k['first_run_s'] <= 5)} (without the install step: "
        f"{_verdict(k['cold_cache_s'] <= 5)})"
    )
    h = r["help"]
    print(
        f"casewatch --help: {h['wall_s']:.3f} s (heavy imports: {h['heavy_imports'] or 'none'}); "
        f"target < 0.3 s, none: {_verdict(h['wall_s'] < 0.3 and not h['heavy_imports'])}"
    )


def _verdict(met: bool) -> str:
    return "met" if met else "MISSED"


if __name__ == "__main__":
    sys.exit(main())
