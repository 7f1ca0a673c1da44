"""Validating a decoded JSON frame into a `Frame`, by hand.

Hand-written checks instead of a pydantic model per object: the bench budget is about a
millisecond per frame, and a reader must name exactly what is wrong (which channel, which
object, which field) in the user's terms. Point lists become numpy arrays in one call each.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from itertools import chain
from typing import Any

import numpy as np

from casewatch.monitor.frames import (
    FORMAT_NAME,
    FORMAT_VERSION,
    ChannelState,
    Coverage,
    Ego,
    Frame,
    Header,
    Objects,
    box_footprint,
    is_convex,
)
from casewatch.monitor.jit import kernel
from casewatch.monitor.world import WorldError, parse_world
from casewatch.safety_case.model import OddValue
from casewatch.safety_case.odd import OddError, flatten_conditions

#: Stable defect kinds, documented in docs/streams.md.
DEFECT_KINDS: dict[str, str] = {
    "malformed-json": "the line is not valid JSON or not a JSON object",
    "missing-field": "a required field is absent",
    "wrong-type": "a field has the wrong JSON type or shape",
    "non-finite": "a number is NaN, infinite or null where a value is required",
    "out-of-range": "a position, velocity, size or trajectory value beyond ±1e9",
    "unknown-channel": "a channel not declared (header or caller) appears",
    "non-increasing-t": "frame time does not increase strictly",
    "bad-trajectory": "plan or prediction dt negative or not strictly increasing",
    "bad-footprint": "footprint missing, given twice, or degenerate",
    "bad-header": "header malformed, of another format/version, or not on the first line",
    "bad-time": "frame time t beyond 1e12 s, where floats no longer resolve the period",
    "frame-spacing": "frame closer than half a period to the previous frame",
    "oversized-line": "line longer than the reader's limit (16 Mi characters)",
    "truncated-stream": "compressed stream ends early or is corrupt; reading stops there",
    "duplicate-id": "two objects of one channel carry the same id in one frame",
}


class FrameDefect(Exception):
    """A validation failure inside one line: `kind` is one of DEFECT_KINDS."""

    def __init__(self, kind: str, message: str):
        super().__init__(message)
        self.kind = kind
        self.message = message


#: The Python types a JSON number decodes to (bool, a subclass of int, is deliberately absent).
_NUMBER_TYPES = frozenset({float, int})


#: Largest magnitude of a position, velocity, size or trajectory value (metres, m/s, s): map
#: coordinates (UTM eastings are about 10^6 m) stay far below; 1e308 would overflow the
#: geometry of the metrics (the squared point distances of the plans' Fréchet distance).
MAX_MAGNITUDE = 1e9

#: How deep the header's `meta` may nest (objects and lists); result.json carries it.
MAX_META_DEPTH = 32


def _depth(value: Any, limit: int = MAX_META_DEPTH + 1) -> int:
    """Nesting depth of a decoded JSON value (0 for a scalar), counted up to `limit` + 1."""
    depth, level = 0, [value]
    while level and depth <= limit:
        level = [
            v
            for x in level
            for v in (x.values() if isinstance(x, dict) else x if isinstance(x, list) else ())
        ]
        depth += 1
    return depth - 1 if not level else depth


def _is_num(v: Any) -> bool:
    # bool is an int subclass in Python but never a number in a frame.
    return isinstance(v, (float, int)) and type(v) is not bool


def _number(d: dict[str, Any], key: str, where: str, default: float | None = None) -> float:
    if key not in d:
        if default is None:
            raise FrameDefect("missing-field", f"{where}: missing required field '{key}'")
        return default
    v = d[key]
    if not _is_num(v):
        if v is None:
            raise FrameDefect("non-finite", f"{where}.{key}: null where a number is required")
        raise FrameDefect(
            "wrong-type", f"{where}.{key}: expected a number, got {type(v).__name__} {v!r:.40}"
        )
    if not math.isfinite(v):
        raise FrameDefect("non-finite", f"{where}.{key}: {v} is not a finite number")
    if key != "t" and abs(v) > MAX_MAGNITUDE:  # `t` has its own bound (bad-time)
        raise FrameDefect(
            "out-of-range",
            f"{where}.{key}: {v:g} is beyond ±{MAX_MAGNITUDE:g} "
            "(metres, m/s, radians: a drive's values are far smaller)",
        )
    return float(v)


def _points(v: Any, where: str, ncols: int, what: str) -> np.ndarray:
    """A list of `ncols`-number rows as an (n, ncols) float array, checked finite.

    Element types are checked before numpy sees them: `np.array` would turn `true` into 1.0
    and, without a dtype, "1.5" into a string array; a JSON boolean or string is never a
    number here."""
    if not isinstance(v, list):
        raise FrameDefect("wrong-type", f"{where}: expected a list of {what}")
    if not v:
        return np.zeros((0, ncols))
    try:
        # a row that is a string or an object of the right length fails the type check below
        if set(map(len, v)) != {ncols}:
            raise FrameDefect("wrong-type", f"{where}: expected a list of {what}")
        flat = list(chain.from_iterable(v))
    except TypeError:  # a row without a length (a number, null)
        raise FrameDefect("wrong-type", f"{where}: expected a list of {what}") from None
    types = set(map(type, flat))
    if not types <= _NUMBER_TYPES:
        if type(None) in types:
            row = next(i for i, point in enumerate(v) if None in point)
            raise FrameDefect("non-finite", f"{where}[{row}]: null in {v[row]!r:.60}")
        raise FrameDefect("wrong-type", f"{where}: expected a list of {what} (numbers only)")
    arr = np.array(flat, dtype=float).reshape(len(v), ncols)
    if not np.isfinite(arr).all():
        row = int(np.nonzero(~np.isfinite(arr).all(axis=1))[0][0])
        raise FrameDefect("non-finite", f"{where}[{row}]: NaN, inf or null in {v[row]!r:.60}")
    if len(arr) and np.abs(arr).max() > MAX_MAGNITUDE:
        row = int(np.nonzero((np.abs(arr) > MAX_MAGNITUDE).any(axis=1))[0][0])
        raise FrameDefect(
            "out-of-range", f"{where}[{row}]: a value beyond ±{MAX_MAGNITUDE:g} in {v[row]!r:.60}"
        )
    return arr


def _trajectory(v: Any, where: str) -> np.ndarray:
    arr = _points(v, where, 3, "[dt, x, y] points")
    if len(arr):
        dt = arr[:, 0]
        if dt[0] < 0:
            raise FrameDefect("bad-trajectory", f"{where}[0]: dt {dt[0]:g} is negative")
        bad = np.nonzero(np.diff(dt) <= 0)[0]
        if len(bad):
            i = int(bad[0]) + 1
            raise FrameDefect(
                "bad-trajectory",
                f"{where}[{i}]: dt {dt[i]:g} does not increase strictly (previous {dt[i - 1]:g})",
            )
    return arr


def _footprint(d: dict[str, Any], where: str) -> np.ndarray:
    has_poly = "polygon" in d
    has_box = "length" in d or "width" in d
    if has_poly and has_box:
        raise FrameDefect(
            "bad-footprint", f"{where}: give either 'length'+'width' or 'polygon', not both"
        )
    if has_poly:
        poly = _points(d["polygon"], f"{where}.polygon", 2, "[x, y] body-frame vertices")
        if len(poly) < 3:
            raise FrameDefect("bad-footprint", f"{where}.polygon: needs at least 3 vertices")
        return poly
    if not has_box:
        raise FrameDefect(
            "missing-field", f"{where}: missing footprint ('length'+'width' or 'polygon')"
        )
    length = _number(d, "length", where)
    width = _number(d, "width", where)
    if length <= 0 or width <= 0:
        raise FrameDefect(
            "bad-footprint", f"{where}: length and width must be > 0 (got {length:g}, {width:g})"
        )
    return box_footprint(length, width)


def _dict(v: Any, where: str) -> dict[str, Any]:
    if not isinstance(v, dict):
        raise FrameDefect("wrong-type", f"{where}: expected an object, got {type(v).__name__}")
    return v


def _ego(v: Any, where: str) -> Ego:
    d = _dict(v, where)
    fp = _footprint(d, where)
    return Ego(
        x=_number(d, "x", where),
        y=_number(d, "y", where),
        yaw=_number(d, "yaw", where),
        vx=_number(d, "vx", where, 0.0),
        vy=_number(d, "vy", where, 0.0),
        footprint=fp,
        convex="polygon" not in d or is_convex(fp),
        half=None if "polygon" in d else (float(fp[0, 0]), float(fp[0, 1])),
    )


@kernel
def _box_objects(num: np.ndarray, pred: np.ndarray):
    """Checks and arrays of box-footprint objects in one compiled pass.

    num (K, 7): x, y, yaw, vx, vy, length, width; pred (K, P, 3) predictions of one length.
    Returns (ok, pos, yaw, vel, footprints, half, pred_len, convex); ok is False when a number
    is not finite, a box is degenerate or a prediction's dt is negative or not strictly
    increasing (the careful path then names the defect).
    """
    k = num.shape[0]
    n_pred = pred.shape[1]
    ok = True
    pos = np.empty((k, 2))
    yaw = np.empty(k)
    vel = np.empty((k, 2))
    footprints = np.empty((k, 4, 2))
    half = np.empty((k, 2))
    for i in range(k):
        for c in range(7):
            if not np.isfinite(num[i, c]):
                ok = False
        if not (num[i, 5] > 0.0 and num[i, 6] > 0.0):
            ok = False
        for j in range(n_pred):
            for c in range(3):
                if not np.isfinite(pred[i, j, c]):
                    ok = False
            if j == 0:
                if not pred[i, 0, 0] >= 0.0:
                    ok = False
            elif not pred[i, j, 0] > pred[i, j - 1, 0]:
                ok = False
        hl = 0.5 * num[i, 5]
        hw = 0.5 * num[i, 6]
        pos[i, 0] = num[i, 0]
        pos[i, 1] = num[i, 1]
        yaw[i] = num[i, 2]
        vel[i, 0] = num[i, 3]
        vel[i, 1] = num[i, 4]
        # body-frame corners in box_footprint's order
        footprints[i, 0, 0] = hl
        footprints[i, 0, 1] = hw
        footprints[i, 1, 0] = -hl
        footprints[i, 1, 1] = hw
        footprints[i, 2, 0] = -hl
        footprints[i, 2, 1] = -hw
        footprints[i, 3, 0] = hl
        footprints[i, 3, 1] = -hw
        half[i, 0] = hl
        half[i, 1] = hw
    pred_len = np.full(k, n_pred, dtype=np.int64)
    convex = np.ones(k, dtype=np.bool_)
    return ok, pos, yaw, vel, footprints, half, pred_len, convex


def _objects_fast(v: list[Any]) -> Objects | None:
    """The common case: box footprints, predictions of one length. Python only gathers the
    fields and checks their JSON types; one compiled pass checks the numbers and builds the
    arrays. Returns None whenever anything is unusual or wrong; the careful path then either
    accepts the input or names the exact defect, so both paths accept exactly the same input."""
    try:
        ids = [o["id"] for o in v]
        cls = [o.get("cls", "unknown") for o in v]
        rows = [
            (
                o["x"],
                o["y"],
                o.get("yaw", 0.0),
                o.get("vx", 0.0),
                o.get("vy", 0.0),
                o["length"],
                o["width"],
            )
            for o in v
        ]
        preds = [o.get("prediction") for o in v]
        if any("polygon" in o for o in v):
            return None
        if not all(type(i) is str or type(i) is int for i in ids):
            return None
        if not all(type(c) is str for c in cls):
            return None
        if not set(map(type, chain.from_iterable(rows))) <= _NUMBER_TYPES:
            return None
        first = preds[0]
        if type(first) is not list or not all(
            type(p) is list and len(p) == len(first) for p in preds
        ):
            return None
        k = len(v)
        if first:
            points = list(chain.from_iterable(preds))
            # a non-list point of length 3 (a string, a dict) fails the element-type check
            if set(map(len, points)) != {3}:
                return None
            flat = list(chain.from_iterable(points))
            if not set(map(type, flat)) <= _NUMBER_TYPES:
                return None
            pred = np.array(flat, dtype=float).reshape(k, len(first), 3)
        else:
            pred = np.zeros((k, 0, 3))
    except (KeyError, TypeError, AttributeError):
        return None
    ok, pos, yaw, vel, footprints, half, pred_len, convex = _box_objects(
        np.array(rows, dtype=float), pred
    )
    if not ok:
        return None
    return Objects(
        ids=[str(i) for i in ids],
        cls=cls,
        pos=pos,
        yaw=yaw,
        vel=vel,
        footprints=footprints,
        pred=pred,
        pred_len=pred_len,
        convex=convex,
        half=half,
    )


def unique_ids(ids: list[str], where: str) -> None:
    """Refuse a frame whose channel reports two objects under one id (`duplicate-id`).

    An id is how a track is followed from frame to frame (metric history, scenario export): with
    two objects under one id in one frame, which of them is the track cannot be known, and a
    trajectory built from them would jump between the two."""
    if len(set(ids)) == len(ids):
        return
    first: dict[str, int] = {}
    for i, oid in enumerate(ids):
        if oid in first:
            raise FrameDefect(
                "duplicate-id",
                f"{where}[{i}].id: object id {oid!r} is also {where}[{first[oid]}]'s in this "
                "frame (ids are compared as strings)",
            )
        first[oid] = i


def _objects(v: Any, where: str) -> Objects:
    objects = _objects_unchecked(v, where)
    unique_ids(objects.ids, where)
    return objects


def _objects_unchecked(v: Any, where: str) -> Objects:
    if isinstance(v, list) and v:
        fast = _objects_fast(v)
        if fast is not None:
            return fast
    if not isinstance(v, list):
        raise FrameDefect("wrong-type", f"{where}: expected a list of objects")
    k = len(v)
    if k == 0:
        return Objects.empty()
    ids: list[str] = []
    cls: list[str] = []
    num = np.empty((k, 5))
    fps: list[np.ndarray] = []
    preds: list[np.ndarray] = []
    convex = np.ones(k, dtype=bool)
    half = np.full((k, 2), np.nan)
    for i, o in enumerate(v):
        w = f"{where}[{i}]"
        o = _dict(o, w)
        if "id" not in o:
            raise FrameDefect("missing-field", f"{w}: missing required field 'id'")
        oid = o["id"]
        if type(oid) is int or type(oid) is str:
            ids.append(str(oid))
        else:
            raise FrameDefect(
                "wrong-type", f"{w}.id: expected a string or integer, got {oid!r:.40}"
            )
        c = o.get("cls", "unknown")
        if not isinstance(c, str):
            raise FrameDefect("wrong-type", f"{w}.cls: expected a string, got {c!r:.40}")
        cls.append(c)
        num[i, 0] = _number(o, "x", w)
        num[i, 1] = _number(o, "y", w)
        num[i, 2] = _number(o, "yaw", w, 0.0)
        num[i, 3] = _number(o, "vx", w, 0.0)
        num[i, 4] = _number(o, "vy", w, 0.0)
        fp = _footprint(o, w)
        if "polygon" in o:
            convex[i] = is_convex(fp)
        else:
            half[i] = fp[0]
        fps.append(fp)
        p = o.get("prediction")
        preds.append(np.zeros((0, 3)) if p is None else _trajectory(p, f"{w}.prediction"))
    vmax = max(len(f) for f in fps)
    if all(len(f) == vmax for f in fps):
        footprints = np.stack(fps)
    else:
        footprints = np.stack(
            [np.concatenate([f, np.repeat(f[-1:], vmax - len(f), 0)]) for f in fps]
        )
    lens = np.fromiter((len(p) for p in preds), dtype=int, count=k)
    pmax = int(lens.max())
    if bool((lens == pmax).all()):
        pred = np.stack(preds) if pmax else np.zeros((k, 0, 3))
    else:
        pred = np.zeros((k, pmax, 3))
        for i, p in enumerate(preds):
            if len(p):
                pred[i, : len(p)] = p
                pred[i, len(p) :] = p[-1]
    return Objects(
        ids=ids,
        cls=cls,
        pos=num[:, 0:2].copy(),
        yaw=num[:, 2].copy(),
        vel=num[:, 3:5].copy(),
        footprints=footprints,
        pred=pred,
        pred_len=lens,
        convex=convex,
        half=half,
    )


def parse_channel(v: Any, where: str) -> ChannelState:
    d = _dict(v, where)
    if "ego" not in d:
        raise FrameDefect("missing-field", f"{where}: missing required field 'ego'")
    ego = _ego(d["ego"], f"{where}.ego")
    plan = _trajectory(d.get("plan", []), f"{where}.plan")
    objects = _objects(d.get("objects", []), f"{where}.objects")
    return ChannelState(ego=ego, plan=plan, objects=objects)


def parse_frame(obj: Any, known_channels: Iterable[str] | None = None, line: int = 0) -> Frame:
    """Validate one decoded frame. Raises `FrameDefect` naming the first problem found."""
    d = _dict(obj, "frame")
    if "t" not in d:
        raise FrameDefect("missing-field", "frame: missing required field 't'")
    t = _number(d, "t", "frame")
    if "channels" not in d:
        raise FrameDefect("missing-field", "frame: missing required field 'channels'")
    chans = _dict(d["channels"], "channels")
    known = None if known_channels is None else set(known_channels)
    channels: dict[str, ChannelState] = {}
    for name, cv in chans.items():
        if known is not None and name not in known:
            raise FrameDefect(
                "unknown-channel",
                f"channels.{name}: channel not declared (declared: {', '.join(sorted(known))})",
            )
        try:
            channels[name] = parse_channel(cv, f"channels.{name}")
        except FrameDefect as defect:
            if defect.kind != "duplicate-id":
                raise
            raise FrameDefect(defect.kind, f"frame t = {t:g}: {defect.message}") from None
    signals, odd, world = frame_extras(d)
    return Frame(t=t, channels=channels, signals=signals, line=line, odd=odd, world=world)


def frame_extras(
    d: dict[str, Any],
) -> tuple[dict[str, float | None], dict[str, OddValue] | None, dict[str, float | None] | None]:
    """A frame's `signals`, `odd` and `world` (read from the decoded frame `d`), checked.

    Its own function so that the compiled reader (`monitor.fastparse`), which hands these small
    parts to orjson, reads them with exactly these checks."""
    signals: dict[str, float | None] = {}
    sv = d.get("signals")
    if sv is not None:
        for key, val in _dict(sv, "signals").items():
            if val is None:
                signals[key] = None
            elif _is_num(val):
                signals[key] = float(val) if math.isfinite(val) else None
            else:
                raise FrameDefect(
                    "wrong-type", f"signals.{key}: expected a number or null, got {val!r:.40}"
                )
    odd = None
    if d.get("odd") is not None:
        try:
            odd = flatten_conditions(d["odd"], "odd")
        except OddError as exc:
            raise FrameDefect("wrong-type", str(exc)) from None
    world = None
    if d.get("world") is not None:
        try:
            world = parse_world(d["world"])
        except WorldError as exc:
            raise FrameDefect("wrong-type", str(exc)) from None
    return signals, odd, world


def parse_header(obj: Any) -> Header:
    """Validate the `{"header": {...}}` line."""
    h = _dict(obj.get("header"), "header")
    fmt = h.get("format", FORMAT_NAME)
    if fmt != FORMAT_NAME:
        raise FrameDefect("bad-header", f"header.format: expected '{FORMAT_NAME}', got {fmt!r}")
    version = h.get("version", FORMAT_VERSION)
    if version != FORMAT_VERSION:
        raise FrameDefect(
            "bad-header",
            f"header.version: this reader reads version {FORMAT_VERSION}, got {version!r}",
        )
    chans = h.get("channels", [])
    if not isinstance(chans, list) or not all(isinstance(c, str) for c in chans):
        raise FrameDefect("bad-header", "header.channels: expected a list of channel names")
    if len(set(chans)) != len(chans):
        raise FrameDefect("bad-header", f"header.channels: duplicate channel names in {chans}")
    period = h.get("period", 0.1)
    if not _is_num(period) or not math.isfinite(period) or period <= 0:
        raise FrameDefect(
            "bad-header", f"header.period: expected a positive number, got {period!r}"
        )
    meta = h.get("meta", {})
    if not isinstance(meta, dict):
        raise FrameDefect("bad-header", "header.meta: expected an object")
    if _depth(meta) > MAX_META_DEPTH:  # result.json repeats meta: its writer has a depth limit
        raise FrameDefect(
            "bad-header",
            f"header.meta: nested deeper than {MAX_META_DEPTH} levels of objects and lists",
        )
    conditions: dict[str, OddValue] = {}
    conditions_problem = None
    if meta.get("odd") is not None:
        try:
            conditions = flatten_conditions(meta["odd"], "header.meta.odd")
        except OddError as exc:  # the rest of the header stands; no condition is reported
            conditions_problem = str(exc)
    return Header(
        format=fmt,
        version=version,
        channels=list(chans),
        period=float(period),
        meta=meta,
        coverage=parse_coverage(h.get("coverage", {}), "header.coverage"),
        conditions=conditions,
        conditions_problem=conditions_problem,
    )


def parse_coverage(v: Any, where: str) -> dict[str, Coverage]:
    """`{"lav": {"fov_deg": 360, "range_m": 80}, ...}`: per channel, the field of view in
    degrees (0 < fov <= 360, centred on the ego heading) and the range in metres (> 0); either
    may be left out (all-round / unlimited)."""
    if not isinstance(v, dict):
        raise FrameDefect("bad-header", f"{where}: expected an object of channel -> coverage")
    out: dict[str, Coverage] = {}
    for channel, spec in v.items():
        here = f"{where}.{channel}"
        if not isinstance(spec, dict):
            raise FrameDefect("bad-header", f"{here}: expected {{fov_deg, range_m}}")
        unknown = set(spec) - {"fov_deg", "range_m"}
        if unknown:
            raise FrameDefect(
                "bad-header", f"{here}: unknown key(s) {sorted(unknown)}; expected fov_deg, range_m"
            )
        fov = spec.get("fov_deg", 360.0)
        rng = spec.get("range_m", math.inf)
        if not _is_num(fov) or not 0 < fov <= 360:
            raise FrameDefect(
                "bad-header", f"{here}.fov_deg: expected 0 < degrees <= 360, got {fov!r}"
            )
        if not _is_num(rng) or not rng > 0 or math.isnan(rng):
            raise FrameDefect("bad-header", f"{here}.range_m: expected metres > 0, got {rng!r}")
        out[channel] = Coverage(float(fov), float(rng))
    return out
