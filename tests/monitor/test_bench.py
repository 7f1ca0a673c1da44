"""The reference load the benchmarks share."""

from __future__ import annotations

import json

from bench.metrics import (
    CHANNELS,
    main,
    reference_load_dicts,
    reference_load_frames,
    run,
    stream_run,
)


def test_reference_load_shape_and_determinism():
    frames = reference_load_frames(3, seed=4)
    assert [f.t for f in frames] == [0.0, 0.1, 0.2]
    for f in frames:
        assert list(f.channels) == CHANNELS
        for s in f.channels.values():
            assert s.plan.shape == (50, 3)
            assert len(s.objects) == 40 and s.objects.pred.shape == (40, 30, 3)
    assert json.dumps(reference_load_dicts(2, 4)) == json.dumps(reference_load_dicts(2, 4))


def test_run_reports_every_family():
    rows = run(3, seed=0, warmup=1)
    assert set(rows) == {
        "similarity",
        "motion_prediction",
        "resampling",
        "comfort",
        "situation",
        "safety_score",
        "all metrics",
        "reading (json+parse)",
    }
    assert all(r["p99"] >= r["p50"] > 0 for r in rows.values())


def test_stream_run_measures_a_recorded_stream(tmp_path, capsys):
    path = tmp_path / "s.jsonl"
    path.write_text("\n".join(json.dumps(d) for d in reference_load_dicts(4, 1)) + "\n")
    rows = stream_run(str(path), limit=3)
    assert set(rows) == {
        "resampling",
        "similarity",
        "motion_prediction",
        "comfort",
        "situation",
        "safety_score",
        "all metrics",
    }
    assert all(r["p99"] >= r["p50"] > 0 and r["mean"] > 0 for r in rows.values())
    assert main(["--stream", str(path), "--frames", "0"]) == 0
    assert "all metrics" in capsys.readouterr().out
