"""Status propagation up supportedBy, and doubt from active hazards."""

from evaluator.status import StatusPropagator
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
