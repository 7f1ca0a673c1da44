"""A refused stream says why on the terminal: its first defects and, for channels, declared
against found names with a did-you-mean."""

from __future__ import annotations

from casewatch.cli import main
from tests.evaluator.streams import SMALL_CASE, write_stream


def test_a_misspelt_channel_is_named_with_a_did_you_mean(tmp_path, capsys):
    case = tmp_path / "case.yaml"
    case.write_text(SMALL_CASE.replace("channels: [lav, tfuse]", "channels: [lav, tfuze]"))
    stream = write_stream(tmp_path / "s.jsonl", frames=50)
    assert main(["run", str(case), str(stream), "-o", str(tmp_path / "out")]) == 2
    out, err = capsys.readouterr()
    lines = err.splitlines()
    assert "no frames could be read (51 defects)" in lines[0]
    assert lines[1] == (
        "  line 1: unknown-channel: header lists channel(s) tfuse not declared "
        "(declared: lav, tfuze)"
    )
    assert lines[2].startswith("  line 2: unknown-channel: channels.tfuse: channel not declared")
    assert lines[3] == "  ... and 49 more defects (result.json lists all: 51 unknown-channel)"
    assert (
        "the case declares channels lav, tfuze; the stream names tfuse, which the case does "
        "not declare"
    ) in err
    assert f"did you mean 'tfuse' where the case says 'tfuze'? (monitor.channels in {case})" in err
    assert "of 0 ticks" not in out  # no share of nothing


def test_a_declared_channel_absent_from_every_frame_is_named(tmp_path, capsys):
    case = tmp_path / "case.yaml"
    case.write_text(SMALL_CASE.replace("channels: [lav, tfuse]", "channels: [lav, tfuse, radar]"))
    stream = write_stream(tmp_path / "s.jsonl", frames=50)
    assert main(["run", str(case), str(stream), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "radar absent from every frame" in err


def test_a_fleet_of_refused_logs_says_the_cause_once(tmp_path, capsys):
    case = tmp_path / "case.yaml"
    case.write_text(SMALL_CASE.replace("channels: [lav, tfuse]", "channels: [lav, tfuze]"))
    logs = tmp_path / "logs"
    logs.mkdir()
    write_stream(logs / "a.jsonl", frames=30)
    write_stream(logs / "b.jsonl", frames=40)
    assert main(["run", str(case), str(logs), "-o", str(tmp_path / "out"), "--jobs", "1"]) == 2
    err = capsys.readouterr().err
    assert err.count("did you mean 'tfuse' where the case says 'tfuze'?") == 1
    a, b = err.index("a.jsonl: 0 frames"), err.index("b.jsonl: 0 frames")
    first, second = (a, b) if a < b else (b, a)
    assert "header lists channel(s) tfuse not declared" in err[first:second]
    assert err[second:].splitlines()[1] == "    (the same cause as above)"
