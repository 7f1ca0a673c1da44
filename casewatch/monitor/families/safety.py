"""The safety score (spi-reference "Safety score"): each channel's plan against each channel's
world model, ss per ordered pair, per channel and worst; and the arbitration it recommends.

Why one compiled call per tick: with two channels and a handful of objects the arithmetic is a
few microseconds, and the Python glue around it (a dict per matrix, lists for the worst values,
one packed scene per scoring group) cost three times that. Each present channel is copied once
into a preallocated scene (`safety_kernel.Scene`), then `safety_kernel._tick` scores every
ordered pair, the worst values and the arbitration into one array, which reaches the tick's
dict by a precomputed name list. A tick the kernel does not take (a polygon footprint, a plan
cut that is not a prefix, a NaN best score) runs the Python composition instead:
`safety_matrix`, `worst`, `arbitrate`, which the tests hold the kernel to.
"""

from __future__ import annotations

from typing import cast

from casewatch.monitor.family import Engine, MetricFamily, worst
from casewatch.monitor.frames import ChannelState
from casewatch.monitor.safety_kernel import PYTHON_PATH, Scene, _load, _tick
from casewatch.monitor.safety_score import arbitrate, safety_matrix
from casewatch.safety_case.signals import SAFETY_SCORE, channel_name, pair_name


class SafetyFamily(MetricFamily):
    name = "safety_score"

    def __init__(self, engine: Engine):
        super().__init__(engine)
        channels = self.channels
        #: the outputs in `_tick`'s order: ss_ij row-major, ss_i, ss
        self._names = (
            *(pair_name(SAFETY_SCORE, i, j) for i in channels for j in channels),
            *(channel_name(SAFETY_SCORE, c) for c in channels),
            SAFETY_SCORE,
        )
        self._index = {c: q for q, c in enumerate(channels)}
        #: the arbitration by `_tick`'s code // 2: None, then the channels
        self._choices: tuple[str | None, ...] = (None, *channels)
        self._scene = Scene(len(channels))

    def step(self, t: float, states: dict[str, ChannelState], out: dict[str, float | None]) -> None:
        scene = self._scene
        data, meta, egos = scene.data, scene.meta, scene.egos
        engine = self.engine
        code = PYTHON_PATH
        for c, name in enumerate(self.channels):
            state = states.get(name)
            if state is None:
                continue
            ego = state.ego
            half = ego.half
            if half is None:  # a polygon ego: the Python path
                meta[:, 0] = 0
                break
            o = state.objects
            plan = state.plan
            # `Scene.load` inlined: this loop runs for every channel of every tick
            if _load(
                data, meta, egos, c, plan, ego.yaw, *half, o.pos, o.yaw, o.half, o.pred_len, o.pred
            ):
                scene.load(c, plan, ego.yaw, half, o)  # grows the scene, then loads
                data = scene.data
        else:
            params = self.params
            code = _tick(
                data,
                meta,
                egos,
                params.pet_ref,
                params.plan_standstill > 0,
                self._index.get(engine.last_arbitration, -1),  # type: ignore[arg-type]
                scene.vals,
                scene.nones,
            )
        if code == PYTHON_PATH:
            self._step_python(states, out)
            return
        values = cast("list[float | None]", scene.vals.tolist())
        if code & 1:
            for q, none in enumerate(scene.nones.tolist()):
                if none:
                    values[q] = None
        out.update(zip(self._names, values, strict=True))
        engine.last_arbitration = self._choices[code >> 1]

    def _step_python(self, states: dict[str, ChannelState], out: dict[str, float | None]) -> None:
        """The tick by `safety_matrix`, `worst` and `arbitrate` (ticks the kernel leaves)."""
        channels = self.channels
        matrix = safety_matrix(
            channels, states, self.params.pet_ref, self.params.plan_standstill > 0
        )
        for (i, j), v in matrix.items():
            out[pair_name(SAFETY_SCORE, i, j)] = v
        for i in channels:
            out[channel_name(SAFETY_SCORE, i)] = worst([matrix[(i, j)] for j in channels], False)
        out[SAFETY_SCORE] = worst(list(matrix.values()), False)
        engine = self.engine
        engine.last_arbitration = arbitrate(channels, matrix, engine.last_arbitration)
