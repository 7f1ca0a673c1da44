"""The one-call-per-tick comfort, situation and resampling glue (issue 36) against the code it
replaced, value for value (bits, None and -0.0 included): the old families are kept here as
the reference (`OldComfort`, `OldSituation`, commit 985ff6a), stepped in an engine beside the
new one over random drives (channels dropping out, time gaps, forward cameras, polygon
footprints, plans on and off the grid)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numba import njit

from casewatch.monitor import engine as engine_module
from casewatch.monitor.comfort import _push_row, hcs, ppcs
from casewatch.monitor.engine import MetricEngine
from casewatch.monitor.families.comfort import ComfortFamily
from casewatch.monitor.families.situation import SituationFamily
from casewatch.monitor.family import (
    Engine,
    KernelOutputs,
    MetricFamily,
    PoseWindows,
    worst,
)
from casewatch.monitor.frames import ChannelState, Coverage
from casewatch.monitor.resample import (
    _scale_of,
    _smooth_plan,
    objects_on_grid,
    prepare_channel,
    prepare_plan,
    resample_objects,
)
from casewatch.monitor.situation import (
    EPS,
    GAP_CAP,
    PATH_SPACING,
    PATH_TOLERANCE,
    TICK_METRICS,
    TIME_CAP,
    _nearest,
    _path,
    _shares_lane,
    acceleration,
    ego_half_length,
    headway,
    neighbours,
    push_row,
    time_to_collision,
)
from casewatch.safety_case.model import MetricParams
from casewatch.safety_case.signals import (
    SITUATION_METRICS,
    WORST_IS_MAX,
    channel_name,
)
from tests.monitor.builders import channel, ego, frame, obj
from tests.monitor.reference_windows import PoseWindow


class OldComfort(MetricFamily):
    """families/comfort.py at 985ff6a."""

    name = "comfort"

    def __init__(self, engine: Engine):
        super().__init__(engine)
        p = self.params
        self.ego = {c: PoseWindow(p.comfort_span, p.max_gap) for c in self.channels}
        self._channel_names = {
            c: {m: channel_name(m, c) for m in ("hcs", "ppcs")} for c in self.channels
        }
        self._hcs_names = [self._channel_names[c]["hcs"] for c in self.channels]
        self._ppcs_names = [self._channel_names[c]["ppcs"] for c in self.channels]

    def step(self, t, states, out):
        p = self.params
        for c in self.channels:
            s = states.get(c)
            if s is None:
                continue
            window = self.ego[c]
            window.push(t, s.ego.x, s.ego.y)
            rows = window.window()
            names = self._channel_names[c]
            out[names["hcs"]] = hcs(rows[:, 0], rows[:, 1:3], p.comfort_span, p.comfort_steepness)
            out[names["ppcs"]] = ppcs(s.plan, p.comfort_span, p.comfort_steepness)
        out["hcs"] = worst([out[n] for n in self._hcs_names], False)
        out["ppcs"] = worst([out[n] for n in self._ppcs_names], False)


class OldSituation(MetricFamily):
    """families/situation.py at 985ff6a."""

    name = "situation"

    def __init__(self, engine: Engine):
        super().__init__(engine)
        p = self.params
        self._situation_names = {
            c: {m: channel_name(m, c) for m in SITUATION_METRICS} for c in self.channels
        }
        self._worst_of = [
            (
                metric,
                [self._situation_names[c][metric] for c in self.channels],
                metric in WORST_IS_MAX,
                metric.startswith("follow_"),
            )
            for metric in SITUATION_METRICS
        ]
        self._speeds = {c: PoseWindow(1.0, p.max_gap) for c in self.channels}

    def step(self, t, states, out):
        p = self.params
        reach = GAP_CAP + 50.0
        behind_seeing = [c for c in self.channels if self.coverage[c].fov_deg >= 360.0]
        driven_paths = self.engine.family(OldComfort).ego
        for c in self.channels:
            s = states.get(c)
            if s is None:
                continue
            e = s.ego
            speed = math.hypot(e.vx, e.vy)
            names = self._situation_names[c]
            driven = driven_paths[c].window()[:-1, 1:3] if c in behind_seeing else None
            lead, follower = neighbours(
                e, s.plan, driven, s.objects, p.lane_half_width, ego_half_length(e), reach
            )
            out[names["ego_speed"]] = speed
            window = self._speeds[c]
            window.push(t, speed, 0.0)
            rows = window.window()
            out[names["ego_accel"]] = acceleration(rows[:, 0], rows[:, 1])
            out[names["lead_gap"]] = lead.gap
            out[names["lead_speed"]] = lead.speed if lead.present else 0.0
            out[names["lead_thw"]] = headway(lead.gap, speed) if lead.present else TIME_CAP
            out[names["lead_ttc"]] = (
                time_to_collision(lead.gap, speed - lead.speed) if lead.present else TIME_CAP
            )
            if follower is not None:
                towards = max(-follower.speed, 0.0)
                out[names["follow_gap"]] = follower.gap
                out[names["follow_speed"]] = towards
                if follower.present:
                    out[names["follow_thw"]] = headway(follower.gap, towards)
                    out[names["follow_ttc"]] = time_to_collision(follower.gap, towards - speed)
                else:
                    out[names["follow_thw"]] = out[names["follow_ttc"]] = TIME_CAP
        all_seeing = len(behind_seeing) == len(self.channels)
        for metric, seeing, use_max, behind in self._worst_of:
            if behind and not all_seeing:
                seeing = [self._situation_names[c][metric] for c in behind_seeing]
            out[metric] = worst([out[n] for n in seeing], use_max) if seeing else None


def _old_engine(params, channels, coverage, monkeypatch):
    """A MetricEngine whose comfort and situation families are the old ones."""
    old = tuple(
        {ComfortFamily: OldComfort, SituationFamily: OldSituation}.get(f, f)
        for f in engine_module.REGISTERED
    )
    with monkeypatch.context() as m:
        m.setattr(engine_module, "REGISTERED", old)
        return MetricEngine(params, channels, coverage)


def _same(a, b) -> bool:
    """Equal to the bit: None, NaN and the sign of zero included."""
    if a is None or b is None:
        return a is None and b is None
    return type(a) is type(b) and (repr(float(a)) == repr(float(b)))


def _drive(seed: int, channels: list[str], frames: int):
    """Random frames: egos accelerating and turning, plans on the grid or off it (or empty,
    or a single point), objects ahead, behind and crossing (some with polygon footprints,
    some with predictions off the grid), channels dropping out, time gaps beyond max_gap."""
    rng = np.random.default_rng(seed)
    t = 0.0
    speed = rng.uniform(0.0, 20.0, len(channels))
    for _ in range(frames):
        t = round(t + (0.1 if rng.random() > 0.05 else rng.choice([0.3, 0.7, 1.3])), 3)
        chans = {}
        for i, c in enumerate(channels):
            if rng.random() < 0.08:
                continue  # a dropout
            speed[i] = max(0.0, speed[i] + rng.normal(0, 1.5))
            yaw = 0.05 * math.sin(0.3 * t + i) + rng.normal(0, 0.01)
            x = 10.0 * t + rng.normal(0, 0.1)
            y = rng.normal(0, 0.1)
            e = ego(x, y, yaw, 4.5, 1.9, vx=speed[i] * math.cos(yaw), vy=speed[i] * math.sin(yaw))
            kind = rng.integers(0, 5)
            if kind == 0:
                plan = []
            elif kind == 1:
                plan = [[0.0, x, y]]
            else:
                step = 0.1 if kind < 4 else float(rng.choice([0.25, 0.5]))
                n = int(rng.integers(2, 60))
                acc = rng.normal(0, 2)
                plan = [
                    [
                        round(j * step, 6),
                        x + speed[i] * j * step + 0.5 * acc * (j * step) ** 2,
                        y + rng.normal(0, 0.05) + (0.3 * j * step if kind == 3 else 0.0),
                    ]
                    for j in range(n)
                ]
            objects = []
            for o in range(int(rng.integers(0, 6))):
                ox = x + rng.uniform(-40, 60)
                oy = y + rng.choice([0.0, 0.3, -0.5, 3.5, -3.5]) + rng.normal(0, 0.3)
                oyaw = rng.choice([0.0, 0.05, math.pi / 2, math.pi]) + rng.normal(0, 0.02)
                ov = rng.uniform(0, 25)
                extra = {"vx": ov * math.cos(oyaw), "vy": ov * math.sin(oyaw)}
                if rng.random() < 0.6:
                    pstep, first = (
                        (0.1, int(rng.integers(0, 2))) if rng.random() < 0.6 else (0.3, 1)
                    )
                    extra["prediction"] = [
                        [round(j * pstep, 6), ox + ov * j * pstep, oy] for j in range(first, 12)
                    ]
                if rng.random() < 0.15:
                    poly = [[-2.0, -1.0], [2.5, -0.8], [2.0, 1.0], [-2.0, 1.0]]
                    d = {"id": f"{c}{o}", "x": ox, "y": oy, "yaw": oyaw, "polygon": poly}
                    d.update(extra)
                    objects.append(d)
                else:
                    objects.append(obj(f"{c}{o}", ox, oy, oyaw, 4.5, 1.9, **extra))
            chans[c] = channel(e, plan=plan, objects=objects)
        if chans:
            yield frame(t, json.loads(json.dumps(chans)))  # numpy scalars as JSON numbers


COVERAGES = [
    {},
    {"b": Coverage(fov_deg=120.0, range_m=70.0)},
    {"a": Coverage(fov_deg=200.0), "b": Coverage(fov_deg=90.0)},
]


@settings(max_examples=12, deadline=None)
@given(
    seed=st.integers(0, 2**31 - 1),
    n_channels=st.sampled_from([1, 2, 3]),
    coverage=st.sampled_from(COVERAGES),
    smoothing=st.sampled_from([0.0, 2.0]),
)
def test_families_equal_the_old_formulation(seed, n_channels, coverage, smoothing):
    channels = ["a", "b", "c"][:n_channels]
    params = MetricParams(plan_smoothing=smoothing, plan_standstill=1.0)
    mp = pytest.MonkeyPatch()
    try:
        old = _old_engine(params, channels, coverage, mp)
    finally:
        mp.undo()
    new = MetricEngine(params, channels, coverage)
    names = [n for n in new.signal_names if n.split("__")[0] in (*SITUATION_METRICS, "hcs", "ppcs")]
    for f in _drive(seed, channels, 70):
        got = new.step(f)
        want = old.step(f)
        assert list(got) == list(want)
        bad = {n: (got[n], want[n]) for n in names if not _same(got[n], want[n])}
        assert bad == {}, f"t = {f.t}"


@settings(max_examples=60, deadline=None)
@given(
    gaps=st.lists(st.sampled_from([0.001, 0.05, 0.1, 0.1, 0.1, 0.4, 0.6, 2.0]), max_size=300),
    span=st.sampled_from([0.2, 1.0, 3.0]),
    capacity=st.sampled_from([2, 3, 8, 64]),
)
def test_pose_windows_keep_the_rows_of_pose_window(gaps, span, capacity):
    """Both kernel copies of the push, with make_room after each, against PoseWindow."""
    for push in (push_row, _push_row):
        ref = [PoseWindow(span, 0.5, 4), PoseWindow(span, 0.5, 4)]
        got = PoseWindows(2, span, 0.5, capacity)
        t = 0.0
        for k, g in enumerate(gaps):
            t += g
            i = k % 3 % 2  # window 0 gets two pushes of three
            ref[i].push(t, float(k), -float(k))
            rows = push(got.buf, got.start, got.end, i, t, float(k), -float(k), span, 0.5)
            got.make_room(rows)
            for j in (0, 1):
                assert np.array_equal(got.window(j), ref[j].window())


def test_a_full_window_refuses_to_write_past_its_end():
    w = PoseWindows(1, 10.0, 0.5, capacity=2)
    push_row(w.buf, w.start, w.end, 0, 0.0, 0.0, 0.0, 10.0, 0.5)
    push_row(w.buf, w.start, w.end, 0, 0.1, 0.0, 0.0, 10.0, 0.5)  # no make_room: full
    with pytest.raises(IndexError, match="make_room"):
        push_row(w.buf, w.start, w.end, 0, 0.2, 0.0, 0.0, 10.0, 0.5)


def test_kernel_outputs_none_where_listed_and_nan_kept_where_not():
    o = KernelOutputs(["a", "b", "c"])
    o.vals[:] = [1.5, math.nan, math.nan]
    o.nones[:1] = [1]
    out: dict[str, float | None] = {"x": 0.0}
    o.write(out, 0b010, 1)
    assert out["a"] == 1.5 and out["b"] is None and math.isnan(out["c"])  # type: ignore[arg-type]
    assert list(out) == ["x", "a", "b", "c"]
    o.write(out, 0b010, 1)  # the cached pattern
    assert out["b"] is None
    o.vals[:] = [math.nan, 2.0, math.nan]
    o.nones[:2] = [0, 2]
    o.write(out, -1, 2)  # more than 62 rows: the listed rows, not a mask
    assert out == {"x": 0.0, "a": None, "b": 2.0, "c": None}


def test_tick_metrics_are_the_catalogue_in_its_order():
    assert tuple(SITUATION_METRICS) == TICK_METRICS
    assert [m for m in TICK_METRICS if m in WORST_IS_MAX] == ["follow_speed", "ego_speed"]


@settings(max_examples=200, deadline=None)
@given(
    seed=st.integers(0, 2**31 - 1),
    smoothing=st.sampled_from([0.0, 1.0, 2.0]),
    standstill=st.sampled_from([0.0, 1.0]),
    layout=st.sampled_from(["C", "F", "strided"]),
)
def test_prepare_channel_equals_prepare_plan_and_resample_objects(
    seed, smoothing, standstill, layout
):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(0, 40))
    step = float(rng.choice([0.1, 0.2, 0.5]))
    dt = np.round(
        np.cumsum(rng.choice([step, 0.1, 0.05], n)) - (step if rng.random() < 0.5 else 0), 6
    )
    plan = np.column_stack([dt, np.cumsum(rng.normal(1, 0.3, n)), rng.normal(0, 0.05, n)])
    if layout == "F":
        plan = np.asfortranarray(plan)
    elif layout == "strided":
        plan = np.repeat(plan, 2, axis=0)[::2]
    f = next(_drive(seed, ["a"], 1), None)
    if f is None:
        return
    objects = f.channels["a"].objects
    want_plan = prepare_plan(plan, smoothing, 0.1, standstill)
    got_plan, start = prepare_channel(
        np.asarray(plan, dtype=np.float64),
        objects.pred,
        objects.pred_len,
        0.5 * smoothing,
        not smoothing <= 0.0,
        0.1,
        standstill,
    )
    assert got_plan.flags.c_contiguous
    assert (
        got_plan.shape == want_plan.shape
        and got_plan.tobytes() == np.ascontiguousarray(want_plan).tobytes()
    )
    want = resample_objects(objects, 0.1)
    got = objects if start == 1 else objects_on_grid(objects, start, 0.1)
    assert (got is objects) == (want is objects)
    assert got.pred.tobytes() == want.pred.tobytes() and got.pred.shape == want.pred.shape
    assert np.array_equal(got.pred_len, want.pred_len)


def test_engine_states_are_the_old_resampling():
    params = MetricParams(plan_smoothing=2.0, plan_standstill=1.0)
    engine = MetricEngine(params, ["a", "b"])
    for f in _drive(7, ["a", "b"], 40):
        states = engine._resampled(f)
        for c, s in f.channels.items():
            plan = prepare_plan(s.plan, 2.0, params.resample_step, 1.0)
            objects = resample_objects(s.objects, params.resample_step)
            got: ChannelState = states[c]
            assert got.ego is s.ego and got.plan.tobytes() == plan.tobytes()
            assert got.plan.shape == plan.shape and got.plan.dtype == np.float64
            assert got.objects.pred.tobytes() == objects.pred.tobytes()
            assert (got.objects is s.objects) == (objects is s.objects)


def test_signals_pass_through_as_before():
    """The frame's scalar signals: new names added, a builtin name never overwritten, a world
    input filled in only where the frame's `world` did not report it."""
    engine = MetricEngine(MetricParams(), ["a"])
    f = next(_drive(3, ["a"], 1))
    f.signals = {"loc_quality": 0.5, "hcs": 9.0, "speed_limit": 13.0}
    out = engine.step(f)
    assert out["loc_quality"] == 0.5 and out["hcs"] != 9.0 and out["speed_limit"] == 13.0
    f2 = next(_drive(4, ["a"], 1))
    f2.t = f.t + 0.1
    f2.signals = {"other": 1.0}
    out = engine.step(f2)
    assert out["other"] == 1.0 and list(out)[-1] == "other"


# -- the path and the projection, against their code at 985ff6a ---------------------------
# (compiled here as they were: numba's hypot is the C library's, not Python's)


@njit(cache=False, error_model="numpy")
def _old_strays(out, m, x, y):
    """True when (x, y) lies more than PATH_TOLERANCE from the line through the last two kept
    points out[m - 2], out[m - 1] (m >= 2)."""
    px = out[m - 1, 0]
    py = out[m - 1, 1]
    lx = px - out[m - 2, 0]
    ly = py - out[m - 2, 1]
    return abs(lx * (y - py) - ly * (x - px)) / math.hypot(lx, ly) > PATH_TOLERANCE + EPS


@njit(cache=False, error_model="numpy")
def _old_path(x0, y0, xs, ys, reverse, heading, lookahead):
    """(P, 2) polyline from (x0, y0) through the points (xs[i], ys[i]) (in reverse order when
    `reverse`), simplified (see PATH_SPACING, PATH_TOLERANCE; the last point is kept when it
    moves on by more than 1 cm) and extended straight by `lookahead` metres along the last
    segment, or along `heading` when the points do not move."""
    n = xs.shape[0] + 1
    x = np.empty(n)
    y = np.empty(n)
    x[0] = x0
    y[0] = y0
    for i in range(n - 1):
        j = n - 2 - i if reverse else i
        x[i + 1] = xs[j]
        y[i + 1] = ys[j]
    out = np.empty((n + 1, 2))
    out[0, 0] = x[0]
    out[0, 1] = y[0]
    m = 1
    last = 0  # index of the last kept input point
    for i in range(1, n):
        if m == 1:
            if math.hypot(x[i] - out[0, 0], y[i] - out[0, 1]) >= PATH_SPACING - EPS:
                out[1, 0] = x[i]
                out[1, 1] = y[i]
                m = 2
                last = i
            continue
        if _old_strays(out, m, x[i], y[i]) and last < i - 1:
            # point i leaves the line: the point before it ends the straight stretch
            out[m, 0] = x[i - 1]
            out[m, 1] = y[i - 1]
            m += 1
            last = i - 1
        if _old_strays(out, m, x[i], y[i]):
            out[m, 0] = x[i]
            out[m, 1] = y[i]
            m += 1
            last = i
    if last < n - 1 and math.hypot(x[n - 1] - out[m - 1, 0], y[n - 1] - out[m - 1, 1]) > 0.01:
        out[m, 0] = x[n - 1]
        out[m, 1] = y[n - 1]
        m += 1
    if m >= 2:
        dx = out[m - 1, 0] - out[m - 2, 0]
        dy = out[m - 1, 1] - out[m - 2, 1]
        length = math.hypot(dx, dy)
        ux = dx / length
        uy = dy / length
    else:
        ux = math.cos(heading)
        uy = math.sin(heading)
    out[m, 0] = out[m - 1, 0] + lookahead * ux
    out[m, 1] = out[m - 1, 1] + lookahead * uy
    return out[: m + 1]


@njit(cache=False, error_model="numpy")
def _old_nearest(
    path, pos, yaw, hl, hw, vel, half_width, ego_half, hold, lane_x, lane_y, lane_heading, lane
):
    """The object with the smallest gap among those within `half_width` of `path` at positive
    arc length whose velocity across the path keeps it there for `hold` seconds (its signed
    offset from the nearest segment's line plus `hold` times its velocity across it stays
    within `half_width`) and, when `lane`, that drives in one lane with the ego at
    (lane_x, lane_y) heading `lane_heading` (`_shares_lane`): (index or -1, gap, tangent x,
    tangent y). See `neighbour`."""
    best_k = -1
    best_gap = np.inf
    best_ux = 0.0
    best_uy = 0.0
    for k in range(pos.shape[0]):
        dist = np.inf
        s_best = 0.0
        ux_best = 0.0
        uy_best = 0.0
        s0 = 0.0
        lat_best = 0.0
        for j in range(path.shape[0] - 1):
            ax = path[j, 0]
            ay = path[j, 1]
            dx = path[j + 1, 0] - ax
            dy = path[j + 1, 1] - ay
            length = math.hypot(dx, dy)
            ux = dx / length
            uy = dy / length
            along = (pos[k, 0] - ax) * ux + (pos[k, 1] - ay) * uy
            along = min(max(along, 0.0), length)
            d = math.hypot(pos[k, 0] - ax - along * ux, pos[k, 1] - ay - along * uy)
            if d < dist - EPS:  # an equidistant vertex keeps the earlier segment
                dist = d
                s_best = s0 + along
                ux_best = ux
                uy_best = uy
                lat_best = ux * (pos[k, 1] - ay) - uy * (pos[k, 0] - ax)
            s0 += length
        if dist > half_width + EPS or s_best <= EPS:
            continue
        drift = ux_best * vel[k, 1] - uy_best * vel[k, 0]
        if abs(lat_best + hold * drift) > half_width + EPS:
            continue  # crossing the corridor: passing through, not in the lane (LANE_HOLD)
        if lane and not _shares_lane(
            lane_x, lane_y, lane_heading, pos[k, 0], pos[k, 1], yaw[k], half_width
        ):
            continue  # in the planned path, but not yet in the ego's lane (LEAD_LANE)
        # |cos| and |sin| of the heading against the tangent, the sine from the cross product:
        # sqrt(1 - cos^2) turns a rounding error of 1e-16 in cos into 1e-8 (a rigid motion of
        # the world moved the gap by 7.5e-9 m)
        hx = math.cos(yaw[k])
        hy = math.sin(yaw[k])
        cos = abs(hx * ux_best + hy * uy_best)
        sin = abs(hx * uy_best - hy * ux_best)
        extent = hl[k] * cos + hw[k] * sin
        gap = max(s_best - ego_half - extent, 0.0)
        if gap < best_gap - EPS:
            best_gap = gap
            best_k = k
            best_ux = ux_best
            best_uy = uy_best
    return best_k, best_gap, best_ux, best_uy


@settings(max_examples=300, deadline=None)
@given(
    seed=st.integers(0, 2**31 - 1),
    n=st.integers(0, 45),
    reverse=st.booleans(),
    curvy=st.sampled_from([0.0, 0.02, 0.3]),
    spacing=st.sampled_from([0.05, 0.5, 2.0]),
)
def test_path_and_nearest_equal_their_old_code(seed, n, reverse, curvy, spacing):
    rng = np.random.default_rng(seed)
    heading = np.cumsum(rng.normal(0, curvy, n))
    xs = np.cumsum(spacing * np.cos(heading)) + rng.normal(0, 0.02, n)
    ys = np.cumsum(spacing * np.sin(heading)) + rng.normal(0, 0.02, n)
    if rng.random() < 0.1:
        xs[:] = 0.0  # standing
        ys[:] = 0.0
    x0, y0, yaw = float(rng.normal(0, 0.1)), float(rng.normal(0, 0.1)), float(rng.normal())
    want = _old_path(x0, y0, xs, ys, reverse, yaw, 250.0)
    got = _path(x0, y0, xs, ys, reverse, yaw, 250.0)
    assert got.shape == want.shape and got.tobytes() == want.tobytes()
    k = int(rng.integers(0, 8))
    pos = np.column_stack([rng.uniform(-10, 60, k), rng.normal(0, 2, k)])
    if k and rng.random() < 0.3:
        pos[0] = want[min(1, len(want) - 1)]  # on a vertex
    oyaw = rng.normal(0, 0.3, k)
    hl = rng.uniform(1, 3, k)
    hw = rng.uniform(0.5, 1.2, k)
    vel = rng.normal(0, 3, (k, 2))
    for lane in (True, False):
        args = (want, pos, oyaw, hl, hw, vel, 1.75, 2.25, 1.0, x0, y0, yaw, lane)
        assert _nearest(*args) == _old_nearest(*args)


# -- plan smoothing, against its code at 985ff6a -------------------------------------------


@njit(cache=False, error_model="numpy")
def _old_smooth_plan(plan, half):
    """Each point replaced by a least-squares quadratic in time through the points within
    `half` seconds of it, evaluated at its time (points with fewer than three neighbours,
    themselves included, are kept)."""
    n = plan.shape[0]
    out = plan.copy()
    lo = 0
    hi = 0
    for k in range(n):
        tk = plan[k, 0]
        while lo < n and plan[lo, 0] < tk - half - 1e-9:
            lo += 1
        if hi < k:
            hi = k
        while hi < n and plan[hi, 0] <= tk + half + 1e-9:
            hi += 1
        m = hi - lo
        if m < 3:
            continue
        # normal equations of x(t) = c0 + c1 u + c2 u^2, u = (t - tk) / half
        s0 = 0.0
        s1 = 0.0
        s2 = 0.0
        s3 = 0.0
        s4 = 0.0
        bx0 = bx1 = bx2 = 0.0
        by0 = by1 = by2 = 0.0
        for j in range(lo, hi):
            u = (plan[j, 0] - tk) / half
            u2 = u * u
            s0 += 1.0
            s1 += u
            s2 += u2
            s3 += u2 * u
            s4 += u2 * u2
            bx0 += plan[j, 1]
            bx1 += plan[j, 1] * u
            bx2 += plan[j, 1] * u2
            by0 += plan[j, 2]
            by1 += plan[j, 2] * u
            by2 += plan[j, 2] * u2
        # Cramer's rule for the constant term c0 of the symmetric 3x3 system
        det = s0 * (s2 * s4 - s3 * s3) - s1 * (s1 * s4 - s2 * s3) + s2 * (s1 * s3 - s2 * s2)
        if abs(det) < 1e-12:
            continue
        cx = (
            bx0 * (s2 * s4 - s3 * s3) - s1 * (bx1 * s4 - s3 * bx2) + s2 * (bx1 * s3 - s2 * bx2)
        ) / det
        cy = (
            by0 * (s2 * s4 - s3 * s3) - s1 * (by1 * s4 - s3 * by2) + s2 * (by1 * s3 - s2 * by2)
        ) / det
        out[k, 1] = cx
        out[k, 2] = cy
    return out


@settings(max_examples=300, deadline=None)
@given(
    seed=st.integers(0, 2**31 - 1),
    n=st.integers(0, 60),
    half=st.sampled_from([1.0, 0.5, 2.0, 0.25, 0.75, 1.5, 0.1, 2.0**-30, 3.0]),
    step=st.sampled_from([0.1, 0.05, 0.5, 0.3]),
)
def test_smoothing_equals_its_old_code(seed, n, half, step):
    """The power-of-two half widths take a multiplication by 1 / half: the same doubles."""
    rng = np.random.default_rng(seed)
    dt = np.round(np.arange(n) * step + rng.choice([0.0, 0.03]), 6)
    if rng.random() < 0.3:
        dt = np.sort(rng.uniform(0, 5, n))
    plan = np.column_stack([dt, rng.normal(0, 1e3, n).cumsum(), rng.normal(0, 1, n)])
    want = _old_smooth_plan(plan, half)
    got = _smooth_plan(plan, half)
    assert got.tobytes() == want.tobytes()


@pytest.mark.parametrize(
    ("half", "scale"),
    [
        (1.0, 1.0),
        (0.5, 2.0),
        (4.0, 0.25),
        (0.75, 0.0),
        (0.1, 0.0),
        (0.0, 0.0),
        (-1.0, 0.0),
        (math.inf, 0.0),
        (math.nan, 0.0),
        (5e-324, 0.0),
        (2.0**1000, 0.0),
    ],
)
def test_scale_of_only_for_normal_powers_of_two(half, scale):
    assert _scale_of(half) == scale


def test_objects_in_mixed_layouts_are_read_as_before(monkeypatch):
    """A channel whose object arrays are not C-contiguous (a frame built in memory): the
    kernel takes one type for every channel, so the family makes them contiguous from then on
    (the same values)."""
    import dataclasses

    params = MetricParams()
    old = _old_engine(params, ["a", "b"], {}, monkeypatch)
    new = MetricEngine(params, ["a", "b"])
    for f in _drive(11, ["a", "b"], 30):
        s = f.channels.get("a")
        if s is not None and len(s.objects):
            o = s.objects
            o = dataclasses.replace(
                o, pos=np.asfortranarray(o.pos), vel=np.repeat(o.vel, 2, axis=0)[::2]
            )
            f.channels["a"] = ChannelState(s.ego, s.plan, o)
        got, want = new.step(f), old.step(f)
        names = [n for n in got if n.split("__")[0] in SITUATION_METRICS]
        assert {n: (got[n], want[n]) for n in names if not _same(got[n], want[n])} == {}
    assert new.family(SituationFamily)._normalise
