"""The bundled reference data (examples/data): present, well-formed, labelled. No SUMO needed."""

from __future__ import annotations

import gzip
import json
from pathlib import Path

import numpy as np
import pytest
import yaml

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "examples" / "data"
INDEX = json.loads((DATA / "index.json").read_text())
NAMES = [e["scenario"] for e in INDEX]
REFERENCE_HAZARDS = {"CSn1", "CSn2", "CSn3"}


def _rows(path: Path) -> list[dict]:
    opener = gzip.open if path.suffix == ".gz" else open
    with opener(path, "rt") as fh:
        return [json.loads(line) for line in fh if line.strip()]


def _labels(name: str) -> list[dict]:
    return _rows(DATA / f"{name}.labels.jsonl")


def test_index_lists_three_scenarios_with_files() -> None:
    assert NAMES == ["highway-tailgating", "highway-tailgated", "urban-grid"]
    for e in INDEX:
        for key in ("stream", "labels", "ssm_labels"):
            assert (DATA / e[key]).is_file(), e[key]


@pytest.mark.parametrize("name", NAMES)
def test_stream_has_header_and_increasing_frames(name: str) -> None:
    rows = _rows(DATA / f"{name}.jsonl.gz")
    head = rows[0]["header"]
    assert head["format"] == "casewatch-frames"
    assert head["channels"] == ["lav", "tfuse"]
    assert head["meta"]["scenario"] == name
    t = np.array([r["t"] for r in rows[1:]])
    assert np.all(np.diff(t) > 0)
    # 1 to 3 minutes at 0.1 s: duration / 0.1 + 1 frames
    assert 60.0 <= t[-1] - t[0] <= 180.0
    assert len(t) == round((t[-1] - t[0]) / 0.1) + 1


@pytest.mark.parametrize("name", NAMES)
def test_label_files_are_well_formed(name: str) -> None:
    for path in (DATA / f"{name}.labels.jsonl", DATA / f"{name}.ssm-labels.jsonl"):
        for lab in _rows(path):
            assert isinstance(lab["hazard"], str)
            assert 0.0 <= lab["start"] <= lab["end"]


def test_labels_cover_all_three_reference_hazards() -> None:
    found = {lab["hazard"] for name in NAMES for lab in _labels(name)}
    assert found >= REFERENCE_HAZARDS


def test_hazard_ids_exist_in_reference_case() -> None:
    case_file = ROOT / "examples" / "reference-case.yaml"
    if not case_file.exists():
        pytest.fail("examples/reference-case.yaml is missing; labels name its CSn nodes")
    case = yaml.safe_load(case_file.read_text())
    assert set(case) >= REFERENCE_HAZARDS
    assert "localization" in case["CSn1"]["text"].lower()
    assert "tailgating" in case["CSn2"]["text"].lower()
    assert "tailgated" in case["CSn3"]["text"].lower()


@pytest.mark.parametrize("name", NAMES)
def test_localization_labels_are_where_els_var_exceeds_reference_threshold(name: str) -> None:
    """els = 1/(1+dist(ego_lav, ego_tfuse)); els_var = sample variance over 5 ticks; the
    reference hazard is els_var > 0.05. It must fire inside each CSn1 label and nowhere else."""
    frames = _rows(DATA / f"{name}.jsonl.gz")[1:]
    t = np.array([f["t"] for f in frames])
    a = np.array([[f["channels"]["lav"]["ego"]["x"], f["channels"]["lav"]["ego"]["y"]]
                  for f in frames])
    b = np.array([[f["channels"]["tfuse"]["ego"]["x"], f["channels"]["tfuse"]["ego"]["y"]]
                  for f in frames])
    els = 1.0 / (1.0 + np.hypot(*(a - b).T))
    windows = np.lib.stride_tricks.sliding_window_view(els, 5)
    var = windows.var(axis=1, ddof=1)
    t_end = t[4:]  # the window ending at that tick
    inside = np.zeros(len(t_end), dtype=bool)
    labels = [lab for lab in _labels(name) if lab["hazard"] == "CSn1"]
    assert labels
    for lab in labels:
        sel = (t_end >= lab["start"]) & (t_end <= lab["end"] + 0.4)
        assert var[sel].max() > 0.05, lab
        inside |= sel
    assert var[~inside].max() < 0.05
