"""Cross-channel similarity (spi-reference "Similarity"): els, els_var, eos, ocs, ols, oos, oas,
ots, ets, lone_age, plan_lat per channel pair, from one object pairing per pair and tick.

crpps needs a Fréchet distance: this family leaves its inputs in `crpps_inputs`, and the motion
family computes them in one compiled call with chpps's (`monitor.frechet`).

A pair's tick is one compiled call (`similarity.PairTracker`: coverage, pairing, lone ages,
scores, ets, plan_lat and the ELS window, its history kept in arrays) whose values the loop
writes into the output dict by precomputed names (issue 36: at a handful of objects per
channel, the glue around a dozen small kernel calls per pair was most of the family's time).
"""

from __future__ import annotations

import numpy as np

from casewatch.monitor.coverage import pair_views
from casewatch.monitor.family import Engine, MetricFamily, worst
from casewatch.monitor.frames import ChannelState, Coverage
from casewatch.monitor.similarity import TICK_OUTPUTS, PairTracker, crpps_inputs
from casewatch.safety_case.signals import PAIR_METRICS, WORST_IS_MAX, pair_name

#: The pair metrics this family writes, in the order `PairTracker.step` returns them (crpps is the
#: motion family's).
METRICS = (
    "els",
    "eos",
    "ego_dist",
    "ego_yaw_diff",
    "ocs",
    "ols",
    "oos",
    "oas",
    "ots",
    "lone_age",
    "ets",
    "plan_lat",
    "els_var",
)
_NONE: list[float | None] = [None] * len(METRICS)


class SimilarityFamily(MetricFamily):
    name = "similarity"

    def __init__(self, engine: Engine):
        super().__init__(engine)
        p = self.params
        if set(METRICS) != set(PAIR_METRICS) - {"crpps"} or len(METRICS) != TICK_OUTPUTS:
            raise AssertionError("SimilarityFamily.METRICS out of step with PAIR_METRICS")
        #: per pair, its history (ELS window, unpaired objects) and its tick's kernel
        self._trackers = [PairTracker(p) for _ in self.pairs]
        #: per pair, the coverages its tracker's views were built from
        self._seen: list[tuple[Coverage | None, Coverage | None]] = [(None, None)] * len(self.pairs)
        #: crpps Fréchet inputs per pair of the current step (None: no value)
        self.crpps_inputs: list[tuple[np.ndarray, np.ndarray] | None] = []
        self._names = [tuple(pair_name(m, *pr) for m in METRICS) for pr in self.pairs]
        self._use_max = tuple(m in WORST_IS_MAX for m in METRICS)
        #: one pair (two channels): the worst pair is that pair, both written by one update
        self._one = self._names[0] + METRICS if len(self.pairs) == 1 else None

    def step(self, t: float, st: dict[str, ChannelState], out: dict[str, float | None]) -> None:
        # crpps needs a Fréchet distance: its inputs wait for the motion family's call
        if self._one is not None:  # two channels: one pair, and the worst pair is that pair
            a, b = self.pairs[0]
            vals, crpps = self._pair(0, t, st.get(a), st.get(b))
            self.crpps_inputs = [crpps]
            out.update(zip(self._one, vals + vals, strict=True))
            return
        self.crpps_inputs = []
        rows = []
        for k, (a, b) in enumerate(self.pairs):
            vals, crpps = self._pair(k, t, st.get(a), st.get(b))
            self.crpps_inputs.append(crpps)
            out.update(zip(self._names[k], vals, strict=True))
            rows.append(vals)
        for k, (m, use_max) in enumerate(zip(METRICS, self._use_max, strict=True)):
            out[m] = worst([vals[k] for vals in rows], use_max)

    def _pair(
        self, k: int, t: float, sa: ChannelState | None, sb: ChannelState | None
    ) -> tuple[list[float | None], tuple[np.ndarray, np.ndarray] | None]:
        """The k-th pair's values (METRICS order) and crpps inputs at t (None: no value)."""
        tracker = self._trackers[k]
        if sa is None or sb is None:
            tracker.forget_objects()
            return _NONE, None
        pair = self.pairs[k]
        cov_a, cov_b = self.engine.coverage[pair[0]], self.engine.coverage[pair[1]]
        seen = self._seen[k]
        if cov_a is not seen[0] or cov_b is not seen[1]:
            # spi-reference "Channel coverage": what each channel can see (the engine learns it
            # from the stream's header after the families are built)
            tracker.views = pair_views(cov_a, cov_b, self.params.coverage_margin)
            self._seen[k] = (cov_a, cov_b)
        return tracker.step(t, sa, sb), crpps_inputs(sa.plan, sb.plan)
