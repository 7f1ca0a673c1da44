"""A 1-hour run's report stays under 5 MB (timing is printed by `python -m bench.reports`)."""

from __future__ import annotations

from casewatch.reports.html import render_html
from casewatch.reports.plot import MAX_BUCKETS
from tools.sample import long_run_result, sample_result

FIVE_MB = 5 * 1024 * 1024


def test_one_hour_report_under_5_mb() -> None:
    result = long_run_result()
    assert result.stream.frames_read == 36_000  # 3600 s at 10 Hz
    assert len(result.episodes) > 200 and len(result.data_gaps) > 200
    html = render_html(result)
    assert len(html.encode("utf-8")) < FIVE_MB
    assert f'id="episode-{len(result.episodes)}"' in html  # every episode still has a section


def test_undecimated_series_are_bounded_by_the_report() -> None:
    # An evaluator that forgot to decimate: 36 000 buckets per series. The plot re-buckets to
    # MAX_BUCKETS, so the report stays small.
    result = sample_result(duration=3600.0, max_buckets=36_000, dips_per_minute=0.2)
    assert len(result.series[0].t) == 36_000
    html = render_html(result)
    assert len(html.encode("utf-8")) < FIVE_MB
    band = html.split('id="plot-Sn1"')[1].split('class="band" d="')[1].split('"')[0]
    # one point per bucket on the upper (max) edge and one on the lower (min) edge
    assert MAX_BUCKETS < band.count(",") <= 2 * MAX_BUCKETS


def test_thousands_of_episodes_keep_every_section_but_bound_traces() -> None:
    from casewatch.reports.html import TRACE_LIMIT

    base = sample_result(duration=60.0)
    episode = base.episodes[0]
    many = [episode.model_copy(update={"start": i * 0.1, "end": i * 0.1}) for i in range(1200)]
    html = render_html(base.model_copy(update={"episodes": many}))
    assert 'id="episode-1200"' in html and 'id="episode-1"' in html
    # episodes of one node starting 0.1 s apart form incidents of 11 (starts within
    # INCIDENT_WINDOW = 1 s of the first, inclusive: one card, one trace each): 109 incident
    # cards and one single card left over; traces stay bounded by TRACE_LIMIT either way
    paths = len(episode.trace)
    assert html.count('class="episode incident"') == 1200 // 11 == 109
    assert html.count('<ol class="trace">') <= TRACE_LIMIT * paths
    # apart (2 s between starts) every episode is its own card: the first TRACE_LIMIT draw
    # their trace, the rest link to the node's trace
    apart = [episode.model_copy(update={"start": i * 2.0, "end": i * 2.0}) for i in range(1200)]
    html = render_html(base.model_copy(update={"episodes": apart}))
    assert html.count("(traces of episodes past #") == 1200 - TRACE_LIMIT
