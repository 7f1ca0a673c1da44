"""`casewatch diff`: episodes paired across two runs of the same stream."""

from __future__ import annotations

import json
import shutil

from casewatch.cli import main
from tests.evaluator.streams import SMALL_CASE, write_case, write_stream


def run(tmp_path, name: str, case_text: str, stream) -> str:
    case = tmp_path / f"{name}.yaml"
    case.write_text(case_text)
    out = tmp_path / name
    main(["run", str(case), str(stream), "-o", str(out), "--format", "none", "--quiet"])
    return str(out)


def test_diff_against_itself_is_empty_and_a_changed_case_shows_exactly_its_episodes(tmp_path,
                                                                                   capsys):
    stream = write_stream(tmp_path / "s.jsonl")
    a = run(tmp_path, "a", SMALL_CASE, stream)  # Sn1: one episode 2.0-3.0 s; CSn1 never
    # B: the hazard fires on every tick (speed 10 > 5: one event 0.0-9.9 s), and Sn1's
    # threshold 0.2 no longer catches els = 1/3: Sn1's episode is fixed
    b_text = SMALL_CASE.replace('"speed > 20"', '"speed > 5"').replace(">= 0.6", ">= 0.2")
    b = run(tmp_path, "b", b_text, stream)
    assert main(["diff", a, a, "-o", str(tmp_path / "self")]) == 0
    report = json.loads((tmp_path / "self" / "diff.json").read_text())
    assert report["regressions"] == 0
    assert all(not (n["new"] or n["fixed"] or n["changed"]) for n in report["logs"][0]["nodes"])
    capsys.readouterr()
    assert main(["diff", a, b, "-o", str(tmp_path / "d")]) == 1
    report = json.loads((tmp_path / "d" / "diff.json").read_text())
    nodes = {n["formula"]: n for n in report["logs"][0]["nodes"]}
    assert [(s["start"], s["end"]) for s in nodes["CSn1"]["new"]] == [(0.0, 9.9)]
    assert [(s["start"], s["end"]) for s in nodes["Sn1"]["fixed"]] == [(2.0, 3.0)]
    assert nodes["Sn1"]["new"] == [] and nodes["CSn1"]["fixed"] == []
    assert report["regressions"] == 1
    assert report["logs"][0]["verdict_a"] != report["logs"][0]["verdict_b"]
    md = (tmp_path / "d" / "diff.md").read_text()
    assert "new CSn1: 0.0-9.9 s" in md and "fixed Sn1: 2.0-3.0 s" in md
    html = (tmp_path / "d" / "diff.html").read_text()
    assert "<script" not in html and "new CSn1" in html
    printed = capsys.readouterr().out
    assert "1 new, 1 fixed, 0 changed" in printed
    # the policy decides what is a regression: the new episode is a hazard event
    assert main(["diff", a, b, "-o", str(tmp_path / "e"), "--fail-on", "spi"]) == 0
    assert main(["diff", a, b, "-o", str(tmp_path / "e"), "--fail-on", "hazard"]) == 1


def test_fleets_pair_logs_by_name_and_bad_input_exits_2(tmp_path, capsys):
    streams = tmp_path / "streams"
    streams.mkdir()
    write_stream(streams / "one.jsonl")
    shutil.copy(streams / "one.jsonl", streams / "two.jsonl")
    case = write_case(tmp_path / "case.yaml")
    for name in ("fa", "fb"):
        main(["run", str(case), str(streams), "-o", str(tmp_path / name), "--format", "none",
              "--quiet"])  # fmt: skip
    assert main(["diff", str(tmp_path / "fa"), str(tmp_path / "fb"), "-o",
                 str(tmp_path / "d")]) == 0  # fmt: skip
    report = json.loads((tmp_path / "d" / "diff.json").read_text())
    assert [d["log"] for d in report["logs"]] == ["one", "two"]
    assert main(["diff", str(tmp_path / "fa"), str(tmp_path / "nothing"), "-o",
                 str(tmp_path / "d")]) == 2  # fmt: skip
    assert "neither a run folder" in capsys.readouterr().err


def test_a_degraded_case_on_a_bundled_drive_shows_exactly_its_new_episodes(tmp_path):
    """The reference case against itself with Sn1's threshold raised to 0.9 (the localisation
    SPI now flags ordinary jitter), on a real bundled drive."""
    from pathlib import Path

    repo = Path(__file__).resolve().parents[2]
    stream = repo / "examples" / "data" / "highway-tailgated.jsonl.gz"
    text = (repo / "examples" / "reference-case.yaml").read_text()
    degraded = text.replace('spi: {signal: els, threshold: ">= 0.6"}',
                            'spi: {signal: els, threshold: ">= 0.9"}')  # fmt: skip
    assert degraded != text
    a = run(tmp_path, "ref", text, stream)
    b = run(tmp_path, "degraded", degraded, stream)
    assert main(["diff", a, a, "-o", str(tmp_path / "self")]) == 0
    assert main(["diff", a, b, "-o", str(tmp_path / "d"), "--fail-on", "hazard"]) == 0
    report = json.loads((tmp_path / "d" / "diff.json").read_text())
    nodes = {n["formula"]: n for n in report["logs"][0]["nodes"]}
    changed = {f for f, n in nodes.items() if n["new"] or n["fixed"] or n["changed"]}
    assert changed == {"Sn1"}  # nothing else moves
    ra = json.loads(Path(a, "result.json").read_text())["episodes"]
    rb = json.loads(Path(b, "result.json").read_text())["episodes"]
    old = [(e["start"], e["end"]) for e in ra if e["node_id"] == "Sn1"]
    want_new = [(e["start"], e["end"]) for e in rb if e["node_id"] == "Sn1"
                and not any(s <= e["end"] and e["start"] <= t for s, t in old)]  # fmt: skip
    assert [(s["start"], s["end"]) for s in nodes["Sn1"]["new"]] == want_new and want_new
    assert report["regressions"] == 0  # --fail-on hazard: new SPI episodes are no regression
