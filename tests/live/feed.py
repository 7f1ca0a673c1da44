"""Feeding a drive into `casewatch run CASE - --serve 0` at real time, for the live tests.

A drive's frames are written to the child's standard input when their stream time comes due
on the wall clock (t - t_first, scaled by `speed`), and the wall time each frame was written
is kept, so a test can compare when the page showed a status with when its frame was sent.
"""

from __future__ import annotations

import gzip
import json
import os
import re
import subprocess
import sys
import threading
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
CASE = REPO / "examples" / "reference-case.yaml"
DRIVE = REPO / "examples" / "data" / "highway-tailgating.jsonl.gz"


def drive_lines(path: Path, t_from: float, t_to: float) -> tuple[str, list[tuple[float, str]]]:
    """The drive's header line and its frames with t_from <= t < t_to, as (t, line)."""
    opener = gzip.open if path.suffix == ".gz" else open
    header = ""
    frames: list[tuple[float, str]] = []
    with opener(path, "rt", encoding="utf-8") as fh:
        for line in fh:
            record = json.loads(line)
            if "header" in record:
                header = line
                continue
            if t_from - 1e-9 <= record["t"] < t_to - 1e-9:
                frames.append((record["t"], line))
    return header, frames


class LiveRun:
    """`casewatch run CASE - --serve 0 ...` as a child process, fed by `feed()`."""

    def __init__(self, out: Path, *extra: str) -> None:
        env = dict(os.environ, PYTHONUNBUFFERED="1")
        self.process = subprocess.Popen(
            [
                *(sys.executable, "-m", "casewatch", "run", str(CASE), "-", "--serve", "0"),
                *("-o", str(out), "--format", "none", *extra),
            ],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            cwd=REPO,
            env=env,
            text=True,
        )
        self.stderr: list[str] = []
        self.url = self._wait_for_url()
        self.sent: dict[float, float] = {}  # stream t -> wall time (time.time()) it was written

    def _wait_for_url(self, timeout: float = 60.0) -> str:
        deadline = time.monotonic() + timeout
        assert self.process.stderr is not None
        while time.monotonic() < deadline:
            line = self.process.stderr.readline()
            if not line:
                break
            self.stderr.append(line)
            found = re.search(r"live page at (http://\S+)", line)
            if found:
                threading.Thread(target=self._drain_stderr, daemon=True).start()
                return found.group(1)
        self.process.kill()
        raise RuntimeError("casewatch run did not print its live page: " + "".join(self.stderr))

    def _drain_stderr(self) -> None:
        assert self.process.stderr is not None
        for line in self.process.stderr:
            self.stderr.append(line)

    def feed(self, header: str, frames: list[tuple[float, str]], speed: float = 1.0) -> None:
        """Write the header, then each frame when its time comes; close standard input."""
        stdin = self.process.stdin
        assert stdin is not None
        stdin.write(header)
        stdin.flush()
        start = time.monotonic()
        t0 = frames[0][0]
        try:
            for t, line in frames:
                delay = start + (t - t0) / speed - time.monotonic()
                if delay > 0:
                    time.sleep(delay)
                stdin.write(line)
                stdin.flush()
                self.sent[round(t, 6)] = time.time()
            stdin.close()
        except BrokenPipeError:  # the run ended (or was killed by a failing test)
            pass

    def feed_in_background(self, header: str, frames: list[tuple[float, str]]) -> threading.Thread:
        thread = threading.Thread(target=self.feed, args=(header, frames), daemon=True)
        thread.start()
        return thread

    def wait(self, timeout: float = 60.0) -> int:
        return self.process.wait(timeout=timeout)
