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
from casewatch.monitor.prediction import _ompv_tick, ompv_tick
from casewatch.safety_case.signals import channel_name, pair_name

_NO_PLAN = np.zeros((0, 3))
_NO_XY = np.zeros((0, 2))
_NO_PRED = np.zeros((0, 0, 3))
_NO_INT = np.zeros(0, dtype=np.int64)
#: a channel absent from the tick, as `ompv_tick` reads the channels' objects
_ABSENT = (False, _NO_XY, _NO_PRED, _NO_INT, _NO_INT, False)
#: a pair without crpps inputs
_NO_PAIR = (False, _NO_XY, _NO_XY)


def _c64(a: np.ndarray) -> np.ndarray:
    """`a` as the readers give arrays: C-contiguous, writeable, float64 (int64 for ints)."""
    dtype = np.int64 if a.dtype.kind in "iub" else np.float64
    return np.require(a, dtype, ["C", "W"])


def _uniform(entries: list) -> list:
    """The kernel entries (arrays, or tuples of a flag and arrays) with every array as `_c64`
    makes it."""
    return [
        _c64(x)
        if isinstance(x, np.ndarray)
        else tuple(_c64(y) if isinstance(y, np.ndarray) else y for y in x)
        for x in entries
    ]


class MotionPredictionFamily(MetricFamily):
    name = "motion_prediction"

    def __init__(self, engine: Engine):
        super().__init__(engine)
        p = self.params
        n_ch = len(self.channels)
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
        #: each channel's ids of its last tick, their numbers and whether none is repeated:
        #: most ticks see the same objects in the same order, and then need no lookup
        self._last_ids: list[list[str] | None] = [None] * n_ch
        self._last_codes = [(_NO_INT, True)] * n_ch
        self._similarity: SimilarityFamily | None = None
        #: the frames' arrays made C-contiguous, writeable float64 / int64 before the kernels
        #: see them: set once a kernel refused another kind (their tuples must be of one type)
        self._uniform = False
        lookback, max_gap, tolerance, _, standing = self._ompv_params
        self._ompv_args = (lookback, max_gap, tolerance, standing)
        self._finish_args = (
            n_ch,
            len(self.pairs),
            self._out.vals,
            self._has,
            self._out.nones,
            self._pair_fd,
        )
        # ompv compares with the objects of `ompv_lookback` seconds ago: the history is pruned
        # by time in the tick, whatever the frame rate
        self.use(PlanHistory(n_ch, p.plan_history, p.max_gap), ObjectHistory(n_ch))

    def use(self, plans: PlanHistory, objects: ObjectHistory) -> None:
        """Keep the plans and the objects in these histories (new ones: the constructor's; a
        test passes small ones, so that every buffer grows)."""
        self._plans = plans
        self._objects = objects
        self._ids = objects.ids
        self._pend = (objects.pending, objects.elapsed)
        self._table = plans.table
        self._fd = np.zeros(plans.table.shape[0])
        self._last_ids = [None] * len(self.channels)
        self._prebuild()

    def step(self, t: float, states: dict[str, ChannelState], out: dict[str, float | None]) -> None:
        """The tick in four compiled calls (the module docstring); every argument that does
        not change from tick to tick is prebuilt (`_cut_args`, `_finish_args`)."""
        objects = self._objects
        if len(self._ids) > objects.ID_LIMIT:
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
                codes, distinct = last_codes[i]
            else:
                codes = objects.codes_of(ids) if ids else _NO_INT
                distinct = len(set(ids)) == len(ids)
                last_ids[i] = ids
                last_codes[i] = (codes, distinct)
            plans_now.append(s.plan)
            seen.append((True, o.pos, o.pred, o.pred_len, codes, distinct))
        # crpps: the Fréchet inputs the similarity family left, one per pair (None: no value)
        similarity = self._similarity
        if similarity is None:
            similarity = self._similarity = self.engine.family(SimilarityFamily)
        given = [_NO_PAIR if x is None else (True, x[0], x[1]) for x in similarity.crpps_inputs]
        n_given = len(given)
        if not given:
            given = [_NO_PAIR]
        if self._uniform:
            seen, plans_now, given = _uniform(seen), _uniform(plans_now), _uniform(given)
        vals = self._out.vals
        has = self._has
        row = self._rows["ompv"]
        ticks = tuple(seen)
        try:
            n = _ompv_tick(t, ticks, *objects.state, *self._ompv_args, vals, has, row, *self._pend)
        except TypingError:
            # a frame's arrays of another kind: refused before the kernel ran, nothing changed
            if self._uniform:
                raise
            self._uniform = True
            self.step(t, states, out)
            return
        if n:
            ompv_tick(objects, t, ticks, self._ompv_params, vals, has, row, n)
        plans_t = tuple(plans_now)
        given_t = tuple(given)
        try:
            status, k, n_geos, need = _tick_cut(t, plans_t, given_t, n_given, *self._cut_args, True)
        except TypingError:
            if self._uniform:
                raise
            self._uniform = True  # refused before it ran: the plans are not pushed yet
            plans_t = tuple(_uniform(plans_now))
            given_t = tuple(_uniform(given))
            status, k, n_geos, need = _tick_cut(t, plans_t, given_t, n_given, *self._cut_args, True)
        if status:
            k, n_geos = self._cut_again(t, plans_t, given_t, n_given, status, need)
        if n_geos:
            pair_distances_into(self._plans.coords, self._plans.starts, n_geos, self._fd)
        mask, count, mean_left = _finish(self._fd, self._table, k, *self._finish_args)
        self._out.write(out, mask, count)
        if mean_left:
            self._mean(out)

    def _prebuild(self) -> None:
        """The kernels' arguments that change only when a buffer grows."""
        plans = self._plans
        self._cut_args = (
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
        )

    def _cut_again(
        self, t: float, plans_now: tuple, given: tuple, n_given: int, status: int, need: int
    ) -> tuple[int, int]:
        """`_tick_cut` after it asked for room (status 1: wider plans, nothing pushed; 2: more
        work space, the plans pushed), until it has it: (pairs, Fréchet pairs)."""
        plans = self._plans
        push = True
        while status:
            if status == 1:
                plans.widen(max(need, 2 * plans.plans.shape[2]))
            else:
                push = False  # the plans are in: only the work space was short
                plans.coords = np.zeros((max(need, 2 * len(plans.coords)), 2))
            self._prebuild()
            status, k, n_geos, need = _tick_cut(t, plans_now, given, n_given, *self._cut_args, push)
        return k, n_geos

    def _mean(self, out: dict[str, float | None]) -> None:
        """crpps_mean = inv(mean fd) over three pairs or more, with np.mean's pairwise sum."""
        distances = self._pair_fd[: len(self.pairs)].tolist()
        mean = float(np.add.reduce(np.array(distances)) / len(distances))
        out["crpps_mean"] = 1.0 / (1.0 + mean)
