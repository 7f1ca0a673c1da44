"""How long each unpaired object has gone without a partner in the other channel.

A tracking stack drops a confirmed track for a few ticks and reports a ghost for a fraction of
a second: an object seen by one channel only is normal for a moment and a fault when it
lasts. The object SPIs therefore read an unpaired object's *age* (spi-reference "Unpaired
objects"), which this module keeps per channel pair and side.

Ages follow the objects by position, not by id: a previous unpaired object, moved on by its
own velocity over the elapsed time, continues as the nearest current unpaired object within
the pairing gate (greedy global matching, as the pairing itself). Track ids are not used, so an
id switch is neither a new disagreement nor a reset of an old one. An object that is paired
again, leaves the compared region or is not found again starts afresh; so does every object
after a gap in its reports longer than `max_gap` (a missed detection shorter than that is
bridged: `LoneAges`).
"""

from __future__ import annotations

import numpy as np

from casewatch.monitor.similarity import follow_lone


class LoneAges:
    """The ages (s) of one side's unpaired objects, carried from tick to tick.

    An unpaired object that is not reported at all for a moment (the one channel that sees it
    misses it for a few ticks) is remembered, moved on by its velocity, for up to `max_gap`
    seconds: found unpaired again within that time, it keeps its age. Without this, every
    missed detection of the channel that does see the car restarted the age of a car the
    other channel had lost."""

    def __init__(self, gate: float, max_gap: float):
        self.gate = gate
        self.max_gap = max_gap
        self.reset()

    def reset(self) -> None:
        """Forget every object (a channel absent, a gap)."""
        self.pos = np.zeros((0, 2))
        self.vel = np.zeros((0, 2))
        self.age = np.zeros(0)
        self.seen = np.zeros(0)  # time each remembered object was last reported unpaired

    def update(self, t: float, pos: np.ndarray, vel: np.ndarray, lone: np.ndarray) -> np.ndarray:
        """The ages at `t` of the unpaired objects among this side's compared objects
        (`pos`, `vel` rows; `lone` flags the unpaired ones), in index order: 0 for an object
        first seen unpaired now, else the time since it was first seen unpaired. Remembered
        objects are followed onto every current object: onto an unpaired one they pass on
        their age, onto a paired one they end."""
        if not isinstance(lone, np.ndarray) or lone.dtype != np.bool_:
            lone = np.asarray(lone, dtype=bool)
        if not len(self.pos) and not np.count_nonzero(lone):
            # the common tick: nothing unpaired now and nothing remembered, so nothing to
            # follow and the (empty) memory stays as it is; the general path below would
            # return the same empty ages through a dozen array calls (issue 36)
            return np.zeros(0)
        pos = np.ascontiguousarray(pos, dtype=float).reshape(-1, 2)
        vel = np.ascontiguousarray(vel, dtype=float).reshape(-1, 2)
        # one compiled pass (similarity._follow_lone, beside the pairing kernel it calls)
        self.pos, self.vel, self.age, self.seen, ages = follow_lone(
            t, pos, vel, lone, (self.pos, self.vel, self.age, self.seen), self.gate, self.max_gap
        )
        return ages


def benefit_of_doubt(age: np.ndarray, horizon: float) -> np.ndarray:
    """Each unpaired object's share of the benefit of the doubt in the object similarities
    (`ObjectComparison.scores`): 1 when first seen unpaired, falling linearly to 0 at
    `horizon` seconds (spi-reference "Unpaired objects")."""
    if not len(age):
        return np.zeros(0)  # most ticks: nothing unpaired (np.clip of nothing, without its cost)
    return np.clip(1.0 - age / horizon, 0.0, 1.0)
