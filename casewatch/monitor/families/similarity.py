"""Cross-channel similarity (spi-reference "Similarity"): els, els_var, eos, ocs, ols, oos, oas,
ots, ets, lone_age, plan_lat per channel pair, from one object pairing per pair and tick.

crpps needs a Fréchet distance: this family leaves its inputs in `crpps_inputs`, and the motion
family computes them in one GEOS call with chpps's.

The tick's loop writes straight into the output dict by precomputed names and builds no
dict per pair (issue 36: at a handful of objects per channel, the glue around the compiled
kernels was most of the family's time).
"""

from __future__ import annotations

import numpy as np

from casewatch.monitor.coverage import common_view
from casewatch.monitor.family import Engine, MetricFamily, TimedHistory, worst
from casewatch.monitor.frames import ChannelState
from casewatch.monitor.history import els_var
from casewatch.monitor.lone import LoneAges, benefit_of_doubt
from casewatch.monitor.similarity import (
    compare_objects,
    crpps_inputs,
    ego_pair,
    ets,
    plan_lateral,
    ranges_from,
)
from casewatch.safety_case.signals import PAIR_METRICS, WORST_IS_MAX, pair_name

#: The pair metrics this family writes, in the order `_pair` returns them (crpps is the
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
_NONE = (None,) * len(METRICS)


class SimilarityFamily(MetricFamily):
    name = "similarity"

    def __init__(self, engine: Engine):
        super().__init__(engine)
        p = self.params
        if set(METRICS) != set(PAIR_METRICS) - {"crpps"}:
            raise AssertionError("SimilarityFamily.METRICS out of step with PAIR_METRICS")
        self._els = {pr: TimedHistory(p.els_window, p.max_gap) for pr in self.pairs}
        #: per pair, the ages of each side's unpaired objects (spi-reference "Unpaired objects")
        self._lone = {
            pr: (LoneAges(p.pairing_gate, p.max_gap), LoneAges(p.pairing_gate, p.max_gap))
            for pr in self.pairs
        }
        #: crpps Fréchet inputs per pair of the current step (None: no value)
        self.crpps_inputs: list[tuple[np.ndarray, np.ndarray] | None] = []
        self._pair_names = {pr: {m: pair_name(m, *pr) for m in PAIR_METRICS} for pr in self.pairs}
        self._names = [tuple(pair_name(m, *pr) for m in METRICS) for pr in self.pairs]
        self._use_max = tuple(m in WORST_IS_MAX for m in METRICS)

    def step(self, t: float, st: dict[str, ChannelState], out: dict[str, float | None]) -> None:
        # crpps needs a Fréchet distance: its inputs wait for the motion family's GEOS call
        self.crpps_inputs = []
        rows = []
        for (a, b), names in zip(self.pairs, self._names, strict=True):
            sa, sb = st.get(a), st.get(b)
            if sa is not None and sb is not None:
                vals = self._pair(t, a, b, sa, sb)
            else:
                vals = _NONE
                self.crpps_inputs.append(None)
                for side in self._lone[(a, b)]:
                    side.reset()
            for name, v in zip(names, vals, strict=True):
                out[name] = v
            rows.append(vals)
        if len(rows) == 1:  # one pair (two channels): the worst pair is that pair
            for m, v in zip(METRICS, rows[0], strict=True):
                out[m] = v
            return
        for k, (m, use_max) in enumerate(zip(METRICS, self._use_max, strict=True)):
            out[m] = worst([vals[k] for vals in rows], use_max)

    def _pair(
        self, t: float, a: str, b: str, sa: ChannelState, sb: ChannelState
    ) -> tuple[float | None, ...]:
        """The METRICS of the pair (a, b) at t, both channels present."""
        p = self.params
        coverage = self.coverage
        els, eos, ego_dist, ego_yaw_diff = ego_pair(sa, sb)
        # spi-reference "Channel coverage": only objects both channels can see
        oa, core_a, ob, core_b = common_view(
            sa.objects,
            sa.ego,
            coverage[a],
            sb.objects,
            sb.ego,
            coverage[b],
            p.coverage_margin,
        )
        ranges: tuple[np.ndarray | None, np.ndarray | None] = (None, None)
        if p.ols_range_scale > 0.0:
            ranges = (
                ranges_from(oa.pos, sa.ego.x, sa.ego.y),
                ranges_from(ob.pos, sb.ego.x, sb.ego.y),
            )
        cmp = compare_objects(
            oa,
            ob,
            p.pairing_gate,
            p.trajectory_decay,
            core_a,
            core_b,
            p.standing_motion,
            *ranges,
            p.ols_range_scale,
            p.ots_time_scale,
        )
        ages_a, ages_b = self._lone[(a, b)]
        age_a = ages_a.update(t, oa.pos, oa.vel, cmp.lone_a)
        age_b = ages_b.update(t, ob.pos, ob.vel, cmp.lone_b)
        scores = cmp.scores(
            benefit_of_doubt(age_a, p.lone_horizon),
            benefit_of_doubt(age_b, p.lone_horizon),
        )
        lone_age = max(
            age_a.max(initial=0.0) if len(age_a) else 0.0,
            age_b.max(initial=0.0) if len(age_b) else 0.0,
        )
        shift = (sa.ego.x - sb.ego.x, sa.ego.y - sb.ego.y)
        ets_value = ets(
            sa.plan, sb.plan, p.trajectory_decay, shift if p.ets_relative == 1 else None
        )
        plan_lat = plan_lateral(
            sa.plan,
            sb.plan,
            shift,
            (sa.ego.yaw, sb.ego.yaw),
            p.plan_lat_horizon,
        )
        self.crpps_inputs.append(crpps_inputs(sa.plan, sb.plan))
        window = self._els[(a, b)]
        window.push(t, els)
        return (
            els,
            eos,
            ego_dist,
            ego_yaw_diff,
            scores["ocs"],
            scores["ols"],
            scores["oos"],
            scores["oas"],
            scores["ots"],
            lone_age,
            ets_value,
            plan_lat,
            els_var([v for _, v in window.items], p.els_window),
        )
