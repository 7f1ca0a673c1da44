"""The whole-log numpy STL engine against rtamt itself, and `--stl-engine` end to end."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import assume, given, settings

from casewatch import api
from casewatch.cli import main
from casewatch.evaluator.session import InputError, RunOptions, evaluate_stream
from casewatch.evaluator.stl_engines import CheckedMonitor, EngineMismatch, WholeLog
from casewatch.evaluator.vector_eval import Segments, evaluated_ticks, robustness
from casewatch.spec.ast import signals_of
from casewatch.spec.emit import new_rtamt_spec, period_fraction, to_rtamt
from tests.evaluator.streams import write_case, write_stream
from tests.evaluator.test_vector_eval import gappy_traces
from tests.spec.strategies import PERIOD, SIGNALS, past_formulas

REPO = Path(__file__).resolve().parents[2]
P = period_fraction(PERIOD)


def rtamt_per_segment(formula, trace, t, max_gap):
    """rtamt's online monitor fed the evaluated ticks, a new monitor at every restart, as the
    evaluator feeds it."""
    segments = Segments(t, evaluated_ticks(formula, trace), max_gap)
    out = np.full(len(t), np.nan)
    monitor = None
    k = 0
    starts = set(segments.starts.tolist())
    for j, i in enumerate(segments.index.tolist()):
        if j in starts:
            monitor = new_rtamt_spec(to_rtamt(formula, P), list(SIGNALS), PERIOD)
            k = 0
        out[i] = monitor.update(k * PERIOD, [(n, float(trace[n][i])) for n in SIGNALS])
        k += 1
    return out


@settings(max_examples=200, deadline=None)
@given(past_formulas, gappy_traces())
def test_numpy_engine_equals_rtamt_on_every_tick(formula, data):
    """Random formulas of the grammar (since included) on random signals with gaps and time
    jumps: every evaluated tick within 1e-9, infinities equal, gaps at the same ticks."""
    assume(signals_of(formula))
    trace, t = data
    # rtamt reads every declared signal at every update: give the unused ones a value
    trace = {n: trace[n] for n in SIGNALS}
    ours = robustness(formula, trace, t, PERIOD, max_gap=0.5)
    theirs = rtamt_per_segment(formula, trace, t, max_gap=0.5)
    np.testing.assert_array_equal(np.isnan(ours), np.isnan(theirs))
    for i in np.flatnonzero(~np.isnan(theirs)):
        a, b = ours[i], theirs[i]
        assert (a == b) if (math.isinf(a) or math.isinf(b)) else abs(a - b) <= 1e-9, (
            f"tick {i}: numpy {a} != rtamt {b} for {to_rtamt(formula, P)}"
        )


def _result(engine: str, path: Path):
    case, spec = api.prepare(REPO / "examples/reference-case.yaml")
    return evaluate_stream(case, spec, path, RunOptions(stl_engine=engine))


@pytest.mark.parametrize("drive", ["urban-realstack", "highway-tailgating"])
def test_every_engine_gives_the_same_run(drive: str) -> None:
    path = REPO / "examples/data" / f"{drive}.jsonl.gz"
    runs = {engine: _result(engine, path) for engine in ("rtamt", "numpy", "both")}
    keys = ("verdict", "episodes", "near_misses", "data_gaps", "status", "formulas", "series")
    base = runs["rtamt"].model_dump(include=set(keys))
    for engine in ("numpy", "both"):
        assert runs[engine].model_dump(include=set(keys)) == base, engine
    assert runs["rtamt"].episodes  # the drive has episodes to agree on
    assert runs["numpy"].timings.stl_s < runs["rtamt"].timings.stl_s


class _Fixed:
    """A stand-in rtamt monitor returning fixed values."""

    def __init__(self, values):
        self.values = list(values)

    def reset(self):
        pass

    def update(self, _i, _inputs):
        return self.values.pop(0)


def test_a_disagreement_names_the_formula_and_the_tick() -> None:
    from casewatch.spec.model import CompiledFormula

    formula = CompiledFormula(
        id="Sn9",
        node_id="Sn9",
        node_text="x",
        kind="spi",
        source="x",
        rtamt="(x >= 0)",
        signals=["x"],
        merge_gap=1,
        min_duration=0,
    )
    whole = WholeLog(
        {"Sn9": np.array([1.0, 2.0, -np.inf])},
        {"Sn9": np.array([0, 2, 3])},
        np.array([0.0, 0.1, 0.2, 0.3]),
    )
    found, counter = [], [0]
    monitor = CheckedMonitor(_Fixed([1.0, 2.5, -np.inf]), formula, whole, found, counter)
    assert [monitor.update(k, []) for k in range(3)] == [1.0, 2.5, -np.inf]
    assert counter == [1] and found[0].format() == "Sn9 at t = 0.2 s: rtamt 2.5, numpy 2.0"
    error = EngineMismatch(found, counter[0])
    assert "disagree on 1 value(s)" in str(error) and "Sn9 at t = 0.2 s" in str(error)


def test_the_command_line_engines(tmp_path: Path, capsys) -> None:
    case = write_case(tmp_path / "case.yaml")
    stream = write_stream(tmp_path / "s.jsonl")
    codes = {}
    for engine in ("rtamt", "numpy", "both"):
        out = tmp_path / engine
        codes[engine] = main(
            [
                "run",
                str(case),
                str(stream),
                "-o",
                str(out),
                "--format",
                "none",
                "--quiet",
                "--stl-engine",
                engine,
            ]
        )
    assert codes == {"rtamt": 1, "numpy": 1, "both": 1}
    episodes = {
        e: json.loads((tmp_path / e / "result.json").read_text())["episodes"] for e in codes
    }
    assert episodes["numpy"] == episodes["rtamt"] == episodes["both"] != []
    with pytest.raises(InputError, match="a live stream on standard input needs"):
        _result("numpy", Path("-"))
    assert main(["run", str(case), "-", "-o", str(tmp_path / "live"), "--stl-engine", "numpy"]) == 2
    assert "needs --stl-engine rtamt" in capsys.readouterr().err


def test_a_fleet_with_the_numpy_engine(tmp_path: Path) -> None:
    logs = tmp_path / "logs"
    logs.mkdir()
    for name in ("urban-grid", "highway-tailgated"):
        (logs / f"{name}.jsonl.gz").write_bytes(
            (REPO / f"examples/data/{name}.jsonl.gz").read_bytes()
        )
    code = main(
        [
            "run",
            str(REPO / "examples/reference-case.yaml"),
            str(logs),
            "-o",
            str(tmp_path / "out"),
            "--format",
            "none",
            "--quiet",
            "--stl-engine",
            "numpy",
            "--jobs",
            "2",
        ]
    )
    assert code == 1
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert [log["ok"] for log in summary["per_log"]] == [True, True]
