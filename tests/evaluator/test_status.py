"""Status propagation up supportedBy, and doubt from active hazards."""

from casewatch.evaluator.result import STATUS_SEVERITY, NodeStatus, StatusInterval
from casewatch.evaluator.status import StatusPropagator, summarize
from tests.evaluator.case_factory import small_case

FORMULAS = {"Sn1": "Sn1", "Sn2": "Sn2", "CSn1": "CSn1"}


def statuses(**verdicts):
    return StatusPropagator(small_case(), FORMULAS).statuses(verdicts)


def test_all_ok_is_satisfied_and_external_nodes_stay_neutral():
    s = statuses(Sn1="ok", Sn2="ok", CSn1="ok")
    assert s["Sn3"] == "external" and s["C1"] == "external"
    assert s["G3"] == "satisfied"  # Sn2 satisfied + Sn3 external
    assert s["G1"] == "satisfied" and s["CSn1"] == "satisfied"


def test_violated_evidence_undermines_every_claim_above_it():
    s = statuses(Sn1="violated", Sn2="ok", CSn1="ok")
    assert s["Sn1"] == "violated"
    assert (s["G2"], s["S1"], s["G1"]) == ("undermined",) * 3
    assert s["G3"] == "satisfied"


def test_active_hazard_puts_the_challenged_claim_and_its_parents_in_doubt():
    s = statuses(Sn1="ok", Sn2="ok", CSn1="violated")
    assert s["CSn1"] == "violated"
    assert (s["G2"], s["S1"], s["G1"]) == ("in-doubt",) * 3
    assert s["G3"] == "satisfied"


def test_violation_outranks_doubt_and_doubt_outranks_missing_data():
    s = statuses(Sn1="violated", Sn2="no-data", CSn1="violated")
    assert s["G2"] == "undermined" and s["G1"] == "undermined"
    s = statuses(Sn1="ok", Sn2="no-data", CSn1="violated")
    assert s["G3"] == "no-data" and s["G1"] == "in-doubt"


def test_missing_data_is_never_satisfied():
    s = statuses(Sn1="no-data", Sn2="ok", CSn1="no-data")
    assert s["Sn1"] == "no-data" and s["G2"] == "no-data" and s["G1"] == "no-data"
    assert s["CSn1"] == "no-data"


def node_status(*runs: tuple[str, int]) -> NodeStatus:
    """A node's run-length timeline at 0.1 s per tick, from (status, ticks) stretches."""
    timeline, ticks, t = [], {}, 0.0
    for status, n in runs:
        timeline.append(StatusInterval(status=status, start=t, end=t + 0.1 * (n - 1), ticks=n))
        ticks[status] = ticks.get(status, 0) + n
        t += 0.1 * n
    worst = max(ticks, key=STATUS_SEVERITY.__getitem__)
    return NodeStatus(node_id="Sn8", worst=worst, timeline=timeline, ticks=ticks)


def test_one_warm_up_tick_does_not_grey_out_a_satisfied_node():
    s = summarize(node_status(("no-data", 1), ("satisfied", 1199)), 0.1)
    assert (s.worst, s.status, s.warmup_ticks) == ("no-data", "satisfied", 1)
    # 3 s of warm-up (comfort fits), then satisfied: still satisfied
    assert summarize(node_status(("no-data", 30), ("satisfied", 1170)), 0.1).status == "satisfied"


def test_gaps_colour_a_node_only_from_one_percent_of_its_ticks_after_warm_up():
    short = node_status(("no-data", 5), ("satisfied", 600), ("no-data", 11), ("satisfied", 584))
    assert summarize(short, 0.1).status == "satisfied"  # 11 of 1195 ticks: 0.92 %
    long = node_status(("no-data", 5), ("satisfied", 600), ("no-data", 13), ("satisfied", 582))
    assert summarize(long, 0.1).status == "no-data"  # 13 of 1195: 1.09 %
    # a run that starts without data for longer than 10 s: only 10 s of it is warm-up
    late = node_status(("no-data", 200), ("satisfied", 1800))
    assert summarize(late, 0.1).warmup_ticks == 101 and summarize(late, 0.1).status == "no-data"
    # never any data: no warm-up, no data
    never = summarize(node_status(("no-data", 50)), 0.1)
    assert (never.status, never.warmup_ticks) == ("no-data", 0)
    assert summarize(None, 0.1).status == "no-data"


def test_findings_colour_a_node_from_a_single_tick():
    one = node_status(("satisfied", 5000), ("violated", 1), ("satisfied", 4999))
    assert summarize(one, 0.1).status == "violated"
    doubt = node_status(("no-data", 3), ("satisfied", 900), ("in-doubt", 2), ("no-data", 95))
    assert summarize(doubt, 0.1).status == "in-doubt"
    # below the findings, the worst status with 1 % or more: outside-odd over satisfied
    odd = node_status(("satisfied", 900), ("outside-odd", 100))
    assert summarize(odd, 0.1).status == "outside-odd"
    assert summarize(node_status(("satisfied", 999), ("outside-odd", 1)), 0.1).status == "satisfied"
