"""`python -m examples.sim.heldout`: fresh seeds generated once, judged, figures per seed."""

from __future__ import annotations

import pytest

pytest.importorskip("libsumo", reason="SUMO not installed: pip install -e .[sim]")
pytest.importorskip("sumolib", reason="SUMO not installed: pip install -e .[sim]")

from examples.sim import heldout


def test_a_seed_is_generated_once_judged_and_printed(tmp_path, monkeypatch, capsys):
    # the 20 s test scenario only (the ego tailgates from 3 s, one tfuse fault at 10 s)
    monkeypatch.setattr(heldout, "KINDS", ("highway-short",))
    assert heldout.main(["--seeds", "7", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "generating 1 drives with seed 7" in out
    assert "Seed 7 (1 drives" in out
    rows = {line.split()[0]: line for line in out.splitlines() if "TP/FP/FN" in line}
    assert set(rows) == {"CSn1", "CSn2", "CSn3", "all"}
    assert "1/0/0 TP/FP/FN, P 100%, R 100%" in rows["CSn1"]  # the injected fault is found
    assert "SPI violated share of nominal ticks" in out
    stream = tmp_path / "s7" / "highway-short.jsonl.gz"
    stamp = stream.stat().st_mtime_ns
    # a second run reuses the drives of the seed and judges them again
    assert heldout.main(["--seeds", "7", "--out", str(tmp_path)]) == 0
    assert "generating" not in capsys.readouterr().out
    assert stream.stat().st_mtime_ns == stamp
