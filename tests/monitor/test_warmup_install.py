"""`casewatch warm-up`, the install step that fills numba's cache (issue 36: kernels ready in
<= 5 s on a machine's first run). It must cover every kernel a run takes, the whole-log STL
engine's loops and the compiled reader included (a kernel it misses compiles on the first run
after installing, which is the time the step is there to save): checked in a fresh interpreter
on a bundled drive judged with the reference case by `casewatch run`, the default path."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

PROBE = """
import gc, json, sys
from numba.core.registry import CPUDispatcher
from casewatch.cli import main
from casewatch.commands.warm_up import warm_up_all

def signatures():
    return {f"{d.py_func.__module__}.{d.py_func.__qualname__}": sorted(map(str, d.signatures))
            for d in gc.get_objects()
            if isinstance(d, CPUDispatcher) and d.py_func.__module__.startswith("casewatch.")}

warm_up_all()
before = signatures()
code = main(["run", sys.argv[1], sys.argv[2], "-o", sys.argv[3], "--jobs", "1", "--quiet"])
print(json.dumps({"code": code, "before": before, "after": signatures()}))
"""


def test_warm_up_all_leaves_nothing_to_compile_for_a_run(tmp_path):
    case = ROOT / "examples" / "reference-case.yaml"
    drive = ROOT / "examples" / "data" / "urban-grid.jsonl.gz"
    out = subprocess.run(
        [sys.executable, "-c", PROBE, str(case), str(drive), str(tmp_path / "run")],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=True,
    )
    seen = json.loads(out.stdout.strip().splitlines()[-1])
    assert seen["code"] in (0, 1)  # judged (1: the drive has findings)
    late = {
        name: [s for s in sigs if s not in seen["before"].get(name, [])]
        for name, sigs in seen["after"].items()
    }
    assert {k: v for k, v in late.items() if v} == {}
    # the three families of compiled code the step is for are all in it
    names = set(seen["before"])
    assert "casewatch.evaluator.stl_kernels.past_window" in names
    assert "casewatch.evaluator.stl_kernels.since" in names
    assert "casewatch.evaluator.stl_kernels.until" in names
    assert "casewatch.monitor.bags.decode._walk_objects" in names
    assert "casewatch.monitor.situation._neighbours" in names


def test_warm_up_command_reports_what_it_compiled_and_loaded():
    """Run twice: the second run finds everything in the cache the first one filled (or that
    was filled before), so it compiles nothing and says how many variants it loaded."""
    cmd = [sys.executable, "-m", "casewatch", "warm-up"]
    first = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, check=True)
    assert first.stdout == ""
    second = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, check=True)
    m = re.search(
        r"kernels ready in [\d.]+ s: (\d+) variants compiled, (\d+) loaded from the cache "
        r"\(numba cache: (.+)\)",
        second.stderr,
    )
    assert m, second.stderr
    assert int(m.group(1)) == 0
    assert int(m.group(2)) >= 20  # the top-level kernels (callees are compiled into them)
    assert m.group(3) != "none (caching unavailable)"
    quiet = subprocess.run([*cmd, "--quiet"], cwd=ROOT, capture_output=True, text=True, check=True)
    assert (quiet.stdout, quiet.stderr) == ("", "")
