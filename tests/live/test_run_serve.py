"""`casewatch run --serve/--annotate`: what the command refuses before judging anything."""

from __future__ import annotations

import json

import pytest

from casewatch.cli import main
from tests.evaluator.streams import write_case, write_stream


@pytest.fixture
def paths(tmp_path):
    return write_case(tmp_path / "case.yaml"), write_stream(tmp_path / "s.jsonl"), tmp_path


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--serve", "0.0.0.0:0"], "not a loopback address"),
        (["--serve", "nonsense"], "expected [HOST:]PORT"),
        (["--serve", "0", "--stl-engine", "numpy"], "need --stl-engine rtamt or auto"),
        (["--serve-public"], "go with --serve or --foxglove"),
        (["--serve", "0", "--serve-linger", "-1"], "0 or more seconds"),
        (["--annotate", "out.txt"], "the output is an MCAP file"),
    ],
)
def test_refusals_exit_2_with_the_reason(paths, capsys, extra, message):
    case, stream, tmp = paths
    code = main(["run", str(case), str(stream), "-o", str(tmp / "o"), "--quiet", *extra])
    assert code == 2
    assert message in capsys.readouterr().err
    assert not (tmp / "o" / "result.json").exists()


def test_serve_goes_with_one_stream(paths, capsys):
    case, stream, tmp = paths
    other = write_stream(tmp / "t.jsonl")
    code = main(["run", str(case), str(stream), str(other), "-o", str(tmp / "o"), "--serve", "0"])
    assert code == 2
    assert "go with one stream" in capsys.readouterr().err


def test_a_served_run_writes_the_same_result_as_one_without(paths, capsys):
    case, stream, tmp = paths
    base = ["run", str(case), str(stream), "--format", "none", "--quiet"]
    assert main([*base, "-o", str(tmp / "plain")]) == 1
    assert main([*base, "-o", str(tmp / "served"), "--serve", "127.0.0.1:0"]) == 1
    assert "live page at http://127.0.0.1:" in capsys.readouterr().err
    plain = (tmp / "plain" / "events.jsonl").read_text()
    assert (tmp / "served" / "events.jsonl").read_text() == plain
    results = [json.loads((tmp / d / "result.json").read_text()) for d in ("plain", "served")]
    for r in results:
        for key in ("created", "timings", "content_digest"):
            r.pop(key, None)
        r["stream"].pop("path", None)
    assert results[0] == results[1]
