"""warm_up compiles every kernel variant real streams need (checked in a fresh interpreter, so
kernels compiled by other tests cannot hide a gap)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

PROBE = """
import gzip, io, json, sys
from numba.core.registry import CPUDispatcher
from casewatch.monitor import comfort, history, parse, prediction, resample
from casewatch.monitor import safety_kernel, safety_score, similarity
from casewatch.monitor.warmup import warm_up
from casewatch.monitor.engine import MetricEngine
from casewatch.monitor.reader import read_stream
from bench.metrics import CHANNELS, reference_load_frames
from casewatch.safety_case.model import MetricParams

MODULES = [comfort, history, parse, prediction, resample, safety_kernel, safety_score, similarity]

def signatures():
    return {f"{m.__name__}.{k}": sorted(map(str, v.signatures))
            for m in MODULES for k, v in vars(m).items() if isinstance(v, CPUDispatcher)}

warm_up()
before = signatures()
text = io.TextIOWrapper(gzip.open(sys.argv[1]), encoding="utf-8")
engine = MetricEngine(MetricParams(), ["lav", "tfuse"])
for frame in read_stream(text, channels=["lav", "tfuse"]):
    engine.step(frame)
engine = MetricEngine(MetricParams(), CHANNELS)
for frame in reference_load_frames(40):
    engine.step(frame)
after = signatures()
print(json.dumps({"before": before, "after": after}))
"""


def test_warm_up_leaves_nothing_to_compile_for_real_streams():
    drive = ROOT / "examples" / "data" / "highway-tailgated.jsonl.gz"
    out = subprocess.run(
        [sys.executable, "-c", PROBE, str(drive)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=True,
        timeout=600,
    )
    got = json.loads(out.stdout.strip().splitlines()[-1])
    before, after = got["before"], got["after"]
    assert before and any(before.values())  # the probe found compiled kernels at all
    new = {k: v for k, v in after.items() if v != before[k]}
    assert new == {}, f"compiled only after warm_up: {new}"
