"""Cross-channel similarity (spi-reference "Similarity"): els, els_var, eos, ocs, ols, oos, oas,
ots, ets, lone_age, plan_lat per channel pair, from one object pairing per pair and tick.

crpps needs a Fréchet distance: this family leaves its inputs in `crpps_inputs`, and the motion
family computes them in one GEOS call with chpps's.
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
    ego_similarities,
    ets,
    plan_lateral,
)
from casewatch.safety_case.signals import PAIR_METRICS, WORST_IS_MAX, pair_name


class SimilarityFamily(MetricFamily):
    name = "similarity"

    def __init__(self, engine: Engine):
        super().__init__(engine)
        p = self.params
        self._els = {pr: TimedHistory(p.els_window, p.max_gap) for pr in self.pairs}
        #: per pair, the ages of each side's unpaired objects (spi-reference "Unpaired objects")
        self._lone = {
            pr: (LoneAges(p.pairing_gate, p.max_gap), LoneAges(p.pairing_gate, p.max_gap))
            for pr in self.pairs
        }
        #: crpps Fréchet inputs per pair of the current step (None: no value)
        self.crpps_inputs: list[tuple[np.ndarray, np.ndarray] | None] = []
        self._pair_names = {pr: {m: pair_name(m, *pr) for m in PAIR_METRICS} for pr in self.pairs}

    def step(self, t: float, st: dict[str, ChannelState], out: dict[str, float | None]) -> None:
        p = self.params
        # crpps needs a Fréchet distance: its inputs wait for the motion family's GEOS call
        self.crpps_inputs = []
        per_pair: dict[str, list[float | None]] = {m: [] for m in PAIR_METRICS if m != "crpps"}
        for a, b in self.pairs:
            sa, sb = st.get(a), st.get(b)
            vals: dict[str, float | None] = dict.fromkeys(PAIR_METRICS)
            window = self._els[(a, b)]
            if sa is not None and sb is not None:
                vals.update(ego_similarities(sa, sb))
                # spi-reference "Channel coverage": only objects both channels can see
                oa, core_a, ob, core_b = common_view(
                    sa.objects,
                    sa.ego,
                    self.coverage[a],
                    sb.objects,
                    sb.ego,
                    self.coverage[b],
                    p.coverage_margin,
                )
                ranges: tuple[np.ndarray | None, np.ndarray | None] = (None, None)
                if p.ols_range_scale > 0.0:
                    ranges = (
                        np.hypot(oa.pos[:, 0] - sa.ego.x, oa.pos[:, 1] - sa.ego.y),
                        np.hypot(ob.pos[:, 0] - sb.ego.x, ob.pos[:, 1] - sb.ego.y),
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
                vals.update(
                    cmp.scores(
                        benefit_of_doubt(age_a, p.lone_horizon),
                        benefit_of_doubt(age_b, p.lone_horizon),
                    )
                )
                vals["lone_age"] = max(age_a.max(initial=0.0), age_b.max(initial=0.0))
                shift = (sa.ego.x - sb.ego.x, sa.ego.y - sb.ego.y)
                vals["ets"] = ets(
                    sa.plan, sb.plan, p.trajectory_decay, shift if p.ets_relative == 1 else None
                )
                vals["plan_lat"] = plan_lateral(
                    sa.plan,
                    sb.plan,
                    shift,
                    (sa.ego.yaw, sb.ego.yaw),
                    p.plan_lat_horizon,
                )
                self.crpps_inputs.append(crpps_inputs(sa.plan, sb.plan))
                window.push(t, vals["els"])
                vals["els_var"] = els_var([v for _, v in window.items], p.els_window)
            else:
                self.crpps_inputs.append(None)
                for side in self._lone[(a, b)]:
                    side.reset()
            del vals["crpps"]
            names = self._pair_names[(a, b)]
            for m, v in vals.items():
                out[names[m]] = v
                per_pair[m].append(v)
        for m, values in per_pair.items():
            out[m] = worst(values, m in WORST_IS_MAX)
