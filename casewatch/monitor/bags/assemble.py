"""Decoded messages -> the channel state of one tick (`monitor.frames`), in numpy.

Conventions (docs/bags.md, "How messages become frames"):

- yaw from the pose quaternion; velocities in the world frame, rotated from the body frame
  where ROS puts them (Odometry twist in `child_frame_id`, Autoware object twist in the
  object's frame);
- trajectories count from the tick: a point `tau` seconds after the message stamp `s` is
  `s + tau - T` after the tick `T`; points already in the past are dropped, nothing is
  interpolated or extrapolated;
- the ego and object poses are brought from their stamps to the tick with their own
  velocities and yaw rates (constant over at most `max_age`), so that two stacks sampled at
  different instants are compared at the same one (mapping `poses_at_tick: false` keeps them
  as stamped).
"""

from __future__ import annotations

import numpy as np

from casewatch.monitor.bags.decode import (
    BOUNDING_BOX,
    CLASS_NAMES,
    CYLINDER,
    ObjectsRecord,
    OdometryRecord,
    TrajectoryRecord,
)
from casewatch.monitor.frames import Ego, Objects, box_footprint, is_convex
from casewatch.monitor.parse import MAX_MAGNITUDE

#: Corner signs of a box footprint, in `box_footprint`'s order.
_BOX_SIGNS = np.sign(box_footprint(2.0, 2.0))

#: Below this speed (m/s) a plan segment timed from velocities is a stop: the plan ends there.
STOP_SPEED = 0.05


class RecordDefect(ValueError):
    """A decoded message that cannot become part of a frame (`kind`, message)."""

    def __init__(self, kind: str, message: str):
        super().__init__(message)
        self.kind = kind
        self.message = message


def yaw_of(q: np.ndarray) -> np.ndarray:
    """Heading (rad) of (..., 4) quaternions x, y, z, w about the z axis."""
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def to_world(v_body: np.ndarray, yaw: np.ndarray | float) -> np.ndarray:
    """(..., 2) body-frame vectors turned by `yaw` into the world frame."""
    c, s = np.cos(yaw), np.sin(yaw)
    out = np.empty_like(v_body)
    out[..., 0] = c * v_body[..., 0] - s * v_body[..., 1]
    out[..., 1] = s * v_body[..., 0] + c * v_body[..., 1]
    return out


def _finite(values: np.ndarray, what: str) -> None:
    if not np.isfinite(values).all():
        raise RecordDefect("non-finite", f"{what}: NaN or infinity in a pose or velocity")
    if values.size and np.abs(values).max() > MAX_MAGNITUDE:  # as a stream's (monitor.parse)
        raise RecordDefect("out-of-range", f"{what}: a pose or velocity beyond ±{MAX_MAGNITUDE:g}")


def ego_state(
    rec: OdometryRecord, footprint: np.ndarray, stamp_ns: int, tick_ns: int, at_tick: bool = True
) -> Ego:
    """The ego at the tick (or as stamped when not `at_tick`); `stamp_ns` is the time the
    message is taken to describe (its header stamp, or its recording time)."""
    _finite(rec.pose, "odometry")
    _finite(rec.twist, "odometry")
    yaw = float(yaw_of(rec.pose[3:7]))
    vx, vy = to_world(rec.twist[:2], np.float64(yaw))
    x, y = float(rec.pose[0]), float(rec.pose[1])
    age = (tick_ns - stamp_ns) / 1e9 if at_tick else 0.0
    if age:
        x, y, yaw = x + float(vx) * age, y + float(vy) * age, yaw + float(rec.twist[2]) * age
    return Ego(
        x=x,
        y=y,
        yaw=yaw,
        vx=float(vx),
        vy=float(vy),
        footprint=footprint,
        convex=True,
        half=(float(footprint[0, 0]), float(footprint[0, 1])),
    )


def _from_tick(times: np.ndarray, shift: float) -> np.ndarray:
    """Boolean mask of points at or after the tick, for times counted from the stamp."""
    return times + shift >= 0.0


def plan_state(rec: TrajectoryRecord, stamp_ns: int, tick_ns: int, plan_time: str) -> np.ndarray:
    """The plan as (N, 3) `[dt, x, y]` from the tick. `plan_time`: `stamps` uses
    `time_from_start`, `velocity` times the points from arc length and
    `longitudinal_velocity_mps` (up to the first stop), `auto` the stamps when they increase
    strictly, else the velocities (several Autoware planners leave `time_from_start` at 0)."""
    _finite(rec.pose[:, :2], "plan")
    tfs = rec.time_from_start / 1e9  # exact ns over 1e9: 41_700_000 ns is 0.0417 s as written
    xy = rec.pose[:, :2]
    increasing = len(tfs) < 2 or bool(np.all(np.diff(tfs) > 0))
    if plan_time == "velocity" or (plan_time == "auto" and not increasing):
        tfs, xy = _timed_by_speed(xy, rec.speed)
    elif not increasing:
        raise RecordDefect(
            "bad-trajectory",
            "plan time_from_start does not increase strictly "
            "(plan_time: auto times such plans from their velocities)",
        )
    if len(tfs) and tfs[0] < 0:
        raise RecordDefect("bad-trajectory", f"plan time_from_start {tfs[0]:g} s is negative")
    shift = (stamp_ns - tick_ns) / 1e9
    keep = _from_tick(tfs, shift)
    out = np.empty((int(keep.sum()), 3))
    out[:, 0] = tfs[keep] + shift
    out[:, 1:] = xy[keep]
    return out


def _timed_by_speed(xy: np.ndarray, speed: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Point times from arc length over the mean speed of each segment, the first point at 0;
    the plan ends at the first segment slower than STOP_SPEED (it is never driven past)."""
    if len(xy) < 2:
        return np.zeros(len(xy)), xy
    if not np.isfinite(speed).all():
        raise RecordDefect("non-finite", "plan: NaN or infinity in longitudinal_velocity_mps")
    ds = np.hypot(*np.diff(xy, axis=0).T)
    v = 0.5 * (np.abs(speed[:-1]) + np.abs(speed[1:]))
    moving = v >= STOP_SPEED
    end = len(xy) if moving.all() else int(np.argmin(moving)) + 1
    ds, v = ds[: end - 1], v[: end - 1]
    keep = np.concatenate([[True], ds > 0])  # repeated points carry no time
    times = np.concatenate([[0.0], np.cumsum(ds / np.where(moving[: end - 1], v, 1.0))])
    return times[keep[:end]], xy[:end][keep[:end]]


def objects_state(rec: ObjectsRecord, stamp_ns: int, tick_ns: int, at_tick: bool = True) -> Objects:
    """The objects at the tick (or as stamped when not `at_tick`), predictions from the tick."""
    k = len(rec.uuids)
    if k == 0:
        return Objects.empty()
    _finite(rec.pose[:, :2], "objects")
    _finite(rec.twist, "objects")
    yaw = yaw_of(rec.pose[:, 3:7])
    vel = to_world(rec.twist[:, :2], yaw)
    pos = rec.pose[:, :2].copy()
    age = (tick_ns - stamp_ns) / 1e9 if at_tick else 0.0
    if age:
        pos += vel * age
        yaw = yaw + rec.twist[:, 2] * age
    ids = [u.hex() for u in rec.uuids]
    _unique(ids)
    footprints, half, convex = _footprints(rec)
    pred, lens = _predictions(rec, (stamp_ns - tick_ns) / 1e9)
    return Objects(
        ids=ids,
        cls=[CLASS_NAMES.get(int(c), "unknown") for c in rec.label],
        pos=pos,
        yaw=yaw,
        vel=vel,
        footprints=footprints,
        pred=pred,
        pred_len=lens,
        convex=convex,
        half=half,
    )


def _unique(ids: list[str]) -> None:
    """Two objects under one uuid in one message are a `duplicate-id` defect, as in a stream
    (`monitor.parse.unique_ids`): which of them is the track cannot be known."""
    if len(set(ids)) == len(ids):
        return
    first: dict[str, int] = {}
    for i, oid in enumerate(ids):
        if oid in first:
            raise RecordDefect(
                "duplicate-id",
                f"objects[{i}]: object id {oid} is also objects[{first[oid]}]'s in this message",
            )
        first[oid] = i


def _predictions(rec: ObjectsRecord, shift: float) -> tuple[np.ndarray, np.ndarray]:
    """Predictions (K, P, 3) `[dt, x, y]` from the tick, padded by their last point, and their
    lengths. Pose i of a path is at i * time_step after the stamp; the points before the tick
    are dropped. One array operation when every path has the same length and step (a stack's
    predictor usually makes them so), else object by object."""
    k = len(rec.paths)
    lengths = np.fromiter((len(p) for p in rec.paths), dtype=np.int64, count=k)
    if (
        lengths[0] > 1
        and (lengths == lengths[0]).all()
        and (rec.steps == rec.steps[0]).all()
        and rec.steps[0] > 0
    ):
        n = int(lengths[0])
        times = (np.arange(n, dtype=np.int64) * int(rec.steps[0])) / 1e9
        keep = _from_tick(times, shift)
        paths = np.stack(rec.paths)[:, keep, :2]
        pred = np.empty((k, paths.shape[1], 3))
        pred[:, :, 0] = times[keep] + shift
        pred[:, :, 1:] = paths
        _finite(pred, "objects prediction")
        return pred, np.full(k, paths.shape[1], dtype=np.int64)
    preds = []
    for i in range(k):
        path = rec.paths[i]
        n = len(path)
        if n == 0:
            preds.append(np.zeros((0, 3)))
            continue
        if rec.steps[i] <= 0 and n > 1:
            raise RecordDefect(
                "bad-trajectory",
                f"objects[{i}]: predicted path with a time step of {rec.steps[i]} ns",
            )
        times = (np.arange(n, dtype=np.int64) * int(rec.steps[i])) / 1e9
        keep = _from_tick(times, shift)
        p = np.empty((int(keep.sum()), 3))
        p[:, 0] = times[keep] + shift
        p[:, 1:] = path[keep, :2]
        _finite(p, f"objects[{i}] prediction")
        preds.append(p)
    lens = np.fromiter((len(p) for p in preds), dtype=np.int64, count=k)
    pred = np.zeros((k, int(lens.max()), 3))
    for i, p in enumerate(preds):
        if len(p):
            pred[i, : len(p)] = p
            pred[i, len(p) :] = p[-1]
    return pred, lens


def _footprints(rec: ObjectsRecord) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Body-frame footprints (K, V, 2), box halves (K, 2; NaN for polygons), convexity.

    A box takes `dimensions` x and y; a cylinder the square around its circle (diameter
    `dimensions.x`), which never understates its extent; a polygon its footprint points."""
    k = len(rec.uuids)
    if (rec.shape == BOUNDING_BOX).all():  # the usual case, in one array operation
        half = 0.5 * rec.dims[:, :2]
        if not (half > 0).all():
            i = int(np.argmin((half > 0).all(axis=1)))
            raise RecordDefect(
                "bad-footprint",
                f"objects[{i}]: shape dimensions "
                f"{rec.dims[i, 0]:g} x {rec.dims[i, 1]:g} m are not positive",
            )
        fp = np.empty((k, 4, 2))
        fp[:, :, 0] = half[:, :1] * _BOX_SIGNS[:, 0]
        fp[:, :, 1] = half[:, 1:] * _BOX_SIGNS[:, 1]
        return fp, half.copy(), np.ones(k, dtype=bool)
    half = np.full((k, 2), np.nan)
    convex = np.ones(k, dtype=bool)
    polys: list[np.ndarray] = []
    for i in range(k):
        kind = int(rec.shape[i])
        if kind in (BOUNDING_BOX, CYLINDER):
            length = rec.dims[i, 0]
            width = rec.dims[i, 1] if kind == BOUNDING_BOX else rec.dims[i, 0]
            if not (length > 0 and width > 0):
                raise RecordDefect(
                    "bad-footprint",
                    f"objects[{i}]: shape dimensions {length:g} x {width:g} m are not positive",
                )
            polys.append(box_footprint(length, width))
            half[i] = (0.5 * length, 0.5 * width)
        else:
            poly = rec.footprints[i]
            if len(poly) < 3 or not np.isfinite(poly).all():
                raise RecordDefect(
                    "bad-footprint",
                    f"objects[{i}]: a polygon shape needs at "
                    f"least 3 finite points, got {len(poly)}",
                )
            polys.append(poly)
            convex[i] = is_convex(poly)
    vmax = max(len(p) for p in polys)
    fp = np.stack(
        [
            p if len(p) == vmax else np.concatenate([p, np.repeat(p[-1:], vmax - len(p), 0)])
            for p in polys
        ]
    )
    return fp, half, convex
