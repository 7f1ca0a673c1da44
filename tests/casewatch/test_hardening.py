"""Issue 23: inputs that used to crash casewatch, each now a finding or a defect (no traceback)."""

from __future__ import annotations

import gzip
import json
from pathlib import Path

import pytest

from casewatch.cli import main
from tests.evaluator.streams import frame, write_case, write_stream

REPO = Path(__file__).resolve().parents[2]
REFERENCE = REPO / "examples" / "reference-case.yaml"


def test_reference_case_without_its_root_goal_is_a_finding(tmp_path, capsys):
    text = REFERENCE.read_text()
    start = text.index("\nG1:\n")
    end = text.index("\n\n", start + 1)
    path = tmp_path / "no-root.yaml"
    path.write_text(text[:start] + text[end:])
    assert main(["check", str(path)]) == 1
    assert main(["compile", str(path), "-o", str(tmp_path / "c")]) == 2
    assert main(["run", str(path), "-", "-o", str(tmp_path / "o")]) == 2
    out, err = capsys.readouterr()
    assert "CW036 error: the argument starts at S1" in out and "Traceback" not in out + err


def test_supported_by_cycle_without_root_is_a_finding(tmp_path, capsys):
    path = tmp_path / "cycle.yaml"
    path.write_text(
        "module: {name: t}\nmonitor: {channels: [lav, tfuse]}\n"
        "G1: {text: a, supportedBy: [G2]}\nG2: {text: b, supportedBy: [G1, Sn1]}\n"
        "Sn1:\n  text: e\n  spi: {signal: els, threshold: '>= 0.6'}\n"
    )
    assert main(["check", str(path)]) == 1
    out = capsys.readouterr().out
    assert ":3:1: CW035 error: no root goal" in out and "CW034" in out


def test_truncated_gzip_stream_judges_the_frames_before_and_writes_result(tmp_path, capsys):
    case = write_case(tmp_path / "case.yaml")
    plain = write_stream(tmp_path / "s.jsonl").read_bytes()
    whole = gzip.compress(plain, mtime=0)
    stream = tmp_path / "half.jsonl.gz"
    stream.write_bytes(whole[: len(whole) // 2])
    code = main(["run", str(case), str(stream), "-o", str(tmp_path / "o"), "--format", "none"])
    assert code in (0, 1)
    result = json.loads((tmp_path / "o" / "result.json").read_text())
    defect = result["stream"]["defects"][-1]
    assert defect["kind"] == "truncated-stream"
    assert 0 < result["stream"]["frames_read"] == defect["line"] - 2  # header on line 1


def test_five_byte_gzip_is_unusable_input_not_a_crash(tmp_path, capsys):
    case = write_case(tmp_path / "case.yaml")
    stream = tmp_path / "five.jsonl.gz"
    stream.write_bytes(b"\x1f\x8b\x08\x00\x00")
    assert main(["run", str(case), str(stream), "-o", str(tmp_path / "o"), "--quiet"]) == 2
    result = json.loads((tmp_path / "o" / "result.json").read_text())
    assert result["stream"]["defects"][0]["kind"] == "truncated-stream"


def test_deeply_nested_line_is_one_malformed_json_defect(tmp_path):
    case = write_case(tmp_path / "case.yaml")
    stream = tmp_path / "deep.jsonl"
    rows = [json.dumps(frame(i)) for i in range(40)]
    rows.insert(20, "[" * 100_000)
    stream.write_text("\n".join(rows) + "\n")
    code = main(
        ["run", str(case), str(stream), "-o", str(tmp_path / "o"), "--format", "none", "--quiet"]
    )
    assert code in (0, 1)
    result = json.loads((tmp_path / "o" / "result.json").read_text())
    assert [(d["line"], d["kind"]) for d in result["stream"]["defects"]] == [(21, "malformed-json")]
    assert result["stream"]["frames_read"] == 40


# -- exit codes ----------------------------------------------------------------------------------


def test_internal_error_exits_3_with_one_line_and_the_traceback_in_the_output_folder(
    tmp_path, capsys, monkeypatch
):
    case = write_case(tmp_path / "case.yaml")
    stream = write_stream(tmp_path / "s.jsonl")

    def boom(*args, **kwargs):
        raise ZeroDivisionError("forced for the test")

    monkeypatch.setattr("casewatch.commands.run.evaluate_stream", boom)
    out = tmp_path / "out"
    assert main(["run", str(case), str(stream), "-o", str(out), "--quiet"]) == 3
    captured = capsys.readouterr()
    (line,) = captured.err.strip().splitlines()
    log = out / "casewatch-crash.log"
    assert line.startswith("casewatch: internal error (ZeroDivisionError: forced for the test)")
    assert str(log) in line and "Traceback" not in captured.out + captured.err
    text = log.read_text()
    assert "Traceback (most recent call last)" in text and f"command: casewatch run {case}" in text


def test_internal_error_without_output_folder_logs_to_a_temporary_file(capsys, monkeypatch):
    def boom(*args, **kwargs):
        raise RuntimeError("forced")

    monkeypatch.setattr("casewatch.api.check", boom)
    assert main(["check", str(REFERENCE)]) == 3
    line = capsys.readouterr().err.strip()
    path = Path(line.split("please attach ", 1)[1].split(" to a bug report")[0])
    try:
        assert path.name.startswith("casewatch-crash-")
        assert "RuntimeError: forced" in path.read_text()
    finally:
        path.unlink()


def test_a_crash_in_one_of_many_logs_exits_3_and_the_others_are_judged(tmp_path, monkeypatch):
    case = write_case(tmp_path / "case.yaml")
    logs = tmp_path / "logs"
    logs.mkdir()
    write_stream(logs / "a.jsonl")
    write_stream(logs / "b.jsonl", frames=50)
    real = __import__("casewatch.batch", fromlist=["evaluate_stream"]).evaluate_stream

    def flaky(case_value, spec, stream, *rest):
        if stream.endswith("b.jsonl"):
            raise KeyError("forced")
        return real(case_value, spec, stream, *rest)

    monkeypatch.setattr("casewatch.batch.evaluate_stream", flaky)
    out = tmp_path / "out"
    assert main(["run", str(case), str(logs), "-o", str(out), "--quiet", "--format", "none"]) == 3
    summary = json.loads((out / "summary.json").read_text())
    assert (summary["logs_failed"], summary["logs_crashed"]) == (1, 1)
    assert (out / "a" / "result.json").exists() and (out / "b" / "casewatch-crash.log").exists()


def _stream_without_tfuse(path: Path, frames: int = 60) -> Path:
    rows = []
    for i in range(frames):
        row = frame(i)
        row["channels"].pop("tfuse", None)
        rows.append(json.dumps(row))
    path.write_text("\n".join(rows) + "\n")
    return path


def test_root_goal_without_data_on_most_ticks_is_unusable_input_not_a_pass(tmp_path, capsys):
    case = write_case(tmp_path / "case.yaml")
    stream = _stream_without_tfuse(tmp_path / "s.jsonl")
    out = tmp_path / "o"
    assert main(["run", str(case), str(stream), "-o", str(out), "--format", "none"]) == 2
    captured = capsys.readouterr()
    assert "root goal G1 had no data on 100.0% of 60 ticks (limit 50%" in captured.err
    assert "root goal without data on 60 of 60 ticks (100.0%; limit 50%)" in captured.out
    no_data = json.loads((out / "result.json").read_text())["root_no_data"]
    assert no_data == {
        "ticks": 60,
        "no_data_ticks": 60,
        "share": 1.0,
        "limit": 0.5,
        "exceeded": True,
    }
    # the limit is the user's: with 1 (anything goes) the same run is an ordinary pass
    assert (
        main(
            [
                "run",
                str(case),
                str(stream),
                "-o",
                str(out),
                "--format",
                "none",
                "--quiet",
                "--max-no-data",
                "1",
            ]
        )
        == 0
    )


def test_half_the_ticks_without_data_is_within_the_default_limit(tmp_path):
    case = write_case(tmp_path / "case.yaml")
    rows = [frame(i) for i in range(30, 50)]  # 3.0-4.9 s: tfuse 2 m off only at 3.0 s
    for row in rows[:10]:  # tfuse missing from 3.0 to 3.9 s: 10 of 20 ticks without data
        row["channels"].pop("tfuse")
    stream = tmp_path / "s.jsonl"
    stream.write_text("".join(json.dumps(r) + "\n" for r in rows))
    out = tmp_path / "o"
    assert main(["run", str(case), str(stream), "-o", str(out), "--format", "none", "--quiet"]) == 0
    assert json.loads((out / "result.json").read_text())["root_no_data"]["share"] == 0.5
    assert (
        main(
            [
                "run",
                str(case),
                str(stream),
                "-o",
                str(out),
                "--format",
                "none",
                "--quiet",
                "--max-no-data",
                "0.4",
            ]
        )
        == 2
    )


@pytest.mark.parametrize("bad", ["1.5", "-0.1", "nan", "half"])
def test_max_no_data_must_be_a_share(tmp_path, bad, capsys):
    case = write_case(tmp_path / "case.yaml")
    assert main(["run", str(case), "-", "-o", str(tmp_path), "--max-no-data", bad]) == 2
    assert "--max-no-data" in capsys.readouterr().err


def test_many_logs_with_too_little_data_exit_2(tmp_path):
    case = write_case(tmp_path / "case.yaml")
    logs = tmp_path / "logs"
    logs.mkdir()
    _stream_without_tfuse(logs / "a.jsonl")
    out = tmp_path / "out"
    assert main(["run", str(case), str(logs), "-o", str(out), "--quiet", "--format", "none"]) == 2
    summary = json.loads((out / "summary.json").read_text())
    assert summary["logs_without_data"] == 1 and summary["per_log"][0]["no_data_share"] == 1.0


def test_bundled_drive_stays_well_within_the_no_data_limit(tmp_path):
    # warm-up gaps are real gaps: the bundled drives' root goal reads no-data on 2-3 % of ticks
    out = tmp_path / "o"
    stream = REPO / "examples" / "data" / "highway-tailgating.jsonl.gz"
    assert (
        main(["run", str(REFERENCE), str(stream), "-o", str(out), "--quiet", "--format", "none"])
        == 1
    )
    no_data = json.loads((out / "result.json").read_text())["root_no_data"]
    assert 0 < no_data["share"] < 0.1 and not no_data["exceeded"]


# -- issue 31: non-finite robustness ---------------------------------------------------------


@pytest.mark.parametrize("engine", ["rtamt", "numpy", "both"])
@pytest.mark.parametrize(
    ("old", "new"),
    [
        ('hazard: {when: "speed > 20"}', 'hazard: {when: "historically[1s:2s] (speed > 5)"}'),
        ('spi: {signal: els, threshold: ">= 0.6"}', 'spi: {stl: "once[1s:2s] (els >= 0.6)"}'),
    ],
)
def test_infinite_robustness_is_written_read_and_rendered(tmp_path, capsys, old, new, engine):
    """The issue's reproductions: -inf at the first second was a crash writing events.jsonl."""
    from tests.evaluator.streams import SMALL_CASE

    case = tmp_path / "case.yaml"
    case.write_text(SMALL_CASE.replace(old, new))
    assert main(["check", str(case)]) == 0
    assert "CW050 warning" in capsys.readouterr().out
    stream = write_stream(tmp_path / "s.jsonl")
    out = tmp_path / "o"
    assert (
        main(["run", str(case), str(stream), "-o", str(out), "--quiet", "--stl-engine", engine])
        == 1
    )
    first = json.loads((out / "result.json").read_text())["episodes"][0]
    assert (first["start"], first["worst_robustness"]) == (0.0, "-Infinity")
    events = [json.loads(line) for line in (out / "events.jsonl").read_text().splitlines()]
    assert any(e.get("worst_robustness") == "-Infinity" for e in events)
    from casewatch.reports.render import load_result

    episode = load_result(out / "result.json").episodes[0]
    assert episode.worst_robustness == float("-inf")
    assert main(["report", str(out), "--format", "html,md,junit"]) == 0
    assert "worst robustness -inf" in (out / "report.md").read_text()


# -- issue 31: exit codes that say one thing -------------------------------------------------


def _disagreeing_engines(monkeypatch) -> None:
    """The numpy engine off by one at every value: `--stl-engine both` must catch it."""
    import casewatch.evaluator.session as session
    from casewatch.evaluator.stl_engines import WholeLog

    real = session.evaluate_whole_log

    def off_by_one(*args, **kwargs):
        whole = real(*args, **kwargs)
        return WholeLog({k: v + 1.0 for k, v in whole.values.items()}, whole.ticks, whole.t)

    monkeypatch.setattr(session, "evaluate_whole_log", off_by_one)


def test_engines_disagreeing_exit_4_not_3(tmp_path, capsys, monkeypatch):
    _disagreeing_engines(monkeypatch)
    case, stream = write_case(tmp_path / "case.yaml"), write_stream(tmp_path / "s.jsonl")
    assert (
        main(
            [
                "run",
                str(case),
                str(stream),
                "-o",
                str(tmp_path / "o"),
                "--quiet",
                "--stl-engine",
                "both",
            ]
        )
        == 4
    )
    assert "the rtamt and numpy STL engines disagree on" in capsys.readouterr().err


def test_a_fleet_with_disagreeing_engines_exits_4_and_says_so_even_quiet(
    tmp_path, capsys, monkeypatch
):
    _disagreeing_engines(monkeypatch)
    case = write_case(tmp_path / "case.yaml")
    logs = tmp_path / "logs"
    logs.mkdir()
    write_stream(logs / "a.jsonl")
    out = tmp_path / "out"
    assert (
        main(
            [
                "run",
                str(case),
                str(logs),
                "-o",
                str(out),
                "--quiet",
                "--format",
                "none",
                "--stl-engine",
                "both",
            ]
        )
        == 4
    )
    summary = json.loads((out / "summary.json").read_text())
    assert (summary["logs_crashed"], summary["logs_engines_disagree"]) == (0, 1)
    err = capsys.readouterr().err
    assert "a.jsonl: the rtamt and numpy STL engines disagree on" in err


def test_a_quiet_fleet_with_a_crashing_log_names_it(tmp_path, capsys, monkeypatch):
    case = write_case(tmp_path / "case.yaml")
    logs = tmp_path / "logs"
    logs.mkdir()
    write_stream(logs / "a.jsonl")

    def boom(*args, **kwargs):
        raise KeyError("forced")

    monkeypatch.setattr("casewatch.batch.evaluate_stream", boom)
    out = tmp_path / "out"
    assert main(["run", str(case), str(logs), "-o", str(out), "--quiet", "--format", "none"]) == 3
    err = capsys.readouterr().err
    assert f"a.jsonl: internal error (KeyError: 'forced'); please attach {out / 'a'}" in err


# -- issue 31: a damaged log never exits 0 ---------------------------------------------------


def _calm_stream(path: Path, frames: int = 60) -> list[str]:
    """Frames 3.5-9.4 s: both channels agree throughout (no episode), except tfuse absent
    5.0-5.5 s; as JSON lines."""
    rows = [json.dumps(frame(i)) for i in range(35, 35 + frames)]
    path.write_text("\n".join(rows) + "\n")
    return rows


@pytest.mark.parametrize("fail_on", ["any", "hazard", "spi", "never"])
def test_a_truncated_log_is_a_damage_finding_under_every_policy(tmp_path, capsys, fail_on):
    case = write_case(tmp_path / "case.yaml")
    clean = tmp_path / "clean.jsonl"
    rows = _calm_stream(clean)
    out = tmp_path / "o"
    args = ["--format", "junit", "--fail-on", fail_on, "--max-no-data", "1"]
    assert main(["run", str(case), str(clean), "-o", str(out), *args]) == 0
    cut = tmp_path / "cut.jsonl.gz"
    whole = gzip.compress(("\n".join(rows) + "\n").encode(), mtime=0)
    cut.write_bytes(whole[: len(whole) * 6 // 10])  # cut at 60 %
    capsys.readouterr()
    assert main(["run", str(case), str(cut), "-o", str(out), *args]) == 1
    err = capsys.readouterr().err
    assert "the log is damaged (1 stream defect(s), listed in result.json)" in err
    result = json.loads((out / "result.json").read_text())
    assert result["episodes"] == [] and result["stream"]["defects"][0]["kind"] == "truncated-stream"
    junit = (out / "junit.xml").read_text()
    assert 'type="casewatch.damage"' in junit and 'name="stream read without damage"' in junit


def test_frames_refused_as_non_increasing_make_a_damaged_fleet_log(tmp_path, capsys):
    case = write_case(tmp_path / "case.yaml")
    logs = tmp_path / "logs"
    logs.mkdir()
    rows = _calm_stream(logs / "a.jsonl")
    (logs / "b.jsonl").write_text("\n".join(rows[:30] + rows[:30]) + "\n")  # 30 refused
    out = tmp_path / "out"
    assert (
        main(
            [
                "run",
                str(case),
                str(logs),
                "-o",
                str(out),
                "--quiet",
                "--format",
                "none",
                "--max-no-data",
                "1",
            ]
        )
        == 1
    )
    summary = json.loads((out / "summary.json").read_text())
    assert summary["logs_damaged"] == 1 and summary["formulas"][0]["episodes"] == 0
    assert [log["defects"] for log in summary["per_log"]] == [0, 30]


# -- issue 31: --resume re-verifies a result's own digest ------------------------------------


def test_resume_judges_again_a_result_edited_after_it_was_written(tmp_path):
    from casewatch.evaluator.result import result_digest
    from casewatch.reports.render import load_result

    case = write_case(tmp_path / "case.yaml")
    logs = tmp_path / "logs"
    logs.mkdir()
    write_stream(logs / "a.jsonl")
    write_stream(logs / "b.jsonl")
    out = tmp_path / "out"
    args = ["run", str(case), str(logs), "-o", str(out), "--quiet", "--format", "none"]
    assert main(args) == 1
    for name in ("a", "b"):
        result = load_result(out / name / "result.json")
        assert result.content_digest == result_digest(result) and result.verdict == "undermined"
    # a forged verdict whose input digests still match
    forged = json.loads((out / "b" / "result.json").read_text())
    forged["verdict"], forged["episodes"] = "satisfied", []
    (out / "b" / "result.json").write_text(json.dumps(forged))
    assert main([*args, "--resume"]) == 1
    summary = json.loads((out / "summary.json").read_text())
    by_name = {Path(log["stream"]).name: log for log in summary["per_log"]}
    assert by_name["a.jsonl"]["seconds"] == 0.0  # intact: reused
    assert by_name["b.jsonl"]["seconds"] > 0.0  # edited: judged again
    assert summary["verdicts"] == {"undermined": 2}
    assert load_result(out / "b" / "result.json").verdict == "undermined"


# -- issue 31: a null binding is a check error ---------------------------------------------


@pytest.mark.parametrize(
    ("old", "new", "where"),
    [
        (
            'spi: {signal: els, threshold: ">= 0.6"}',
            "spi: null",
            ":17:8: CW018 error: node Sn1, `spi`: "
            "`spi:` is empty (null), so nothing would be monitored",
        ),
        (
            'hazard: {when: "speed > 20"}',
            "hazard:",
            ":21:10: CW018 error: node CSn1, `hazard`: `hazard:` is empty (null)",
        ),
    ],
)
def test_a_null_spi_or_hazard_is_a_check_error(tmp_path, capsys, old, new, where):
    from tests.evaluator.streams import SMALL_CASE

    case = tmp_path / "case.yaml"
    case.write_text(SMALL_CASE.replace(old, new))
    assert main(["check", str(case)]) == 1
    assert main(["run", str(case), "-", "-o", str(tmp_path / "o")]) == 2
    assert f"{case}{where}" in capsys.readouterr().out


# -- issue 31: the fuzz's crash causes, each from its reproduction ---------------------------


def test_an_integer_beyond_float_range_is_a_stream_defect(tmp_path, capsys):
    case = write_case(tmp_path / "case.yaml")
    rows = [json.dumps(frame(i)) for i in range(35, 60)]
    rows[5] = rows[5].replace('"t": 4.0', '"t": ' + "9" * 401, 1)
    rows[6] = rows[6].replace('"x": 41.0', '"x": ' + "9" * 401, 1)
    stream = tmp_path / "s.jsonl"
    stream.write_text("\n".join(rows) + "\n")
    out = tmp_path / "o"
    assert (
        main(
            [
                "run",
                str(case),
                str(stream),
                "-o",
                str(out),
                "--quiet",
                "--format",
                "none",
                "--max-no-data",
                "1",
            ]
        )
        == 1
    )
    defects = json.loads((out / "result.json").read_text())["stream"]["defects"]
    assert [(d["line"], d["kind"], d["message"]) for d in defects] == [
        (6, "non-finite", "frame.t: inf is not a finite number"),
        (7, "non-finite", "channels.lav.ego.x: inf is not a finite number"),
    ]


def test_a_header_meta_nested_900_deep_is_a_bad_header(tmp_path):
    case = write_case(tmp_path / "case.yaml")
    stream = write_stream(tmp_path / "s.jsonl", frames=30)
    lines = stream.read_text().splitlines()
    lines[0] = lines[0].replace(
        '"meta": {"test": "e2e"}', '"meta": ' + '{"a": ' * 900 + "1" + "}" * 900
    )
    stream.write_text("\n".join(lines) + "\n")
    out = tmp_path / "o"
    assert main(["run", str(case), str(stream), "-o", str(out), "--quiet"]) == 1
    result = json.loads((out / "result.json").read_text())
    assert result["stream"]["defects"] == [
        {
            "line": 1,
            "kind": "bad-header",
            "message": "header.meta: nested deeper than 32 levels of objects and lists",
        }
    ]
    assert result["stream"]["frames_read"] == 30


@pytest.mark.parametrize(
    ("name", "shown"),
    [
        ("a\\0b.yaml", "'a\\x00b.yaml': not a usable file name (embedded null byte)"),
        ("a" * 300 + ".yaml", "(305 chars): not a usable file name (File name too long)"),
    ],
)
def test_a_module_uses_name_that_is_no_file_name_is_cw028(tmp_path, capsys, name, shown):
    from tests.evaluator.streams import SMALL_CASE

    case = tmp_path / "case.yaml"
    case.write_text(
        SMALL_CASE.replace("brief: One SPI and one hazard}", f'brief: x, uses: ["{name}"]}}')
    )
    assert main(["check", str(case)]) == 1
    out = capsys.readouterr().out
    assert f"{case}:1:" in out and "CW028 error: module `uses` " in out and shown in out


@pytest.mark.parametrize("name", ["a\\0b.yaml", "b" * 300 + ".yaml"])
def test_an_odd_file_name_that_is_no_file_name_is_cw009(tmp_path, capsys, name):
    from tests.evaluator.streams import SMALL_CASE

    text = (
        SMALL_CASE.replace("  supportedBy: [S1]", "  supportedBy: [S1]\n  inContextOf: [C1]", 1)
        + f'C1:\n  text: the ODD\n  odd: "{name}"\n'
    )
    case = tmp_path / "case.yaml"
    case.write_text(text)
    assert main(["check", str(case)]) == 1
    out = capsys.readouterr().out
    assert "CW009 error: node C1: `odd`: " in out and "cannot read the ODD specification" in out
    assert len(out) < 1000


@pytest.mark.parametrize(
    ("scores", "expected"),
    [
        ("abc", "scores: Input should be a valid dictionary"),
        ({"penalty": "x", "carla": None}, "scores.penalty: expected an object or null"),
        ({"penalty": {"score": "x"}, "carla": None}, "scores.penalty.score: expected a number"),
        ({"per_rule": 1}, "scores.penalty: missing"),
    ],
)
def test_a_result_with_malformed_scores_is_refused_by_report(tmp_path, capsys, scores, expected):
    case, stream = write_case(tmp_path / "case.yaml"), write_stream(tmp_path / "s.jsonl", 30)
    out = tmp_path / "o"
    assert main(["run", str(case), str(stream), "-o", str(out), "--quiet", "--format", "none"]) == 1
    result = json.loads((out / "result.json").read_text())
    result["scores"] = scores
    (out / "result.json").write_text(json.dumps(result))
    assert main(["report", str(out), "--format", "html,md,junit"]) == 2
    err = capsys.readouterr().err
    assert expected in err and "internal error" not in err


@pytest.mark.parametrize(
    ("frames", "expected"),
    [
        (
            "9" * 401,
            ":11:70: CW008 error: node Sn1: `params.frames` must be a finite number, got "
            "9999999999999999999999999999999999999...",
        ),
        ("100", ":11:19: CW051 error: guarantee of node Sn1 is nested too deeply for rtamt"),
    ],
)
def test_library_parameters_that_used_to_crash_are_findings(tmp_path, capsys, frames, expected):
    case = tmp_path / "case.yaml"
    case.write_text(
        "module: {name: da}\nmonitor:\n  channels: [lav, tfuse]\n  period: 0.1s\n"
        '  signals: {gt_lead_gap: "reference gap, m"}\nG1:\n  text: top\n'
        "  supportedBy: [Sn1]\nSn1:\n  text: lav measures its leader\n"
        f"  contract: {{use: detection_accuracy, params: {{channel: lav, frames: {frames}}}}}\n"
    )
    assert main(["check", str(case)]) == 1
    assert f"{case}{expected}" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("period", "expected"),
    [
        (float("nan"), "period must be a finite number above 0, got nan"),
        ([0.1, 0.2], "period must be a finite number above 0, got [0.1, 0.2]"),
    ],
)
def test_saved_signals_with_a_bad_period_are_refused_by_calibrate(
    tmp_path, capsys, period, expected
):
    import numpy as np

    case = write_case(tmp_path / "case.yaml")
    logs = tmp_path / "logs"
    logs.mkdir()
    write_stream(logs / "a.jsonl", frames=40)
    fleet = tmp_path / "fleet"
    assert (
        main(
            [
                "run",
                str(case),
                str(logs),
                "-o",
                str(fleet),
                "--quiet",
                "--format",
                "none",
                "--save-signals",
            ]
        )
        == 1
    )
    npz = fleet / "a" / "signals.npz"
    with np.load(npz, allow_pickle=False) as saved:
        arrays = {k: saved[k] for k in saved.files}
    arrays["period"] = np.array(period)
    np.savez_compressed(npz, **arrays)
    assert (
        main(
            [
                "calibrate",
                str(case),
                str(fleet),
                "--false-alarms-per-hour",
                "10",
                "-o",
                str(tmp_path / "cal"),
            ]
        )
        == 2
    )
    err = capsys.readouterr().err
    assert f"{npz}: {expected}" in err and "internal error" not in err


def test_plan_and_object_points_at_1e308_are_out_of_range_defects(tmp_path, capsys):
    """They crashed the plan metrics (a GEOS error in the Frechet distance); now each such
    frame is a defect and the run, with nothing left to judge, is unusable input."""
    rows = []
    for i in range(20):
        row = frame(i)
        for state in row["channels"].values():
            state["plan"] = [[0.0, 1e308, 1e308], [0.5, -1e308, 1e308], [1.0, 1e308, -1e308]]
        rows.append(json.dumps(row))
    stream = tmp_path / "s.jsonl"
    stream.write_text("\n".join(rows) + "\n")
    out = tmp_path / "o"
    assert (
        main(["run", str(REFERENCE), str(stream), "-o", str(out), "--quiet", "--format", "none"])
        == 2
    )
    assert "line 1: out-of-range: channels.lav.plan[0]: a value beyond ±1e+09 in [0.0, 1e+308" in (
        capsys.readouterr().err
    )


@pytest.mark.parametrize("engine", ["rtamt", "numpy", "both"])
def test_a_division_by_a_signal_reaching_zero_is_ieee_not_a_crash(tmp_path, engine):
    """`els / (els - els)` divides by 0 at every tick (CW045 only refuses the constant 0):
    rtamt raised ZeroDivisionError; both engines now divide as IEEE 754 does (els > 0: +inf,
    a pass of `> 1`), and a 0 / 0 would be a tick without a verdict."""
    from tests.evaluator.streams import SMALL_CASE

    case = tmp_path / "case.yaml"
    case.write_text(
        SMALL_CASE.replace(
            'spi: {signal: els, threshold: ">= 0.6"}', 'spi: {stl: "els / (els - els) > 1"}'
        )
    )
    stream = write_stream(tmp_path / "s.jsonl", frames=40)
    out = tmp_path / "o"
    assert (
        main(
            [
                "run",
                str(case),
                str(stream),
                "-o",
                str(out),
                "--quiet",
                "--format",
                "none",
                "--stl-engine",
                engine,
            ]
        )
        == 0
    )
    sn1 = next(
        f for f in json.loads((out / "result.json").read_text())["formulas"] if f["id"] == "Sn1"
    )
    assert (sn1["ticks_evaluated"], sn1["ticks_violated"], sn1["worst_robustness"]) == (
        40,
        0,
        "Infinity",
    )


def test_a_not_a_number_robustness_is_no_data() -> None:
    from casewatch.evaluator.core import UNDEFINED, Evaluator
    from casewatch.spec.compiler import compile_case
    from tests.spec.cases import make_case, stl_node

    case = make_case(stl_node("Sn1", "x / y > 1"), signals={"x": "a", "y": "b"})
    spec, _ = compile_case(case)
    evaluator = Evaluator(case, spec)
    statuses = [
        evaluator.step(i / 10, {"x": x, "y": y})["Sn1"]
        for i, (x, y) in enumerate([(4.0, 2.0), (0.0, 0.0), (1.0, 0.0), (1.0, 2.0)])
    ]
    assert statuses == ["satisfied", "no-data", "satisfied", "violated"]
    evaluator.finish()
    assert [g.missing for g in evaluator.data_gaps] == [[UNDEFINED]]


def test_a_401_digit_count_in_result_json_is_refused_not_an_overflow(tmp_path, capsys):
    case, stream = write_case(tmp_path / "case.yaml"), write_stream(tmp_path / "s.jsonl", 30)
    out = tmp_path / "o"
    assert main(["run", str(case), str(stream), "-o", str(out), "--quiet", "--format", "none"]) == 1
    text = (out / "result.json").read_text()
    (out / "result.json").write_text(
        text.replace(
            '"ticks_violated": ', '"ticks_violated": ' + "9" * 401 + ', "ticks_violated_was": ', 1
        )
    )
    assert main(["report", str(out)]) == 2
    err = capsys.readouterr().err
    assert "formulas.0.ticks_violated: Input should be a finite number" in err
