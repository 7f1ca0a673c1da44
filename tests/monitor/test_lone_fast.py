"""LoneAges with its empty-tick shortcut against the general update on random sequences in
which most ticks have nothing unpaired (issue 36): the same ages, bit for bit, every tick."""

from __future__ import annotations

import numpy as np
import pytest

from casewatch.monitor.lone import LoneAges
from casewatch.monitor.similarity import pair_objects


class GeneralAges:
    """LoneAges.update as it was before the shortcut: every tick through the array path."""

    def __init__(self, gate: float, max_gap: float):
        self.gate, self.max_gap = gate, max_gap
        self.pos = np.zeros((0, 2))
        self.vel = np.zeros((0, 2))
        self.age = np.zeros(0)
        self.seen = np.zeros(0)

    def update(self, t, pos, vel, lone):
        pos = np.array(pos, dtype=float).reshape(-1, 2)
        vel = np.array(vel, dtype=float).reshape(-1, 2)
        lone = np.asarray(lone, dtype=bool)
        age = np.zeros(len(pos))
        keep = np.zeros(len(self.pos), dtype=bool)
        if len(self.pos):
            recent = t - self.seen <= self.max_gap + 1e-9
            found = np.zeros(len(self.pos), dtype=bool)
            if len(pos) and recent.any():
                idx = np.flatnonzero(recent)
                moved = self.pos[idx] + self.vel[idx] * (t - self.seen[idx])[:, None]
                prev, cur, _ = pair_objects(np.ascontiguousarray(moved), pos, self.gate)
                found[idx[prev]] = True
                cont = lone[cur]
                age[cur[cont]] = self.age[idx[prev[cont]]] + (t - self.seen[idx[prev[cont]]])
            keep = recent & ~found & (t - self.seen < self.max_gap - 1e-9)
        self.pos = np.concatenate([pos[lone], self.pos[keep]])
        self.vel = np.concatenate([vel[lone], self.vel[keep]])
        self.age = np.concatenate([age[lone], self.age[keep]])
        self.seen = np.concatenate([np.full(int(lone.sum()), t), self.seen[keep]])
        return age[lone]


@pytest.mark.parametrize("seed", range(30))
def test_shortcut_gives_the_general_ages(seed):
    rng = np.random.default_rng(seed)
    fast, general = LoneAges(3.0, 0.5), GeneralAges(3.0, 0.5)
    t = 0.0
    empty_ticks = 0
    for _ in range(200):
        t = round(t + float(rng.choice([0.1, 0.1, 0.1, 0.3, 0.7])), 6)
        k = int(rng.integers(0, 5))
        pos = rng.uniform(-20, 20, (k, 2))
        vel = rng.normal(0, 3, (k, 2))
        lone = rng.random(k) < (0.05 if seed % 2 else 0.3)
        if not lone.any() and not len(fast.pos):
            empty_ticks += 1
        got, want = fast.update(t, pos, vel, lone), general.update(t, pos, vel, lone)
        assert got.tolist() == want.tolist()
        assert got.dtype == want.dtype and got.shape == want.shape
        for name in ("pos", "vel", "age", "seen"):
            assert getattr(fast, name).tolist() == getattr(general, name).tolist(), name
    assert empty_ticks > 10  # the shortcut was taken


def test_benefit_of_doubt_of_nothing_is_an_empty_float_array():
    from casewatch.monitor.lone import benefit_of_doubt

    out = benefit_of_doubt(np.zeros(0), 2.0)
    want = np.clip(1.0 - np.zeros(0) / 2.0, 0.0, 1.0)
    assert (out.dtype, out.shape) == (want.dtype, want.shape)
    assert benefit_of_doubt(np.array([0.0, 1.0, 3.0]), 2.0).tolist() == [1.0, 0.5, 0.0]


@pytest.mark.parametrize("seed", range(20))
def test_compiled_update_follows_moving_objects_like_the_general_one(seed):
    """The general case compiled (similarity._follow_lone): objects that keep moving by their
    velocity, drop out for a tick or two and come back, paired or not, with ties at the
    gate, give the general update's ages and memory, bit for bit (issue 36)."""
    rng = np.random.default_rng(100 + seed)
    fast, general = LoneAges(3.0, 0.5), GeneralAges(3.0, 0.5)
    k = int(rng.integers(1, 9))
    pos = rng.uniform(-30, 30, (k, 2))
    vel = rng.normal(0, 5, (k, 2))
    t = 0.0
    for _ in range(150):
        step = float(rng.choice([0.1, 0.1, 0.2, 0.6]))
        t = round(t + step, 6)
        pos = pos + vel * step + rng.normal(0, 0.3, (k, 2))
        shown = rng.random(k) < 0.8
        lone = rng.random(int(shown.sum())) < 0.5
        got = fast.update(t, pos[shown], vel[shown], lone)
        want = general.update(t, pos[shown], vel[shown], lone)
        assert got.tolist() == want.tolist()
        assert got.dtype == want.dtype and got.shape == want.shape
        for name in ("pos", "vel", "age", "seen"):
            assert getattr(fast, name).tolist() == getattr(general, name).tolist(), name
