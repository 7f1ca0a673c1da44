"""Plans and predictions over time (spi-reference "Motion and plans"): chpps (a channel's plan
against its own earlier plans), ompv (objects against their earlier predictions), and crpps /
crpps_mean, whose Fréchet distances are computed with chpps's.

A tick is four compiled calls whatever the number of channels and stored plans: ompv of every
channel (`prediction.ompv_tick`, the objects' history in `history.ObjectHistory`), the plans
pushed and every Fréchet pair of the tick cut (`history._tick_cut`, the plans in
`history.PlanHistory`), their distances (`frechet.pair_distances_into`) and the scores
(`history._finish`), written into one array and copied into the tick's dict by a
precomputed name list (`family.KernelOutputs`). The per-channel formulation this replaced
(`prediction.ompv`, `history.chpps_frame`) stays the reference the tests hold it to.
"""

from __future__ import annotations

import numpy as np
from numba.core.errors import TypingError

from casewatch.monitor.families.similarity import SimilarityFamily
from casewatch.monitor.family import Engine, KernelOutputs, MetricFamily
from casewatch.monitor.frames import ChannelState
from casewatch.monitor.frechet import pair_distances_into
from casewatch.monitor.history import (
    ObjectHistory,
    PlanHistory,
    _finish,
    _tick_cut,
    decay_weights,
    tick_rows,
)
from casewatch.monitor.prediction import ompv_tick
from casewatch.safety_case.signals import channel_name, pair_name

_NO_PLAN = np.zeros((0, 3))
_NO_XY = np.zeros((0, 2))
_NO_PRED = np.zeros((0, 0, 3))
_NO_INT = np.zeros(0, dtype=np.int64)
#: a channel absent from the tick, as `ompv_tick` reads the channels' objects
_ABSENT = (False, _NO_XY, _NO_PRED, _NO_INT, _NO_INT)
#: a pair without crpps inputs
_NO_PAIR = (False, _NO_XY, _NO_XY)


def _c64(a: np.ndarray) -> np.ndarray:
    """`a` as the readers give arrays: C-contiguous, writeable, float64 (int64 for ints)."""
    dtype = np.int64 if a.dtype.kind in "iub" else np.float64
    return np.require(a, dtype, ["C", "W"])


def _uniform(entry: tuple) -> tuple:
    """A channel's or pair's kernel entry with every array as `_c64` makes it."""
    return tuple(_c64(x) if isinstance(x, np.ndarray) else x for x in entry)


class MotionPredictionFamily(MetricFamily):
    name = "motion_prediction"

    def __init__(self, engine: Engine):
        super().__init__(engine)
        p = self.params
        n_ch = len(self.channels)
        self._plans = PlanHistory(n_ch, p.plan_history, p.max_gap)
        # ompv compares with the objects of `ompv_lookback` seconds ago: the history is pruned
        # by time in the tick, whatever the frame rate
        self._objects = ObjectHistory(n_ch)
        self._rows = tick_rows(n_ch, len(self.pairs))
        names = [
            *(channel_name("chpps", c) for c in self.channels),
            *(channel_name("ompv", c) for c in self.channels),
            *(pair_name("crpps", *pr) for pr in self.pairs),
            "chpps",
            "ompv",
            "crpps",
            "crpps_mean",
        ]
        self._out = KernelOutputs(names)
        self._has = np.zeros(len(names), dtype=np.bool_)
        self._fd = np.zeros(self._plans.table.shape[0])
        #: each pair's Fréchet distance of the tick (`_finish`), for crpps_mean
        self._pair_fd = np.zeros(max(len(self.pairs), 1))
        self._ompv_params = (
            p.ompv_lookback - 1e-9,
            float(p.max_gap),
            float(p.prediction_tolerance),
            float(p.pairing_gate),
            float(p.standing_motion),
        )
        self._weights = decay_weights(float(p.trajectory_decay), p.plan_history + 1)
        #: each channel's ids of its last tick and their numbers: most ticks see the same
        #: objects in the same order, and then need no lookup
        self._last_ids: list[list[str] | None] = [None] * n_ch
        self._last_codes = [_NO_INT] * n_ch
        self._similarity: SimilarityFamily | None = None
        #: the frames' arrays made C-contiguous, writeable float64 / int64 before the kernels
        #: see them: set once a kernel refused another kind (their tuples must be of one type)
        self._uniform = False

    def step(self, t: float, states: dict[str, ChannelState], out: dict[str, float | None]) -> None:
        """The tick in four compiled calls (the module docstring)."""
        objects = self._objects
        if objects.id_count > objects.ID_LIMIT:
            objects.forget_unused()
            self._last_ids = [None] * len(self.channels)
        last_ids = self._last_ids
        last_codes = self._last_codes
        plans_now = []
        seen = []
        for i, c in enumerate(self.channels):
            s = states.get(c)
            if s is None:
                plans_now.append(_NO_PLAN)
                seen.append(_ABSENT)
                continue
            o = s.objects
            ids = o.ids
            if ids == last_ids[i]:
                codes = last_codes[i]
            else:
                codes = objects.codes_of(ids) if ids else _NO_INT
                last_ids[i] = ids
                last_codes[i] = codes
            plans_now.append(s.plan)
            seen.append((True, o.pos, o.pred, o.pred_len, codes))
        vals = self._out.vals
        has = self._has
        row = self._rows["ompv"]
        if self._uniform:
            seen = [_uniform(x) for x in seen]
        try:
            ompv_tick(objects, t, tuple(seen), self._ompv_params, vals, has, row)
        except TypingError:
            if self._uniform:
                raise
            self._uniform = True  # refused before it ran: nothing changed
            seen = [_uniform(x) for x in seen]
            ompv_tick(objects, t, tuple(seen), self._ompv_params, vals, has, row)
        # crpps: the Fréchet inputs the similarity family left, one per pair (None: no value)
        similarity = self._similarity
        if similarity is None:
            similarity = self._similarity = self.engine.family(SimilarityFamily)
        inputs = similarity.crpps_inputs
        given = [_NO_PAIR if x is None else (True, x[0], x[1]) for x in inputs]
        n_given = len(given)
        if self._uniform:
            plans_now = [_c64(x) for x in plans_now]
            given = [_uniform(x) for x in given]
        try:
            k, n_geos = self._cut(t, tuple(plans_now), tuple(given or [_NO_PAIR]), n_given)
        except TypingError:
            if self._uniform:
                raise
            self._uniform = True  # refused before it ran: nothing changed
            plans_now = [_c64(x) for x in plans_now]
            given = [_uniform(x) for x in given]
            k, n_geos = self._cut(t, tuple(plans_now), tuple(given or [_NO_PAIR]), n_given)
        plans = self._plans
        if n_geos:
            pair_distances_into(plans.coords, plans.starts, n_geos, self._fd)
        mask, count, mean_left = _finish(
            self._fd,
            plans.table,
            k,
            len(self.channels),
            len(self.pairs),
            vals,
            has,
            self._out.nones,
            self._pair_fd,
        )
        self._out.write(out, mask, count)
        if mean_left:
            self._mean(out)

    def _cut(self, t: float, plans_now: tuple, given: tuple, n_given: int) -> tuple[int, int]:
        """`_tick_cut` of the tick, its buffers grown when it asks: (pairs, Fréchet pairs)."""
        plans = self._plans
        push = True
        while True:
            status, k, n_geos, need = _tick_cut(
                t,
                plans_now,
                given,
                n_given,
                plans.plans,
                plans.segs,
                plans.lens,
                plans.times,
                plans.count,
                plans.head,
                plans.max_gap,
                self._weights,
                plans.coords,
                plans.starts,
                plans.table,
                push,
            )
            if status == 0:
                return k, n_geos
            if status == 1:
                plans.widen(max(need, 2 * plans.plans.shape[2]))
            else:
                push = False  # the plans are in: only the work space was short
                plans.coords = np.zeros((max(need, 2 * len(plans.coords)), 2))

    def _mean(self, out: dict[str, float | None]) -> None:
        """crpps_mean = inv(mean fd) over three pairs or more, with np.mean's pairwise sum."""
        distances = self._pair_fd[: len(self.pairs)].tolist()
        mean = float(np.add.reduce(np.array(distances)) / len(distances))
        out["crpps_mean"] = 1.0 / (1.0 + mean)
