"""Episodes: consecutive violating ticks, merged across short clean stretches."""

from casewatch.evaluator.episodes import EpisodeTracker

P = 0.1


def feed(tracker: EpisodeTracker, robustness: list[float | None], t0: float = 0.0):
    closed = []
    for i, r in enumerate(robustness):
        done = tracker.step(round(t0 + i * P, 6), r)
        if done:
            closed.append(done)
    done = tracker.finish()
    if done:
        closed.append(done)
    return closed


def test_consecutive_violations_form_one_episode_with_worst_value():
    tracker = EpisodeTracker(merge_gap=1.0, min_duration=0.0, period=P)
    # ticks 0..7: violated at t=0.2, 0.3, 0.4 with robustness -0.1, -0.5, -0.2
    closed = feed(tracker, [0.3, 0.2, -0.1, -0.5, -0.2, 0.4, 0.4, 0.4])
    assert len(closed) == 1
    e = closed[0]
    assert (e.start, e.end, e.ticks) == (0.2, 0.4, 3)
    assert e.worst_robustness == -0.5 and e.t_worst == 0.3


def test_episodes_closer_than_merge_gap_merge_and_farther_ones_do_not():
    tracker = EpisodeTracker(merge_gap=0.5, min_duration=0.0, period=P)
    # violation at t=0.0; clean 0.1..0.4 (0.4 s clean < 0.5) -> violation at 0.5 merges;
    # then clean 0.6..1.1 (0.6 s >= 0.5) -> violation at 1.2 is a new episode.
    r = [-1.0, 1, 1, 1, 1, -2.0, 1, 1, 1, 1, 1, 1, -0.5, 1]
    closed = feed(tracker, r)
    assert [(e.start, e.end, e.ticks) for e in closed] == [(0.0, 0.5, 2), (1.2, 1.2, 1)]
    assert closed[0].worst_robustness == -2.0 and closed[0].t_worst == 0.5


def test_zero_merge_gap_keeps_adjacent_ticks_together_but_splits_on_a_clean_tick():
    tracker = EpisodeTracker(merge_gap=0.0, min_duration=0.0, period=P)
    closed = feed(tracker, [-1, -1, 1, -1])
    assert [(e.start, e.end) for e in closed] == [(0.0, 0.1), (0.3, 0.3)]


def test_min_duration_drops_short_episodes_and_counts_them():
    tracker = EpisodeTracker(merge_gap=0.0, min_duration=0.3, period=P)
    # first episode 2 ticks = 0.2 s (dropped), second 3 ticks = 0.3 s (kept)
    closed = feed(tracker, [-1, -1, 1, 1, -1, -1, -1, 1])
    assert [(e.start, e.end) for e in closed] == [(0.4, 0.6)]
    assert tracker.dropped == 1 and tracker.closed == 1


def test_data_gap_neither_extends_nor_closes_an_episode():
    tracker = EpisodeTracker(merge_gap=1.0, min_duration=0.0, period=P)
    closed = feed(tracker, [-1, None, None, -1])
    assert [(e.start, e.end, e.ticks) for e in closed] == [(0.0, 0.3, 2)]


def test_episode_is_returned_when_merge_window_passes_not_before():
    tracker = EpisodeTracker(merge_gap=0.3, min_duration=0.0, period=P)
    assert tracker.step(0.0, -1) is None
    assert tracker.step(0.1, 1) is None  # clean 0.0 s so far
    assert tracker.step(0.2, 1) is None  # clean since 0.1: 0.1 s
    # at 0.3 a violation from 0.4 on would be 0.3 s of clean time away: no merge possible
    done = tracker.step(0.3, 1)
    assert done is not None and (done.start, done.end) == (0.0, 0.0)


def test_onset_is_announced_once_the_episode_is_certain():
    # min_duration 0.3 s, merge_gap 0.5 s, period 0.1 s: ticks 0.0 and 0.1 violate (0.2 s, not
    # yet certain), 0.2 is clean, 0.3 violates again: the same episode, now 0.4 s long, so it
    # is announced at 0.3 s with its start 0.0; later ticks do not announce it again
    from casewatch.evaluator.episodes import EpisodeTracker

    tracker = EpisodeTracker(0.5, 0.3, 0.1)
    seen = []
    for t, rho in ((0.0, -1.0), (0.1, -1.0), (0.2, 1.0), (0.3, -1.0), (0.4, -1.0)):
        tracker.step(t, rho)
        opened = tracker.onset()
        seen.append(None if opened is None else (t, opened.start))
    assert seen == [None, None, None, (0.3, 0.0), None]
    # a violation shorter than min_duration is never announced (and then dropped)
    short = EpisodeTracker(0.5, 0.3, 0.1)
    short.step(0.0, -1.0)
    assert short.onset() is None
    assert short.step(1.0, 1.0) is None and short.onset() is None and short.dropped == 1
