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
from functools import cache
from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from casewatch.cli import main
from casewatch.monitor.reader import read_stream
from tests.casewatch.fuzz_inputs import (
    CHANNELS,
    ODD_FILES,
    REFERENCE,
    mutated_bags,
    mutated_cases,
    mutated_mappings,
    mutated_streams,
    mutated_uses,
    result_mutation,
)

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
            ran, printed = cli(
                "run",
                str(case),
                str(stream),
                "-o",
                str(Path(tmp) / "o"),
                "--quiet",
                "--format",
                "md",
            )
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
        code, printed = cli(
            "run", str(REFERENCE), str(stream), "-o", str(out), "--quiet", "--format", "none"
        )
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
            statuses = [
                iv["status"]
                for iv in root["timeline"]
                if iv["start"] - 1e-6 <= frame.t <= iv["end"] + 1e-6
            ]
            assert statuses and "satisfied" not in statuses, (frame.t, frame.line, statuses)
    formulas = result["formulas"]
    ticks = sum(root["ticks"].values())
    for f in formulas:  # every tick of every formula is either judged or a data gap
        assert f["ticks_evaluated"] + f["ticks_no_data"] == ticks, f["id"]


# -- issue 31: bags, topic mappings, uses, ODD files, run and fleet folders ------------------


@settings(FUZZ, max_examples=EXAMPLES or 25)
@given(mutated_bags())
def test_mutated_bags_never_crash_run_or_convert(data: bytes) -> None:
    from tests.casewatch.fuzz_inputs import small_bag
    from tests.evaluator.streams import SMALL_CASE

    with tempfile.TemporaryDirectory() as tmp:
        bag, topics, case = Path(tmp) / "b.mcap", Path(tmp) / "t.yaml", Path(tmp) / "c.yaml"
        bag.write_bytes(data)
        topics.write_text(small_bag()[1])
        case.write_text(SMALL_CASE)
        out = Path(tmp) / "o"
        code, printed = cli(
            "run",
            str(case),
            str(bag),
            "--topics",
            str(topics),
            "-o",
            str(out),
            "--quiet",
            "--format",
            "junit",
        )
        assert_no_crash(code, printed, f"run of a bag of {len(data)} bytes")
        if code == 0:  # nothing lost: every frame a bag of 40 ticks holds was judged
            result = json.loads((out / "result.json").read_text())
            assert result["stream"]["defect_count"] == 0, result["stream"]["defects"]
        code, printed = cli("convert", "--list-topics", str(bag))
        assert_no_crash(code, printed, "convert --list-topics")
        code, printed = cli(
            "convert", str(bag), "--topics", str(topics), "-o", str(Path(tmp) / "f.jsonl.gz")
        )
        assert_no_crash(code, printed, "convert to frames")


@settings(FUZZ, max_examples=EXAMPLES or 40)
@given(mutated_mappings())
def test_mutated_topic_mappings_never_crash(text: str) -> None:
    from tests.casewatch.fuzz_inputs import small_bag
    from tests.evaluator.streams import SMALL_CASE

    with tempfile.TemporaryDirectory() as tmp:
        bag, topics, case = Path(tmp) / "b.mcap", Path(tmp) / "t.yaml", Path(tmp) / "c.yaml"
        bag.write_bytes(small_bag()[0])
        topics.write_text(text, encoding="utf-8")
        case.write_text(SMALL_CASE)
        code, printed = cli(
            "run",
            str(case),
            str(bag),
            "--topics",
            str(topics),
            "-o",
            str(Path(tmp) / "o"),
            "--quiet",
            "--format",
            "none",
        )
        assert_no_crash(code, printed, f"a run with the mapping\n{text}")
        if code == 2:
            assert "t.yaml" in printed or "b.mcap" in printed, printed  # names the culprit


@settings(FUZZ, max_examples=EXAMPLES or 30)
@given(mutated_uses())
def test_cases_using_hostile_modules_never_crash_check_or_compile(data) -> None:
    case_text, files = data
    with tempfile.TemporaryDirectory() as tmp:
        for name, text in files.items():
            (Path(tmp) / name).write_text(text, encoding="utf-8")
        case = Path(tmp) / "case.yaml"
        case.write_text(case_text, encoding="utf-8")
        code, printed = cli("check", str(case))
        assert_no_crash(code, printed, f"check of\n{case_text}\nusing {files}")
        code, printed = cli("compile", str(case), "-o", str(Path(tmp) / "c"))
        assert_no_crash(code, printed, "compile")


@settings(FUZZ, max_examples=EXAMPLES or 12)
@given(st.sampled_from(ODD_FILES))
def test_hostile_odd_files_never_crash_check(odd_text: str) -> None:
    from tests.evaluator.streams import SMALL_CASE

    text = (
        SMALL_CASE.replace("  supportedBy: [S1]", "  supportedBy: [S1]\n  inContextOf: [C1]", 1)
        + "C1:\n  text: the ODD\n  odd: odd.yaml\n"
    )
    with tempfile.TemporaryDirectory() as tmp:
        (Path(tmp) / "odd.yaml").write_text(odd_text, encoding="utf-8")
        case = Path(tmp) / "case.yaml"
        case.write_text(text)
        code, printed = cli("check", str(case))
        assert_no_crash(code, printed, f"check with the ODD file\n{odd_text}")


@cache
def _fleet() -> bytes:
    """A fleet folder (two small logs, signals saved) as a tar archive, judged once."""
    import io as _io
    import tarfile

    from tests.evaluator.streams import SMALL_CASE, write_stream

    with tempfile.TemporaryDirectory() as tmp:
        logs = Path(tmp) / "logs"
        logs.mkdir()
        write_stream(logs / "a.jsonl", frames=60)
        write_stream(logs / "b.jsonl", frames=40)
        (Path(tmp) / "case.yaml").write_text(SMALL_CASE)
        code, printed = cli(
            "run",
            str(Path(tmp) / "case.yaml"),
            str(logs),
            "-o",
            str(Path(tmp) / "fleet"),
            "--quiet",
            "--format",
            "none",
            "--save-signals",
        )
        assert code == 1, printed
        buffer = _io.BytesIO()
        with tarfile.open(fileobj=buffer, mode="w") as tar:
            tar.add(tmp, arcname=".")
        return buffer.getvalue()


@settings(FUZZ, max_examples=EXAMPLES or 20)
@given(st.data())
def test_mutated_run_and_fleet_folders_never_crash_the_commands_that_read_them(data) -> None:
    import io as _io
    import tarfile

    with tempfile.TemporaryDirectory() as tmp:
        with tarfile.open(fileobj=_io.BytesIO(_fleet())) as tar:
            tar.extractall(tmp, filter="data")
        root = Path(tmp)
        fleet = root / "fleet"
        target = data.draw(st.sampled_from(["a/result.json", "b/result.json", "summary.json"]))
        record = json.loads((fleet / target).read_text())
        data.draw(result_mutation(record))
        (fleet / target).write_text(json.dumps(record))
        case, logs = str(root / "case.yaml"), str(root / "logs")
        for argv in (
            ["report", str(fleet / "a")],
            ["report", str(fleet)],
            ["compare", str(fleet), "-o", str(root / "cmp"), "--by", "test"],
            ["odd", str(fleet), "-o", str(root / "odd")],
            ["diff", str(fleet), str(fleet), "-o", str(root / "diff")],
            ["run", case, logs, "-o", str(fleet), "--quiet", "--format", "none", "--resume"],
        ):
            code, printed = cli(*argv)
            assert_no_crash(code, printed, f"{argv[0]} after setting {target} to\n{record}")
