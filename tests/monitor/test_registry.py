"""The metric registry: the registered families together write every built-in signal the
catalogue names (world inputs apart, which frames carry), each signal written by one family."""

from __future__ import annotations

from bench.metrics import CHANNELS, reference_load_frames
from casewatch.monitor.engine import FAMILIES, MetricEngine
from casewatch.monitor.families.comfort import ComfortFamily
from casewatch.monitor.frames import Coverage
from casewatch.monitor.registry import FAMILIES as REGISTERED
from casewatch.safety_case.model import MetricParams
from casewatch.safety_case.signals import WORLD_METRICS, builtin_signals


class _Recording(dict):
    """The tick's output dict, remembering which keys were written."""

    def __init__(self, *args):
        super().__init__(*args)
        self.written: set[str] = set()

    def __setitem__(self, key, value):
        self.written.add(key)
        super().__setitem__(key, value)

    def update(self, *args, **kwargs):
        # a family may write its signals in one `dict.update` (family.KernelOutputs), which
        # does not go through __setitem__
        items = dict(*args, **kwargs)
        self.written.update(items)
        super().update(items)


def test_every_catalogue_signal_has_exactly_one_family():
    engine = MetricEngine(MetricParams(), CHANNELS)
    writers: dict[str, list[str]] = {}
    for frame in reference_load_frames(3):
        states = engine._resampled(frame)
        out = _Recording(dict.fromkeys(engine.signal_names))
        for family in engine.families:
            before = set(out.written)
            family.step(frame.t, states, out)
            for key in out.written - before:
                writers.setdefault(key, [])
                if family.name not in writers[key]:
                    writers[key].append(family.name)
    expected = set(builtin_signals(CHANNELS)) - set(WORLD_METRICS)
    assert set(writers) == expected
    assert {k: v for k, v in writers.items() if len(v) > 1} == {}


def test_registry_order_and_lookup():
    assert ("resampling", *(f.name for f in REGISTERED)) == FAMILIES
    assert FAMILIES[1:] == (
        "similarity",
        "motion_prediction",
        "comfort",
        "situation",
        "safety_score",
    )
    engine = MetricEngine(MetricParams(), CHANNELS)
    assert isinstance(engine.family(ComfortFamily), ComfortFamily)
    # a family reading another's state finds it already stepped: comfort before situation
    names = [f.name for f in engine.families]
    assert names.index("comfort") < names.index("situation")
    assert names.index("similarity") < names.index("motion_prediction")


def test_coverage_learnt_after_construction_reaches_every_family():
    """A run learns the channels' coverage from the stream header after building the engine
    (evaluator.session): the families must judge with it, not with the all-round default."""
    engine = MetricEngine(MetricParams(), CHANNELS)
    narrow = {"lav": Coverage(fov_deg=90.0, range_m=60.0), "tfuse": Coverage()}
    engine.coverage = narrow
    assert all(f.coverage is narrow for f in engine.families)
    frame = reference_load_frames(1)[0]
    learnt = engine.step(frame)
    fresh = MetricEngine(MetricParams(), CHANNELS, coverage=narrow)
    assert fresh.step(frame) == learnt  # the same values as an engine built with it
    wide = MetricEngine(MetricParams(), CHANNELS).step(frame)
    assert wide != learnt  # and coverage does matter on this frame
