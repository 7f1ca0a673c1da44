"""Incident triage in the report: grouping, TP/FP marks, labels on plots, arbitration strip."""

from __future__ import annotations

from casewatch.evaluator.result import Episode, TraceStep
from casewatch.reports.view import EpisodeView, incidents

GOALS = {"Sn1": "G2", "Sn4": "G3", "Sn5": "G3", "Sn6": "G3"}


def view(number: int, node: str, start: float) -> EpisodeView:
    path = [
        TraceStep(id=node, text=""),
        TraceStep(id=GOALS[node], text=""),
        TraceStep(id="S1", text=""),
        TraceStep(id="G1", text=""),
    ]
    e = Episode(
        formula_id=node,
        node_id=node,
        kind="spi",
        start=start,
        end=start + 1,
        ticks=10,
        worst_robustness=-0.1,
        t_worst=start,
        trace=[path],
    )
    return EpisodeView(number, "spi", node, "", node, "", "", "", 10, "", "", [path], e)


def test_episodes_starting_together_under_one_goal_form_one_incident():
    # Sn4 and Sn5 (both under G3) start 0.5 s apart: one incident. Sn1 starts in between but
    # argues G2 (the strategy S1 and the root G1 are shared by all and do not count): its own.
    # Sn6 (G3) starts 1.2 s after the incident's first episode: the next incident.
    got = incidents(
        [view(1, "Sn4", 10.0), view(2, "Sn1", 10.2), view(3, "Sn5", 10.5), view(4, "Sn6", 11.2)]
    )
    assert [[m.node_id for m in inc.members] for inc in got] == [["Sn4", "Sn5"], ["Sn1"], ["Sn6"]]
    assert got[0].shared == ["G3"] and got[1].shared == ["G2"]


def test_report_marks_events_draws_labels_and_the_arbitration_strip(real_run_result):
    from casewatch.reports.html import render_html

    html = render_html(real_run_result)
    marks = real_run_result.ground_truth.marks
    assert marks and html.count('<span class="mark TP">TP</span>') >= sum(
        m.match == "TP" for m in marks
    )
    assert '<rect class="label-span"' in html  # the hazard plots show the labels
    assert 'class="strip arbitration"' in html and 'class="arb-0"' in html
