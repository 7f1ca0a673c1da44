"""Violated share of nominal ticks: hand-built timelines, labels with a margin."""

from __future__ import annotations

import json

import numpy as np
import pytest

from casewatch.evaluator.ground_truth import Label
from casewatch.evaluator.nominal import nominal_mask, nominal_shares
from casewatch.evaluator.result import FormulaStats, NodeStatus, RunResult, StatusInterval
from casewatch.nominal import main as nominal_main


def formula(node: str, signal: str, kind: str = "spi") -> FormulaStats:
    return FormulaStats(
        id=node, node_id=node, node_text=node, kind=kind, source=signal, rtamt="", signal=signal
    )


def interval(status: str, start: float, end: float) -> StatusInterval:
    return StatusInterval(status=status, start=start, end=end, ticks=round((end - start) / 0.1) + 1)


def test_nominal_mask_keeps_ticks_beyond_the_margin():
    t = np.round(np.arange(0, 101) * 0.1, 1)  # 0.0 .. 10.0
    mask = nominal_mask(t, [Label("CSn2", 4.0, 5.0, 1)], margin=1.0)
    # 3.0 .. 6.0 lie within 1 s of the label: 31 ticks; the other 70 are nominal
    assert mask.sum() == 70
    assert not mask[30] and not mask[60] and mask[29] and mask[61]


def test_shares_count_only_evaluated_nominal_ticks():
    # Sn1 over 0 .. 9.9 s: violated 1.0-1.4 (5 ticks, nominal) and 4.0-4.4 (5 ticks, inside
    # the label's margin), no data 8.0-9.9 (20 ticks). Label 4.2-4.3, margin 1 s: 3.2-5.3 is
    # not nominal (22 ticks). Evaluated nominal ticks: 100 - 20 - 22 = 58; violated 5.
    result = RunResult.model_construct(
        formulas=[formula("Sn1", "els"), formula("CSn1", "els_var", "hazard")],
        status=[
            NodeStatus(
                node_id="Sn1",
                worst="violated",
                timeline=[
                    interval("satisfied", 0.0, 0.9),
                    interval("violated", 1.0, 1.4),
                    interval("satisfied", 1.5, 3.9),
                    interval("violated", 4.0, 4.4),
                    interval("satisfied", 4.5, 7.9),
                    interval("no-data", 8.0, 9.9),
                ],
            )
        ],
    )
    (row,) = nominal_shares(result, [Label("CSn1", 4.2, 4.3, 1)], margin=1.0)
    assert (row.node_id, row.signal, row.evaluated, row.violated) == ("Sn1", "els", 58, 5)
    assert row.share == pytest.approx(5 / 58)


def test_cli_needs_labels_and_prints_the_table(tmp_path, capsys):
    from casewatch.evaluator.result import CaseInfo, GroundTruth, HazardScore, StreamInfo

    labels = tmp_path / "drive.labels.jsonl"
    labels.write_text(json.dumps({"hazard": "CSn1", "start": 4.2, "end": 4.3}) + "\n")
    score = HazardScore(
        hazard="all",
        true_positives=0,
        false_positives=0,
        false_negatives=0,
        precision=None,
        recall=None,
    )
    run = tmp_path / "drive"
    run.mkdir()
    result = RunResult(
        casewatch_version="t",
        created="2026-11-24T00:00:00Z",
        case=CaseInfo(
            path="c",
            digest="d",
            module="m",
            root_id="G1",
            channels=["a", "b"],
            period=0.1,
            nodes=[],
        ),
        stream=StreamInfo(path="s", digest=None),
        verdict="violated",
        formulas=[formula("Sn1", "els")],
        episodes=[],
        data_gaps=[],
        series=[],
        status=[
            NodeStatus(
                node_id="Sn1",
                worst="violated",
                timeline=[interval("satisfied", 0.0, 0.9), interval("violated", 1.0, 1.4)],
            )
        ],
        ground_truth=None,
    )
    (run / "result.json").write_text(result.model_dump_json())
    assert nominal_main([str(run)]) == 2  # judged without labels: refused, not guessed
    assert "--labels" in capsys.readouterr().err
    result.ground_truth = GroundTruth(
        labels_path=str(labels), labels_digest="x", per_hazard=[], overall=score
    )
    (run / "result.json").write_text(result.model_dump_json())
    # default margin 3 s around 4.2-4.3: ticks 0.0-1.1 are nominal (12), of which 1.0 and 1.1
    # violated: 2 / 12 = 16.67 % > 1 %: exit 1
    assert nominal_main([str(run)]) == 1
    out = capsys.readouterr().out
    assert "Sn1 els" in out and "16.67% !" in out and "12" in out
    assert nominal_main([str(tmp_path / "missing")]) == 2
    # an SSM conflict beside the labels (drive.ssm-labels.jsonl) at 2.0-2.0 s: 3 s around it
    # covers every tick 0.0-1.4, so no tick is nominal ("n/a", exit 0); --no-ssm counts them
    ssm = tmp_path / "drive.ssm-labels.jsonl"
    ssm.write_text(json.dumps({"hazard": "ssm-conflict", "start": 2.0, "end": 2.0}) + "\n")
    assert nominal_main([str(run)]) == 0
    out = capsys.readouterr().out
    assert "SSM conflict" in out and "n/a" in out
    assert nominal_main([str(run), "--no-ssm"]) == 1
    assert "16.67% !" in capsys.readouterr().out
    ssm.write_text("not json\n")  # a broken SSM file is an input error, never a silent skip
    assert nominal_main([str(run)]) == 2
    assert "drive.ssm-labels.jsonl:1" in capsys.readouterr().err
