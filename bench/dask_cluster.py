"""Fleets on a real Dask cluster: a `dask scheduler` and `dask worker` processes on loopback.

`make bench` part 3c (`bench/suite.py`); alone: `python -m bench.dask_cluster --hours 1`.
The replay's files are judged by `casewatch run --engine dask --scheduler ADDRESS` on 1 and on
2 worker processes (single-threaded, each with its nanny, every port on 127.0.0.1), and by
`--jobs 2`, interleaved `repeat` times (medians): the speed-up from 1 to 2 workers and the
cost of 2 workers against `--jobs 2`. Each cluster first judges one file unmeasured (a new
worker loads casewatch and its compiled kernels once). Last, a `--resume` run after half the
logs' folders were removed: its rate counts only the hours it judged, not the logs it reused.

`LoopbackCluster` is also what the test suite's real-cluster tests start.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
CASE = REPO / "examples" / "reference-case.yaml"
DASK = Path(sys.executable).with_name("dask")


class LoopbackCluster:
    """A scheduler and `workers` worker processes on 127.0.0.1 (dashboards too, on free ports),
    started in `folder` (their working directory); `close` kills the process groups it
    started. `env` is added to their environment; each worker runs the `preload` files
    (`dask worker --preload`) before it takes a task."""

    def __init__(
        self,
        folder: Path,
        workers: int,
        env: dict[str, str] | None = None,
        preload: list[Path] | None = None,
    ) -> None:
        folder.mkdir(parents=True, exist_ok=True)
        self.folder = folder
        self.env = dict(os.environ, **(env or {}))
        self.preload = [str(p) for p in preload or []]
        self.processes: list[subprocess.Popen] = []
        info = folder / "scheduler.json"
        info.unlink(missing_ok=True)
        loopback = ["--host", "127.0.0.1", "--dashboard-address", "127.0.0.1:0"]
        self.scheduler = self._start(
            "scheduler", *loopback, "--port", "0", "--scheduler-file", str(info)
        )
        deadline = time.monotonic() + 60
        while not info.is_file() and time.monotonic() < deadline:
            if self.scheduler.poll() is not None:
                raise RuntimeError(f"dask scheduler exited: see {folder}")
            time.sleep(0.1)
        self.address: str = json.loads(info.read_text())["address"]
        for _ in range(workers):
            self.add_worker()
        from distributed import Client

        with Client(self.address, timeout="30s") as client:
            client.wait_for_workers(workers, timeout=120)

    def _start(self, *args: str) -> subprocess.Popen:
        with (self.folder / f"{args[0]}-{len(self.processes)}.log").open("w") as log:
            proc = subprocess.Popen(
                [str(DASK), *args],
                cwd=self.folder,
                env=self.env,
                stdout=log,
                stderr=subprocess.STDOUT,
                start_new_session=True,  # its own process group: the nanny's worker too
            )
        self.processes.append(proc)
        return proc

    def add_worker(self) -> None:
        loopback = ["--host", "127.0.0.1", "--dashboard-address", "127.0.0.1:0"]
        preload = [arg for path in self.preload for arg in ("--preload", path)]
        self._start(
            "worker",
            self.address,
            *loopback,
            *preload,
            "--nthreads",
            "1",
            "--memory-limit",
            "0",
        )

    def kill_scheduler(self) -> None:
        os.killpg(self.scheduler.pid, signal.SIGKILL)
        self.scheduler.wait(timeout=30)

    def close(self) -> None:
        for proc in self.processes:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGKILL)
            proc.wait(timeout=30)

    def __enter__(self) -> LoopbackCluster:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _run(args: list[str]) -> tuple[float, int]:
    """`casewatch ARGS` in a child process: wall seconds and exit code (0/1 expected)."""
    started = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-m", "casewatch", *args], capture_output=True, text=True, check=False
    )
    wall = time.perf_counter() - started
    if done.returncode not in (0, 1):
        raise RuntimeError(f"casewatch {' '.join(args)} failed: {done.stderr[-2000:]}")
    return wall, done.returncode


def _fleet_args(streams: list[Path], out: Path, *extra: str) -> list[str]:
    args = ["run", str(CASE), *map(str, streams), "-o", str(out), "--format", "none"]
    return [*args, "--quiet", *extra]


def measure(streams: list[Path], hours: float, repeat: int, folder: Path) -> dict:
    """Walls of 1 and 2 external workers and of --jobs 2 on `streams` (medians of `repeat`
    interleaved runs), and a half-resumed run's rate over the hours it judged."""
    walls: dict[str, list[float]] = {"workers1": [], "workers2": [], "jobs2": []}
    with (
        tempfile.TemporaryDirectory() as tmp,
        LoopbackCluster(Path(tmp) / "one", 1) as one,
        LoopbackCluster(Path(tmp) / "two", 2) as two,
    ):
        clusters = {"workers1": one.address, "workers2": two.address}
        for name, address in clusters.items():  # workers load casewatch, unmeasured
            dask = ("--engine", "dask", "--scheduler", address)
            _run(_fleet_args(streams[:2], folder / f"warm-{name}", *dask))
        for _ in range(repeat):
            for name, address in clusters.items():
                out = folder / name
                shutil.rmtree(out, ignore_errors=True)
                args = _fleet_args(streams, out, "--engine", "dask", "--scheduler", address)
                walls[name].append(round(_run(args)[0], 2))
            out = folder / "jobs2"
            shutil.rmtree(out, ignore_errors=True)
            walls["jobs2"].append(round(_run(_fleet_args(streams, out, "--jobs", "2"))[0], 2))
        resumed = _resumed_rate(streams, folder / "workers2", two.address)
    med = {name: statistics.median(w) for name, w in walls.items()}
    return {
        "hours": round(hours, 4),
        "logs": len(streams),
        "walls": walls,
        "median_s": med,
        "speed_up": round(med["workers1"] / med["workers2"], 3),
        "overhead_vs_jobs2": round(med["workers2"] / med["jobs2"] - 1, 4),
        "resumed": resumed,
    }


def _resumed_rate(streams: list[Path], out: Path, address: str) -> dict:
    """Half the logs' folders removed, then `--resume`: the hours it judged, the hours it
    reused, and its rate over the judged hours only."""
    summary = json.loads((out / "summary.json").read_text())
    logs = summary["per_log"]
    for log in logs[: len(logs) // 2]:
        shutil.rmtree(log["out_dir"])
    dask = ("--engine", "dask", "--scheduler", address, "--resume")
    wall, _ = _run(_fleet_args(streams, out, *dask))
    after = json.loads((out / "summary.json").read_text())["per_log"]
    judged = sum(log["duration_s"] for log in after if log["seconds"] > 0) / 3600
    reused = sum(log["duration_s"] for log in after if log["seconds"] == 0) / 3600
    return {
        "wall_s": round(wall, 2),
        "judged_h": round(judged, 4),
        "reused_h": round(reused, 4),
        "x_real_time_judged": round(judged * 3600 / wall, 1),
    }


def report(r: dict) -> str:
    """The lines `make bench` prints for this part."""
    med = r["median_s"]
    res = r["resumed"]
    return (
        f"\nDask, a real scheduler and workers on loopback, {r['hours']:g} h in {r['logs']} "
        f"logs (medians of {len(r['walls']['jobs2'])}): 1 worker {med['workers1']:.1f} s, "
        f"2 workers {med['workers2']:.1f} s: speed-up {r['speed_up']:.2f}x (goal >= 1.8x: "
        f"{'met' if r['speed_up'] >= 1.8 else 'MISSED'}); against --jobs 2 "
        f"({med['jobs2']:.1f} s): {r['overhead_vs_jobs2']:+.1%} (goal <= +10 %: "
        f"{'met' if r['overhead_vs_jobs2'] <= 0.10 else 'MISSED'})\n"
        f"  --resume with half the logs done: judged {res['judged_h']:.3f} h (reused "
        f"{res['reused_h']:.3f} h, not counted) in {res['wall_s']:.1f} s, "
        f"{res['x_real_time_judged']:g}x real time over the judged hours"
    )


def main(argv: list[str] | None = None) -> int:
    from bench.suite import BENCH, build_replay

    ap = argparse.ArgumentParser(prog="python -m bench.dask_cluster", description=__doc__)
    ap.add_argument("--hours", type=float, default=1.0, help="length of the replay")
    ap.add_argument("--repeat", type=int, default=2, help="interleaved runs of each (medians)")
    args = ap.parse_args(argv)
    BENCH.mkdir(parents=True, exist_ok=True)
    replay, _ = build_replay(args.hours, 4, BENCH / "replay")
    result = measure(replay, args.hours, args.repeat, BENCH / "dask-cluster")
    (BENCH / "dask_cluster.json").write_text(json.dumps(result, indent=1))
    print(report(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
