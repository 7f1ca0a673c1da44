"""LiveState fed by a real run of the small case (tests.evaluator.streams): one SPI episode of
Sn1 from 2.0 to 3.0 s (els = 1/3 below its 0.6 threshold), Sn1 without data 5.0-5.5 s."""

from __future__ import annotations

import pytest

from casewatch import api
from casewatch.evaluator.options import RunOptions, RunSinks
from casewatch.evaluator.result import OddChange
from casewatch.evaluator.session import evaluate_stream
from casewatch.live.state import LiveState
from tests.evaluator.streams import write_case, write_stream


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    root = tmp_path_factory.mktemp("state")
    case, spec = api.prepare(str(write_case(root / "case.yaml")))
    return case, spec, write_stream(root / "s.jsonl")


class Clock:
    """The wall clock of a test: set to each frame's time (plus a delay) as it is judged."""

    def __init__(self, delay=lambda t: 0.0) -> None:
        self.now = 0.0
        self.delay = delay

    def __call__(self) -> float:
        return self.now


def run_with(small, state: LiveState, at_tick=None, clock: Clock | None = None):
    """Judge the small stream with `state` observing; `at_tick(t)` after each tick."""
    case, spec, stream = small

    def on_tick(frame, statuses, evaluator, reader):
        if clock is not None:
            clock.now = frame.t + clock.delay(frame.t)
        state.on_tick(frame, statuses, evaluator, reader)
        if at_tick is not None:
            at_tick(frame.t)

    sinks = RunSinks(on_event=state.on_event, on_tick=on_tick)
    return evaluate_stream(case, spec, str(stream), RunOptions(), sinks)


def test_the_snapshot_holds_the_run_so_far(small):
    _, spec, _ = small
    clock = Clock()
    state = LiveState(spec, 0.1, clock=clock)
    seen = {}

    def at_tick(t):
        if round(t, 6) in (1.0, 2.5, 4.0):
            seen[round(t, 6)] = state.snapshot()[0]

    result = run_with(small, state, at_tick, clock)
    sn1 = [f["id"] for f in seen[1.0]["formulas"]].index("Sn1")
    at_1, at_25, at_4 = seen[1.0], seen[2.5], seen[4.0]
    assert at_1["status"]["Sn1"] == "satisfied" and at_1["status"]["G1"] == "satisfied"
    assert at_1["ticks"][-1][0] == 1.0 and at_1["ticks"][-1][1][sn1] == 1.0  # els, agreeing
    assert at_25["status"]["Sn1"] == "violated" and at_25["status"]["G1"] == "undermined"
    assert at_25["ticks"][-1][1][sn1] == pytest.approx(1 / 3, abs=1e-4)  # 2 m apart
    assert [e["node"] for e in at_25["open"]] == ["Sn1"] and at_25["open"][0]["start"] == 2.0
    assert at_25["open"][0]["trace"] == [["Sn1", "G2", "S1", "G1"]]
    assert at_4["open"] == [] and at_4["counts"]["episodes"] == 1
    assert (at_4["closed"][0]["start"], at_4["closed"][0]["end"]) == (2.0, 3.0)
    assert at_4["formulas"][sn1] == {
        "id": "Sn1",
        "node": "Sn1",
        "kind": "spi",
        "quantity": "els",
        "reference": 0.6,
        "threshold": ">= 0.6",
    }
    # the wall clock advances as the stream does: judged on time, 0 s behind
    assert at_4["stream"]["behind"] == 0.0 and at_4["stream"]["frames"] == 41
    final, _ = state.snapshot()
    assert final["counts"]["data_gaps"] == 1 and final["gaps"][0]["missing"] == ["els"]
    assert final["status"] == {s.node_id: s.timeline[-1].status for s in result.status}
    assert final["stream"]["dropouts"] == {"lav": 0, "tfuse": 6}


def test_the_window_keeps_the_last_minute_only(small):
    _, spec, _ = small
    state = LiveState(spec, 0.1, window_s=2.0)
    run_with(small, state)
    body, _ = state.snapshot()
    assert [round(t, 6) for t, _ in body["ticks"]] == [round(8.0 + k / 10, 6) for k in range(20)]


def test_deltas_send_new_ticks_and_only_what_changed(small):
    _, spec, _ = small
    state = LiveState(spec, 0.1)
    cursors = {}

    def at_tick(t):
        t = round(t, 6)
        if t == 0.5:
            cursors["a"] = state.snapshot()[1]
        elif t == 0.8:
            body, cursors["b"] = state.delta(cursors["a"])
            cursors["body_b"] = body
        elif t == 2.0:
            cursors["body_c"], _ = state.delta(cursors["b"])

    run_with(small, state, at_tick)
    b = cursors["body_b"]
    assert [round(t, 6) for t, _ in b["ticks"]] == [0.6, 0.7, 0.8]
    assert "status" not in b and "open" not in b  # nothing changed from 0.5 to 0.8 s
    c = cursors["body_c"]
    assert c["status"]["Sn1"] == "violated"  # the onset tick
    assert [e["node"] for e in c["open"]] == ["Sn1"]


def test_the_final_verdict_stays(small):
    _, spec, _ = small
    clock = Clock()
    state = LiveState(spec, 0.1, clock=clock)
    result = run_with(small, state, clock=clock)
    state.finish(result)
    body, cursor = state.snapshot()
    assert body["final"]["verdict"] == result.verdict == "undermined"
    assert body["final"]["frames"] == 100 and body["final"]["episodes"] == 1
    behind = body["stream"]["behind"]
    clock.now += 50.0  # time passes after the end: the indicator stays frozen
    assert state.snapshot()[0]["stream"]["behind"] == behind
    assert state.delta(cursor)[0] is None  # nothing changes any more


def test_a_stalled_stream_falls_behind(small):
    _, spec, _ = small
    clock = Clock(delay=lambda t: 3.0 if t >= 5.0 else 0.0)  # 3 s late from 5 s on
    state = LiveState(spec, 0.1, clock=clock)
    run_with(small, state, clock=clock)
    clock.now += 0.5  # and half a second without a frame since the last
    assert state.snapshot()[0]["stream"]["behind"] == pytest.approx(3.5)


def test_defects_dropouts_and_odd_changes_reach_the_page(small, tmp_path):
    case, spec, stream = small
    lines = stream.read_text().splitlines()
    lines.insert(12, '{"t": "not a time"}')  # one defect, on line 13
    broken = tmp_path / "broken.jsonl"
    broken.write_text("\n".join(lines) + "\n")
    state = LiveState(spec, 0.1)
    run_with((case, spec, broken), state)
    body, _ = state.snapshot()
    assert body["stream"]["defect_count"] == 1
    assert body["stream"]["defects"][0]["line"] == 13
    assert body["stream"]["dropouts"] == {"lav": 0, "tfuse": 6}
    state.on_event(OddChange(node_id="C1", t=4.2, state="outside", because="weather = fog"))
    body, _ = state.snapshot()
    assert body["odd"] == {"C1": {"state": "outside", "because": "weather = fog", "t": 4.2}}
