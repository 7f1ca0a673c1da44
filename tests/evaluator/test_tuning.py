"""Threshold tuning and calibration (evaluator.tuning) on hand-built saved signals, and the
episodes it forms against the evaluator's own, on a real run."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from casewatch.evaluator.episodes import EpisodeTracker
from casewatch.evaluator.ground_truth import Label
from casewatch.evaluator.signal_store import (
    SavedSignals,
    SignalRecorder,
    SignalsError,
    load_signals,
)
from casewatch.evaluator.tuning import (
    Knob,
    episodes_for,
    episodes_from,
    knobs,
    margins,
    pick,
    sweep,
    threshold_candidates,
    tune,
)
from casewatch.spec.parser import parse_formula

PERIOD = 0.1


def saved(x: list[float], name: str = "x", path: str = "log") -> SavedSignals:
    t = np.round(np.arange(len(x)) * PERIOD, 6)
    return SavedSignals(path, t, [name], np.array(x, dtype=float)[:, None], PERIOD, 0.5)


def hazard(when: str, min_duration: float = 0.0, merge_gap: float = 0.0) -> Knob:
    """A hazard knob on `when` (its first comparison swept)."""
    from casewatch.spec.ast import Num, Signal

    condition = parse_formula(when)
    cmp = condition if hasattr(condition, "op") and isinstance(condition.left, Signal) else None
    assert cmp is not None and isinstance(cmp.right, Num)
    return Knob(
        "H",
        "H",
        "h",
        "hazard",
        when,
        condition,
        (),
        cmp.left.name,
        cmp.op,
        True,
        cmp.right.value,
        "min_duration",
        min_duration,
        merge_gap,
        min_duration,
    )


def test_episodes_merge_and_drop_like_the_evaluator_hand_computed():
    t = np.round(np.arange(20) * PERIOD, 6)
    v = np.zeros(20, dtype=bool)
    v[[2, 3, 4, 9, 10, 17]] = True
    # ticks 2-4 and 9-10: clean time 0.8 - 0.5 = 0.4 s between them (< merge 0.5): one episode
    # 0.2-1.0; tick 17 alone lasts one period (0.1 s < min 0.2): dropped
    assert episodes_from(t, v, PERIOD, 0.5, 0.2) == [(0.2, 1.0)]
    # merge_gap 0.3 s: apart; min 0: tick 17 too
    assert episodes_from(t, v, PERIOD, 0.3, 0.0) == [(0.2, 0.4), (0.9, 1.0), (1.7, 1.7)]


@settings(max_examples=200, deadline=None)
@given(
    st.lists(st.sampled_from([None, True, False, False]), max_size=40),
    st.sampled_from([0.0, 0.1, 0.3, 1.0]),
    st.sampled_from([0.0, 0.1, 0.25, 0.5]),
)
def test_episodes_equal_the_episode_tracker(ticks, merge_gap, min_duration):
    tracker = EpisodeTracker(merge_gap, min_duration, PERIOD)
    want = []
    for i, v in enumerate(ticks):
        closed = tracker.step(round(i * PERIOD, 6), None if v is None else (-1.0 if v else 1.0))
        if closed is not None:
            want.append((closed.start, closed.end))
    closed = tracker.finish()
    if closed is not None:
        want.append((closed.start, closed.end))
    t = np.round(np.arange(len(ticks)) * PERIOD, 6)
    violated = np.array([v is True for v in ticks], dtype=bool)
    assert episodes_from(t, violated, PERIOD, merge_gap, min_duration) == want


def test_sweep_picks_the_threshold_that_separates_and_scores_it_held_out():
    # x dips to 0.2 during each labelled hazard and to 0.7 once in nominal driving; the rule
    # `x < 0.9` catches the nominal dip too (1 FP per log), `x < 0.5` only the hazards
    dip = [1.0] * 10 + [0.2] * 5 + [1.0] * 10 + [0.7] * 5 + [1.0] * 10
    logs = [saved(dip, path=f"log{k}") for k in range(3)]
    labels = [[Label("H", 1.0, 1.4, 1)] for _ in logs]
    knob = hazard("x < 0.9")
    result = tune(sweep(knob, logs, labels, count=20))
    assert result["original"]["tp"] == 3 and result["original"]["fp"] == 3
    assert result["tuned"]["precision"] == 1.0 and result["tuned"]["recall"] == 1.0
    # candidates 0.2, 0.7, 0.9 (the original) and 1.0: only `x < 0.7` flags the hazards and
    # not the nominal dip (x < 0.7 does not flag 0.7)
    assert result["tuned"]["threshold"] == 0.7
    # held out: each log scored at the point picked on the other two: the same point
    assert result["heldout"] == {
        "tp": 3,
        "fp": 0,
        "fn": 0,
        "precision": 1.0,
        "recall": 1.0,
        "f1": 1.0,
    }


def test_min_precision_objective_and_unreachable_precision():
    # two hazards per log: one deep (0.2), one shallow (0.6) labelled, one nominal dip (0.6)
    # unlabelled: no threshold gets the shallow hazard without the nominal dip
    x = [1.0] * 5 + [0.2] * 5 + [1.0] * 5 + [0.6] * 5 + [1.0] * 5 + [0.6] * 5 + [1.0] * 5
    logs = [saved(x, path="a"), saved(x, path="b")]
    labels = [[Label("H", 0.5, 0.9, 1), Label("H", 1.5, 1.9, 2)] for _ in logs]
    sw = sweep(hazard("x < 0.9"), logs, labels, count=20)
    f1 = tune(sw)  # 2 TP, 1 FP, 0 FN (F1 0.8) beats 1/0/1 (F1 0.67)
    assert (f1["tuned"]["tp"], f1["tuned"]["fp"], f1["tuned"]["fn"]) == (4, 2, 0)
    strict = tune(sw, "min-precision", 1.0)
    assert (strict["tuned"]["tp"], strict["tuned"]["fp"]) == (2, 0)
    assert strict["tuned"]["recall"] == 0.5 and strict["reached"]


def test_candidates_span_the_observed_values_outwards():
    log = saved([0.123456, 0.5, 0.987654])
    got = threshold_candidates(hazard("x < 0.9"), [log], count=3)
    assert got[0] <= 0.123456 and got[-1] >= 0.987654 and 0.9 in got and 0.5 in got


def test_signal_store_round_trip_and_errors(tmp_path):
    rec = SignalRecorder(["a", "b"], 0.1, 0.5)
    rec.add(0.0, {"a": 1.0, "b": None})
    rec.add(0.1, {"a": 2.5, "b": 3.0})
    path = rec.save(tmp_path / "signals.npz")
    log = load_signals(tmp_path)
    assert log.names == ["a", "b"] and log.period == 0.1 and log.max_gap == 0.5
    np.testing.assert_array_equal(log.column("a"), [1.0, 2.5])
    assert np.isnan(log.column("b")[0]) and log.column("b")[1] == 3.0
    with pytest.raises(SignalsError, match="'c' was not saved"):
        log.column("c")
    path.write_bytes(b"not a zip")
    with pytest.raises(SignalsError, match="not a saved-signals file"):
        load_signals(path)
    with pytest.raises(SignalsError, match="--save-signals"):
        load_signals(tmp_path / "missing")


def test_vectorised_episodes_equal_the_evaluators_on_a_bundled_run(tmp_path):
    """Every formula of the reference case at its own threshold: the same episodes."""
    from casewatch import api
    from casewatch.evaluator.session import RunOptions, RunSinks, evaluate_stream

    case, spec = api.prepare("examples/reference-case.yaml")
    stream = "examples/data/highway-tailgated.jsonl.gz"
    result = evaluate_stream(
        case, spec, stream, RunOptions(), RunSinks(signals_path=tmp_path / "signals.npz")
    )
    log = load_signals(tmp_path)
    found, _ = knobs(case, spec)
    assert len(found) == len(spec.formulas) >= 17
    for knob in found:
        mine = [
            (round(a, 6), round(b, 6))
            for a, b in episodes_for(knob, log, knob.value, knob.duration)
        ]
        theirs = [
            (round(e.start, 6), round(e.end, 6))
            for e in result.episodes
            if e.node_id == knob.node_id
        ]
        assert mine == theirs, knob.formula_id
    assert json.loads(json.dumps([k.parameter for k in found]))  # plain values


def test_an_empty_sweep_names_the_rule():
    from casewatch.evaluator.tuning import TuningError

    with pytest.raises(TuningError, match="H: signal 'x' has no value in any log"):
        sweep(hazard("x < 0.9"), [saved([np.nan] * 5)], [[]])
    with pytest.raises(TuningError, match="no logs"):
        sweep(hazard("x < 0.9"), [], [])


def test_margins_are_the_distance_to_the_nearest_worse_threshold():
    th = np.array([0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7])
    best = np.array([False, True, True, True, True, False, False])
    # 0.2: 0.1 below, 0.6 above -> 0.1; 0.3 -> 0.2; 0.4 -> min(0.3, 0.2); 0.5 -> 0.1
    np.testing.assert_allclose(margins(th, best), [-1, 0.1, 0.2, 0.2, 0.1, -1, -1])
    # nothing worse: the outermost candidates bound the range
    np.testing.assert_allclose(margins(th[:3], np.ones(3, dtype=bool)), [0.0, 0.1, 0.0])


def test_the_middle_of_the_perfect_range_not_its_edge():
    """A mis-set `x < 1.6` whose hazards dip through 1.0 ... 0.5 and whose nominal driving
    holds 1.2 for a second: every threshold in (0.5, 1.2] separates them. The old rule (the
    nearest to the original) took 1.2, a hair under nominal driving; the largest margin to the
    errors on either side (0.5 and 1.6) is at 1.0: 0.5 from both."""
    x = [2.0] * 10 + [1.0, 0.9, 0.8, 0.7, 0.6, 0.5] + [2.0] * 10 + [1.2] * 10 + [2.0] * 10
    logs = [saved(x, path=f"log{k}") for k in range(2)]
    labels = [[Label("H", 1.0, 1.5, 1)] for _ in logs]
    sw = sweep(hazard("x < 1.6"), logs, labels, count=20)
    assert sw.thresholds == [0.5, 0.6, 0.7, 0.8, 0.9, 1.0, 1.2, 1.6, 2.0]
    result = tune(sw)
    assert (result["tuned"]["threshold"], result["tuned"]["duration"]) == (1.0, 0.0)
    assert result["original"]["fp"] == 2 and result["tuned"]["fp"] == 0


def test_durations_by_held_out_score_then_room_not_the_shortest_passing():
    """Hazards lasting 1.8 s and a 0.3 s nominal dip: `min_duration` 0 flags the dip, 2 s drops
    the hazards; 0.5, 1 and 1.5 s all score perfectly, on the logs and held out. The duration
    with the most room to the failing ones on either side is 1 s (the old rule took 0.5 s, the
    shortest passing one, next to the durations that let the dip through)."""
    x = [2.0] * 10 + [0.5] * 18 + [2.0] * 20 + [0.5] * 3 + [2.0] * 10
    logs = [saved(x, path=f"log{k}") for k in range(3)]
    labels = [[Label("H", 1.0, 2.7, 1)] for _ in logs]
    sw = sweep(hazard("x < 1.0"), logs, labels, count=20)
    assert sw.durations == [0.0, 0.5, 1.0, 1.5, 2.0]
    c = pick(sw, [0, 1, 2], "f1", None)
    assert sw.candidates()[c] == (1.0, 1.0)
    result = tune(sw)
    assert result["heldout"]["fp"] == 0 and result["heldout"]["fn"] == 0


def test_violations_follow_run_s_persistence_after_a_restart():
    """A `for:` SPI's violation counts once it has lasted `for:` of data, as `casewatch run`
    judges it: after the start and after a gap the first for/period samples give no verdict."""
    from casewatch.evaluator.tuning import violations
    from casewatch.spec.ast import Num, Signal

    condition = parse_formula("x >= 0.5")
    assert isinstance(condition.left, Signal) and isinstance(condition.right, Num)
    knob = Knob(
        "Sn1",
        "Sn1",
        "s",
        "spi",
        ">= 0.5",
        condition,
        (),
        "x",
        ">=",
        True,
        0.5,
        "for",
        0.3,
        0.0,
        0.0,
    )
    t = np.round(np.concatenate([np.arange(10) * 0.1, 2.0 + np.arange(10) * 0.1]), 6)
    log = SavedSignals("log", t, ["x"], np.full((20, 1), 0.2), PERIOD, 0.5)
    # 3 samples of each segment (the start, and after the 1.1 s gap) are no verdict
    assert (
        violations(knob, log, 0.5, 0.3).tolist()
        == [False] * 3 + [True] * 7 + [False] * 3 + [True] * 7
    )
    # without a `for:` every violated sample counts
    assert violations(knob, log, 0.5, 0.0).all()
