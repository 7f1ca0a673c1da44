"""warm_up also covers the kernels a case's metric options switch on (issue 36: a kernel left
to compile on the first real frames is first-run time the start-up benchmark does not see).
Checked in a fresh interpreter on a bundled drive judged with the reference case, which sets
every such option (plan smoothing, standing objects and plans, range-scaled tolerances)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

PROBE = """
import gc, json, sys
from numba.core.registry import CPUDispatcher
from casewatch import api
from casewatch.evaluator.options import RunOptions
from casewatch.evaluator.session import evaluate_stream
from casewatch.monitor.warmup import warm_up

def signatures():
    return {f"{d.py_func.__module__}.{d.py_func.__name__}": sorted(map(str, d.signatures))
            for d in gc.get_objects()
            if isinstance(d, CPUDispatcher)
            and d.py_func.__module__.startswith("casewatch.monitor")}

warm_up()
before = signatures()
case, spec = api.prepare(sys.argv[1])
evaluate_stream(case, spec, sys.argv[2], RunOptions(stl_engine="rtamt"))
print(json.dumps({"before": before, "after": signatures()}))
"""


def test_warm_up_leaves_nothing_to_compile_for_the_reference_case():
    case = ROOT / "examples" / "reference-case.yaml"
    drive = ROOT / "examples" / "data" / "urban-grid.jsonl.gz"
    out = subprocess.run(
        [sys.executable, "-c", PROBE, str(case), str(drive)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=True,
    )
    seen = json.loads(out.stdout.strip().splitlines()[-1])
    compiled_late = {
        name: [s for s in sigs if s not in seen["before"].get(name, [])]
        for name, sigs in seen["after"].items()
    }
    assert {k: v for k, v in compiled_late.items() if v} == {}
    assert "casewatch.monitor.prediction._standing_counts" in seen["before"]
