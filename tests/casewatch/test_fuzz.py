"""The fuzz corpus of issue 23: mutated cases and streams through the real CLI, in-process.

Properties: no traceback and an exit code in {0, 1, 2} (3 would be a crash; its log is shown),
and no tick reads `satisfied` where data was missing. Example counts are fixed and small so the
whole module runs in well under a minute; raise them locally to hunt (`FUZZ_EXAMPLES=500`).
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import re
import tempfile
from pathlib import Path

from hypothesis import HealthCheck, given, settings

from casewatch.cli import main
from monitor.reader import read_stream
from tests.casewatch.fuzz_inputs import CHANNELS, REFERENCE, mutated_cases, mutated_streams

EXAMPLES = int(os.environ.get("FUZZ_EXAMPLES", "0"))
FUZZ = settings(
    deadline=None,
    derandomize=EXAMPLES == 0,  # CI: the same examples every run; locally: explore
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
    database=None,
)


def cli(*argv: str) -> tuple[int, str]:
    """Run the CLI in-process; returns the exit code and everything it printed."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(list(argv))
    printed = out.getvalue() + err.getvalue()
    return code, printed


def assert_no_crash(code: int, printed: str, what: str) -> None:
    assert "Traceback" not in printed, printed
    if code == 3:  # show the traceback the crash log holds
        match = re.search(r"please attach (\S+) to a bug report", printed)
        log = Path(match.group(1)).read_text() if match else printed
        raise AssertionError(f"internal error on {what}:\n{log}")
    assert code in (0, 1, 2), (code, printed)


@settings(FUZZ, max_examples=EXAMPLES or 60)
@given(mutated_cases())
def test_mutated_cases_never_crash_check_compile_or_run(text: str) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        case = Path(tmp) / "case.yaml"
        case.write_text(text, encoding="utf-8")
        code, printed = cli("check", str(case))
        assert_no_crash(code, printed, f"check of\n{text}")
        compiled, printed = cli("compile", str(case), "-o", str(Path(tmp) / "c"))
        assert_no_crash(compiled, printed, f"compile of\n{text}")
        assert (code == 1) == (compiled == 2) or code == 2, (code, compiled, printed)
        if code == 0:  # a case that passes check must also run
            stream = Path(tmp) / "s.jsonl"
            stream.write_text(short_stream())
            ran, printed = cli("run", str(case), str(stream), "-o", str(Path(tmp) / "o"),
                               "--quiet", "--format", "md")
            assert_no_crash(ran, printed, f"run of\n{text}")


def short_stream() -> str:
    from tests.casewatch.fuzz_inputs import bundled_rows

    return "\n".join(bundled_rows()[:41]) + "\n"


@settings(FUZZ, max_examples=EXAMPLES or 40)
@given(mutated_streams())
def test_mutated_streams_never_crash_and_missing_data_is_never_satisfied(data: bytes) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        stream = Path(tmp) / "s.jsonl"
        stream.write_bytes(data)
        out = Path(tmp) / "o"
        code, printed = cli("run", str(REFERENCE), str(stream), "-o", str(out), "--quiet",
                            "--format", "none")
        assert_no_crash(code, printed, f"a stream of {len(data)} bytes")
        result_path = out / "result.json"
        if not result_path.exists():
            assert code == 2, printed  # unusable input, said so, nothing judged
            return
        result = json.loads(result_path.read_text())
        assert_never_satisfied_without_data(stream, result)


def assert_never_satisfied_without_data(stream: Path, result: dict) -> None:
    """At every frame that lacks a declared channel, the root goal is not `satisfied`: every
    formula of the reference case reads metrics of both channels."""
    root = next(s for s in result["status"] if s["node_id"] == result["case"]["root_id"])
    reader = read_stream(stream, channels=CHANNELS, period=result["case"]["period"])
    with contextlib.suppress(UnicodeDecodeError):  # judged up to there, like the run
        for frame in reader:
            if set(CHANNELS) <= set(frame.channels):
                continue
            statuses = [iv["status"] for iv in root["timeline"]
                        if iv["start"] - 1e-6 <= frame.t <= iv["end"] + 1e-6]  # fmt: skip
            assert statuses and "satisfied" not in statuses, (frame.t, frame.line, statuses)
    formulas = result["formulas"]
    ticks = sum(root["ticks"].values())
    for f in formulas:  # every tick of every formula is either judged or a data gap
        assert f["ticks_evaluated"] + f["ticks_no_data"] == ticks, f["id"]
