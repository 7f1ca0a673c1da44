"""End to end: a hand-made two-channel stream through metrics, STL, episodes and status."""

from __future__ import annotations

import json

import pytest

from casewatch import api
from casewatch.evaluator.session import InputError, RunOptions, RunSinks, evaluate_stream
from tests.evaluator.streams import frame, write_case, write_stream


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    folder = tmp_path_factory.mktemp("e2e")
    case_path = write_case(folder / "case.yaml")
    stream = write_stream(folder / "stream.jsonl")
    case, spec = api.prepare(case_path)
    events = folder / "events.jsonl"
    result = evaluate_stream(case, spec, stream, RunOptions(), RunSinks(events_path=events))
    return result, events


def test_exactly_one_els_episode_from_2_0_to_3_0(run):
    result, _ = run
    els = [e for e in result.episodes if e.node_id == "Sn1"]
    assert len(els) == 1
    episode = els[0]
    assert (episode.start, episode.end, episode.ticks) == (2.0, 3.0, 11)
    # els = 1 / (1 + 2) during the disagreement, robustness = 1/3 - 0.6
    assert episode.worst_robustness == pytest.approx(1 / 3 - 0.6, abs=1e-9)


def test_trace_ends_at_the_root_goal(run):
    result, _ = run
    episode = next(e for e in result.episodes if e.node_id == "Sn1")
    assert [[s.id for s in path] for path in episode.trace] == [["Sn1", "G2", "S1", "G1"]]
    assert episode.trace[0][-1].text == "EGO vehicle goes from Point A to Point B safely"


def test_dropout_is_a_data_gap_not_a_pass(run):
    result, _ = run
    gaps = [g for g in result.data_gaps if g.node_id == "Sn1"]
    assert [(g.start, g.end, g.ticks, g.missing) for g in gaps] == [(5.0, 5.5, 6, ["els"])]
    stats = next(f for f in result.formulas if f.node_id == "Sn1")
    assert (stats.ticks_evaluated, stats.ticks_no_data, stats.ticks_violated) == (94, 6, 11)
    assert result.stream.dropouts == {"lav": 0, "tfuse": 6}


def test_root_is_undermined_exactly_over_the_episode(run):
    result, _ = run
    root = next(s for s in result.status if s.node_id == "G1")
    spans = [(i.status, i.start, i.end) for i in root.timeline]
    assert spans == [
        ("satisfied", 0.0, 1.9),
        ("undermined", 2.0, 3.0),
        ("satisfied", 3.1, 4.9),
        ("no-data", 5.0, 5.5),
        ("satisfied", 5.6, 9.9),
    ]
    assert result.verdict == "undermined"


def test_hazard_never_fired_and_its_node_is_satisfied(run):
    result, _ = run
    assert not [e for e in result.episodes if e.kind == "hazard"]
    csn = next(s for s in result.status if s.node_id == "CSn1")
    assert csn.worst == "satisfied" and csn.ticks == {"satisfied": 100}


def test_events_log_holds_the_episode_and_the_gap(run):
    _, events = run
    lines = [json.loads(line) for line in events.read_text().splitlines()]
    kinds = [(e["event"], e["node_id"], e["start"]) for e in lines]
    assert ("spi_episode", "Sn1", 2.0) in kinds and ("data_gap", "Sn1", 5.0) in kinds


def test_result_round_trips_through_json(run):
    result, _ = run
    again = type(result).model_validate_json(result.model_dump_json())
    assert again == result


def test_period_mismatch_is_an_input_error(tmp_path):
    case, spec = api.prepare(write_case(tmp_path / "case.yaml"))
    stream = tmp_path / "s.jsonl"
    stream.write_text(
        json.dumps({"header": {"channels": ["lav", "tfuse"], "period": 0.05}})
        + "\n"
        + json.dumps({"t": 0.0, "channels": {}})
        + "\n"
    )
    with pytest.raises(InputError, match=r"s.jsonl:1: the stream's period is 0.05 s"):
        evaluate_stream(case, spec, stream)


def test_labels_score_one_tp_one_fp_one_fn(tmp_path):
    """The speed hazard fires twice (3.0-3.9 s and 7.0-7.4 s); labels at 3.5-4.5 (TP) and
    8.5-9.0 (FN); the second event matches nothing (FP): precision 1/2, recall 1/2."""
    case, spec = api.prepare(write_case(tmp_path / "case.yaml"))
    lines = []
    for i in range(100):
        t = round(i * 0.1, 6)
        speed = 25.0 if 3.0 <= t <= 3.9 or 7.0 <= t <= 7.4 else 10.0
        ch = {"ego": {"x": t, "y": 0.0, "yaw": 0.0, "length": 4.5, "width": 1.8}}
        lines.append(
            json.dumps({"t": t, "channels": {"lav": ch, "tfuse": ch}, "signals": {"speed": speed}})
        )
    stream = tmp_path / "s.jsonl"
    stream.write_text("\n".join(lines) + "\n")
    labels = tmp_path / "labels.jsonl"
    labels.write_text(
        '{"hazard": "CSn1", "start": 3.5, "end": 4.5}\n'
        '{"hazard": "Ego far off the speed limit", "start": 8.5, "end": 9.0}\n'
    )
    result = evaluate_stream(case, spec, stream, RunOptions(labels=labels))
    hazards = [(e.start, e.end) for e in result.episodes if e.kind == "hazard"]
    assert hazards == [(3.0, 3.9), (7.0, 7.4)]
    gt = result.ground_truth
    assert gt is not None
    score = gt.per_hazard[0]
    assert (score.true_positives, score.false_positives, score.false_negatives) == (1, 1, 1)
    assert score.precision == pytest.approx(0.5) and score.recall == pytest.approx(0.5)


def test_frames_missing_longer_than_max_gap_are_a_gap_for_every_formula(tmp_path):
    """Frames 3.0-3.9 s are absent (1.1 s between 2.9 and 4.0 > max_gap 0.5 s): ten missing
    ticks, a data gap from 3.0 to 3.9 for each formula, and no-data in the root's timeline."""
    case, spec = api.prepare(write_case(tmp_path / "case.yaml"))
    stream = tmp_path / "s.jsonl"
    ticks = [i for i in range(60) if not 30 <= i <= 39]
    stream.write_text("".join(json.dumps(frame(i)) + "\n" for i in ticks))
    result = evaluate_stream(case, spec, stream)
    gaps = {(g.node_id, g.start, g.end, g.ticks, tuple(g.missing)) for g in result.data_gaps}
    assert ("Sn1", 3.0, 3.9, 10, ("(no frames)",)) in gaps
    assert ("CSn1", 3.0, 3.9, 10, ("(no frames)",)) in gaps
    root = next(s for s in result.status if s.node_id == "G1")
    assert ("no-data", 3.0, 3.9, 10) in [(i.status, i.start, i.end, i.ticks) for i in root.timeline]
    # the ELS episode (2.0-3.0 s) is cut by the missing frames: it ends at 2.9
    assert [(e.start, e.end) for e in result.episodes if e.node_id == "Sn1"] == [(2.0, 2.9)]
