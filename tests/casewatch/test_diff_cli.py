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


def test_diff_against_itself_is_empty_and_a_changed_case_shows_exactly_its_episodes(
    tmp_path, capsys
):
    stream = write_stream(tmp_path / "s.jsonl")
    a = run(tmp_path, "a", SMALL_CASE, stream)  # Sn1: one episode 2.0-3.0 s; CSn1 never
    # B: the hazard fires on every tick (speed 10 > 5: one event 0.0-9.9 s), and Sn1's
    # threshold 0.2 no longer catches els = 1/3: Sn1's episode is gone (not "fixed": nothing
    # says it was a false alarm)
    b_text = SMALL_CASE.replace('"speed > 20"', '"speed > 5"').replace(">= 0.6", ">= 0.2")
    b = run(tmp_path, "b", b_text, stream)
    assert main(["diff", a, a, "-o", str(tmp_path / "self")]) == 0
    report = json.loads((tmp_path / "self" / "diff.json").read_text())
    assert report["regressions"] == 0
    assert all(not (n["new"] or n["gone"] or n["changed"]) for n in report["logs"][0]["nodes"])
    capsys.readouterr()
    assert main(["diff", a, b, "-o", str(tmp_path / "d")]) == 1
    report = json.loads((tmp_path / "d" / "diff.json").read_text())
    nodes = {n["formula"]: n for n in report["logs"][0]["nodes"]}
    assert [(s["start"], s["end"]) for s in nodes["CSn1"]["new"]] == [(0.0, 9.9)]
    assert [(s["start"], s["end"]) for s in nodes["Sn1"]["gone"]] == [(2.0, 3.0)]
    assert nodes["Sn1"]["new"] == [] and nodes["CSn1"]["gone"] == []
    assert all(n["fixed"] == [] for n in nodes.values())  # no labels: never "fixed"
    assert report["regressions"] == 1
    assert report["logs"][0]["verdict_a"] != report["logs"][0]["verdict_b"]
    md = (tmp_path / "d" / "diff.md").read_text()
    assert "new CSn1: 0.0-9.9 s" in md and "gone Sn1: 2.0-3.0 s" in md
    html = (tmp_path / "d" / "diff.html").read_text()
    assert "<script" not in html and "new CSn1" in html
    printed = capsys.readouterr().out
    assert "1 new, 1 gone, 0 changed" in printed and "no labels" in printed
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
        main(
            [
                "run",
                str(case),
                str(streams),
                "-o",
                str(tmp_path / name),
                "--format",
                "none",
                "--quiet",
            ]
        )
    assert (
        main(["diff", str(tmp_path / "fa"), str(tmp_path / "fb"), "-o", str(tmp_path / "d")]) == 0
    )
    report = json.loads((tmp_path / "d" / "diff.json").read_text())
    assert [d["log"] for d in report["logs"]] == ["one", "two"]
    assert (
        main(["diff", str(tmp_path / "fa"), str(tmp_path / "nothing"), "-o", str(tmp_path / "d")])
        == 2
    )
    assert "neither a run folder" in capsys.readouterr().err


def test_a_degraded_case_on_a_bundled_drive_shows_exactly_its_new_episodes(tmp_path):
    """The reference case against itself with Sn1's threshold raised to 0.9 (the localisation
    SPI now flags ordinary jitter), on a real bundled drive."""
    from pathlib import Path

    repo = Path(__file__).resolve().parents[2]
    stream = repo / "examples" / "data" / "highway-tailgated.jsonl.gz"
    text = (repo / "examples" / "reference-case.yaml").read_text()
    degraded = text.replace(
        'spi: {signal: els, threshold: ">= 0.6", for: 0.5s}',
        'spi: {signal: els, threshold: ">= 0.9", for: 0.5s}',
    )
    assert degraded != text
    a = run(tmp_path, "ref", text, stream)
    b = run(tmp_path, "degraded", degraded, stream)
    assert main(["diff", a, a, "-o", str(tmp_path / "self")]) == 0
    assert main(["diff", a, b, "-o", str(tmp_path / "d"), "--fail-on", "hazard"]) == 0
    report = json.loads((tmp_path / "d" / "diff.json").read_text())
    nodes = {n["formula"]: n for n in report["logs"][0]["nodes"]}
    changed = {f for f, n in nodes.items() if n["new"] or n["gone"] or n["changed"]}
    assert changed == {"Sn1"}  # nothing else moves
    ra = json.loads(Path(a, "result.json").read_text())["episodes"]
    rb = json.loads(Path(b, "result.json").read_text())["episodes"]
    old = [(e["start"], e["end"]) for e in ra if e["node_id"] == "Sn1"]
    want_new = [
        (e["start"], e["end"])
        for e in rb
        if e["node_id"] == "Sn1" and not any(s <= e["end"] and e["start"] <= t for s, t in old)
    ]
    assert [(s["start"], s["end"]) for s in nodes["Sn1"]["new"]] == want_new and want_new
    assert report["regressions"] == 0  # --fail-on hazard: new SPI episodes are no regression


def test_labels_given_or_carried_decide_fixed_lost_and_new_detection(tmp_path, capsys):
    """B's hazard fires from 0.0 to 9.9 s; a label at 1-2 s makes it a new detection, and
    the diff the other way round a lost one. Different labels in the two runs are refused."""
    stream = write_stream(tmp_path / "s.jsonl")
    labels = tmp_path / "s.labels.jsonl"
    labels.write_text('{"hazard": "CSn1", "start": 1.0, "end": 2.0}\n')
    a = run(tmp_path, "a", SMALL_CASE, stream)
    b = run(tmp_path, "b", SMALL_CASE.replace('"speed > 20"', '"speed > 5"'), stream)
    assert main(["diff", a, b, "-o", str(tmp_path / "d"), "--labels", str(labels)]) == 0
    row = {
        n["formula"]: n
        for n in json.loads((tmp_path / "d" / "diff.json").read_text())["logs"][0]["nodes"]
    }["CSn1"]
    assert [(s["start"], s["end"]) for s in row["new_detection"]] == [(0.0, 9.9)]
    assert row["new"] == [] and row["labelled"] is True
    assert "1 new detection" in capsys.readouterr().out
    assert main(["diff", b, a, "-o", str(tmp_path / "r"), "--labels", str(labels)]) == 1
    report = json.loads((tmp_path / "r" / "diff.json").read_text())
    row = {n["formula"]: n for n in report["logs"][0]["nodes"]}["CSn1"]
    assert [(s["start"], s["end"]) for s in row["lost"]] == [(0.0, 9.9)]
    assert row["gone"] == [] and row["fixed"] == [] and report["regressions"] == 1
    assert "lost detection CSn1: 0.0-9.9 s" in (tmp_path / "r" / "diff.md").read_text()
    # a label the event does not overlap: the vanished event was a false alarm, fixed
    far = tmp_path / "far.labels.jsonl"
    far.write_text('{"hazard": "CSn1", "start": 20.0, "end": 21.0}\n')
    assert main(["diff", b, a, "-o", str(tmp_path / "f"), "--labels", str(far)]) == 0
    row = {
        n["formula"]: n
        for n in json.loads((tmp_path / "f" / "diff.json").read_text())["logs"][0]["nodes"]
    }["CSn1"]
    assert [(s["start"], s["end"]) for s in row["fixed"]] == [(0.0, 9.9)]
    # runs judged against different labels: refused, with the way out named
    la, lb = tmp_path / "la", tmp_path / "lb"
    for out, path in ((la, labels), (lb, far)):
        main(
            [
                "run",
                str(tmp_path / "b.yaml"),
                str(stream),
                "-o",
                str(out),
                "--format",
                "none",
                "--quiet",
                "--labels",
                str(path),
            ]
        )
    capsys.readouterr()
    assert main(["diff", str(la), str(lb), "-o", str(tmp_path / "x")]) == 2
    assert "different labels" in capsys.readouterr().err
    assert main(["diff", str(la), str(la), "-o", str(tmp_path / "y")]) == 0
    assert json.loads((tmp_path / "y" / "diff.json").read_text())["logs"][0]["labelled"]


def test_the_readme_example_reads_truthfully_on_one_drive(tmp_path):
    """Reference vs study case on a bundled drive with its labels: every hazard event only
    the reference finds was a true positive there, so it is a lost detection, never fixed."""
    from pathlib import Path

    repo = Path(__file__).resolve().parents[2]
    stream = repo / "examples" / "data" / "highway-tailgated.jsonl.gz"
    labels = repo / "examples" / "data" / "highway-tailgated.labels.jsonl"
    outs = []
    for case in ("reference-case", "study-case"):
        out = tmp_path / case
        main(
            [
                "run",
                str(repo / "examples" / f"{case}.yaml"),
                str(stream),
                "--labels",
                str(labels),
                "-o",
                str(out),
                "--format",
                "none",
                "--quiet",
            ]
        )
        outs.append(str(out))
    assert main(["diff", *outs, "-o", str(tmp_path / "d"), "--fail-on", "hazard"]) == 1
    report = json.loads((tmp_path / "d" / "diff.json").read_text())
    ref = json.loads(Path(outs[0], "result.json").read_text())
    mark = {(m["node_id"], m["start"]): m["match"] for m in ref["ground_truth"]["marks"]}
    hazards = [n for n in report["logs"][0]["nodes"] if n["kind"] == "hazard"]
    lost = [(n["node"], s["start"]) for n in hazards for s in n["lost"]]
    fixed = [(n["node"], s["start"]) for n in hazards for s in n["fixed"]]
    assert len(lost) == 4 and all(mark[x] == "TP" for x in lost)
    assert all(mark[x] == "FP" for x in fixed)
    assert report["regressions"] == len(lost) + sum(len(n["new"]) for n in hazards)
