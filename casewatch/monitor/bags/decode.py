"""Decoding the three message types casewatch reads into plain arrays, two ways.

- `FAST`: a reader of the CDR bytes written for exactly the shipped field layout
  (`monitor/bags/msg`). It never builds a Python object per pose: poses, covariances and plan
  points are numpy views of the message bytes. rosbags' generic deserialiser builds about 20
  Python objects per predicted pose, which made a 2-channel frame cost ~1 ms, as much as
  judging it.
- `GENERIC`: rosbags' deserialiser and attribute access by field name. It serves bags whose
  definitions differ from the shipped ones (a newer Autoware with added fields) and is the fast
  reader's test oracle (`tests/test_bag_decode.py`).

Both return the same records; `DecodeError` names what is wrong with one message.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from casewatch.errors import CasewatchError
from casewatch.monitor.bags.types import OBJECTS, ODOMETRY, TRAJECTORY
from casewatch.monitor.jit import kernel

#: Autoware `ObjectClassification.label` -> casewatch object class.
CLASS_NAMES: dict[int, str] = {
    0: "unknown",
    1: "car",
    2: "truck",
    3: "bus",
    4: "trailer",
    5: "motorcycle",
    6: "bicycle",
    7: "pedestrian",
    8: "animal",
    9: "hazard",
    10: "over_drivable",
    11: "under_drivable",
}

#: `Shape.type` values.
BOUNDING_BOX, CYLINDER, POLYGON = 0, 1, 2


class DecodeError(CasewatchError, ValueError):
    """A message whose bytes do not hold what its type promises (truncated, corrupt)."""


@dataclass(slots=True)
class OdometryRecord:
    """`nav_msgs/Odometry`: stamp (ns), pose (7: x, y, z, qx, qy, qz, qw) in the map frame,
    twist (3: linear x, y and angular z, the yaw rate) in the body frame (`child_frame_id`)."""

    stamp: int
    pose: np.ndarray
    twist: np.ndarray


@dataclass(slots=True)
class ObjectsRecord:
    """`PredictedObjects`, one row per object.

    `pose` (K, 7) map frame; `twist` (K, 3) linear x, y and yaw rate in the object's frame;
    `label` (K,) the
    most probable class; `shape` (K,) Shape.type; `dims` (K, 3); `footprints` per object the
    polygon points (n, 2) in the object's frame; `paths` per object the most confident
    predicted path as (n, 7) poses, `steps` (K,) its time step in ns.
    """

    stamp: int
    uuids: list[bytes]
    pose: np.ndarray
    twist: np.ndarray
    label: np.ndarray
    shape: np.ndarray
    dims: np.ndarray
    footprints: list[np.ndarray]
    paths: list[np.ndarray]
    steps: np.ndarray


@dataclass(slots=True)
class TrajectoryRecord:
    """`Trajectory`: stamp (ns), per point `time_from_start` (ns), pose (N, 7), and the
    longitudinal velocity (N,)."""

    stamp: int
    time_from_start: np.ndarray
    pose: np.ndarray
    speed: np.ndarray


Record = OdometryRecord | ObjectsRecord | TrajectoryRecord

_CDR_LE = b"\x00\x01"  # plain CDR, little endian: what ROS 2 writes (rosbags reads no other)
_BASE = 4  # alignment counts from the end of the encapsulation header
_STAMP = struct.Struct("<iI")
_U32 = struct.Struct("<I")
_F32 = struct.Struct("<f")
_TRAJ_POINT = np.dtype(
    [
        ("sec", "<i4"),
        ("nsec", "<u4"),
        ("pose", "<f8", (7,)),
        ("speed", "<f4"),
        ("rest", "<f4", (5,)),
    ]
)


def _rank(value: float) -> float:
    """A confidence or probability as it ranks: NaN ranks lowest, like -inf."""
    return -math.inf if math.isnan(value) else value


def _first_best(values: np.ndarray) -> int:
    """Index of the greatest value, the first on ties, NaN ranking lowest."""
    return int(np.argmax(np.where(np.isnan(values), -np.inf, values)))


def header_stamp(raw: bytes | memoryview) -> int:
    """The `header.stamp` (ns) of a message whose first field is a std_msgs/Header, read
    straight from the bytes (the reader aligns on stamps before it decodes anything)."""
    if len(raw) < 12:
        raise DecodeError(f"{len(raw)} bytes cannot hold a header")
    sec, nsec = _STAMP.unpack_from(raw, _BASE)
    return sec * 1_000_000_000 + nsec


def _align(offset: int, size: int) -> int:
    return offset + (-(offset - _BASE)) % size


def _skip_string(raw, o: int) -> int:
    o = _align(o, 4)
    (n,) = _U32.unpack_from(raw, o)
    return o + 4 + n


def _doubles(raw, o: int, count: int) -> np.ndarray:
    return np.frombuffer(raw, "<f8", count, o)


def fast_odometry(raw) -> OdometryRecord:
    stamp = header_stamp(raw)
    o = _skip_string(raw, _BASE + 8)  # header.frame_id
    o = _align(_skip_string(raw, o), 8)  # child_frame_id
    values = _doubles(raw, o, 43 + 42)
    return OdometryRecord(stamp, values[:7].copy(), values[[43, 44, 48]])


@kernel
def _at(o, size):  # pragma: no cover - compiled
    """`o` aligned to `size` bytes, counted from the end of the encapsulation header."""
    r = (o - 4) % size
    return o if r == 0 else o + size - r


@kernel
def _u32(buf, o):  # pragma: no cover - compiled
    return np.int64(buf[o : o + 4].view(np.uint32)[0])


@kernel
def _f32(buf, o):  # pragma: no cover - compiled
    v = np.float64(buf[o : o + 4].view(np.float32)[0])
    return -np.inf if v != v else v  # NaN ranks lowest


@kernel
def _walk_objects(
    buf, fill, uuid_at, pose, twist, label, shape, dims, path_len, steps, paths, poly_len, poly
):  # pragma: no cover - compiled
    """One pass over the CDR bytes of a PredictedObjects message.

    With `fill` False it only checks the bytes and counts (objects, path poses, polygon
    points), so the caller can size the outputs; with `fill` True it writes them. Returns
    (status, objects, poses, points): status 0 fine, -1 the bytes end inside the message, -2
    more objects claimed than the bytes can hold. Per object it keeps the most probable class
    and the most confident non-empty path, the first on ties, NaN ranking lowest."""
    n = buf.shape[0]
    if n < 16:
        return -1, 0, 0, 0
    o = 12 + 4 + _u32(buf, 12)  # header.frame_id
    o = _at(o, 4)
    if o + 4 > n:
        return -1, 0, 0, 0
    k = _u32(buf, o)
    o += 4
    if k * 1080 > n:  # an object takes at least 1080 bytes (its covariances alone 1016)
        return -2, k, 0, 0
    total_poses = 0
    total_points = 0
    for i in range(k):
        if o + 16 > n:
            return -1, 0, 0, 0
        if fill:
            uuid_at[i] = o
        o = _at(o + 16, 4) + 4  # uuid, existence_probability
        if o + 4 > n:
            return -1, 0, 0, 0
        ncls = _u32(buf, o)
        o += 4
        if o + 8 * ncls > n:
            return -1, 0, 0, 0
        best_l = 0
        best_p = -np.inf
        for c in range(ncls):
            p = _f32(buf, o + 8 * c + 4)
            if c == 0 or p > best_p:
                best_p = p
                best_l = buf[o + 8 * c]
        if fill:
            label[i] = best_l
        o = _at(o + 8 * ncls, 8)
        if o + 1016 > n:
            return -1, 0, 0, 0
        if fill:
            kin = buf[o : o + 1016].view(np.float64)
            for j in range(7):
                pose[i, j] = kin[j]
            twist[i, 0] = kin[43]
            twist[i, 1] = kin[44]
            twist[i, 2] = kin[48]
        o = _at(o + 1016, 4)
        if o + 4 > n:
            return -1, 0, 0, 0
        npaths = _u32(buf, o)
        o += 4
        best_at = -1
        best_n = 0
        best_step = 0
        best_c = -np.inf
        for _ in range(npaths):
            o = _at(o, 4)
            if o + 4 > n:
                return -1, 0, 0, 0
            m = _u32(buf, o)
            o += 4
            at = -1
            if m > 0:
                o = _at(o, 8)
                if o + 56 * m > n:
                    return -1, 0, 0, 0
                at = o
                o += 56 * m
            o = _at(o, 4)
            if o + 12 > n:
                return -1, 0, 0, 0
            sec = np.int64(buf[o : o + 4].view(np.int32)[0])
            nsec = _u32(buf, o + 4)
            conf = _f32(buf, o + 8)
            o += 12
            if m > 0 and (best_at < 0 or conf > best_c):
                best_at = at
                best_n = m
                best_c = conf
                best_step = sec * 1_000_000_000 + nsec
        if fill:
            path_len[i] = best_n
            steps[i] = best_step
            if best_n > 0:
                flat = buf[best_at : best_at + 56 * best_n].view(np.float64)
                for r in range(best_n):
                    for j in range(7):
                        paths[total_poses + r, j] = flat[7 * r + j]
        total_poses += best_n
        if o + 1 > n:
            return -1, 0, 0, 0
        if fill:
            shape[i] = buf[o]
        o = _at(o + 1, 4)
        if o + 4 > n:
            return -1, 0, 0, 0
        q = _u32(buf, o)
        o += 4
        if o + 12 * q > n:
            return -1, 0, 0, 0
        if fill:
            poly_len[i] = q
            if q > 0:
                pts = buf[o : o + 12 * q].view(np.float32)
                for r in range(q):
                    poly[total_points + r, 0] = pts[3 * r]
                    poly[total_points + r, 1] = pts[3 * r + 1]
        total_points += q
        o = _at(o + 12 * q, 8)
        if o + 24 > n:
            return -1, 0, 0, 0
        if fill:
            d = buf[o : o + 24].view(np.float64)
            dims[i, 0] = d[0]
            dims[i, 1] = d[1]
            dims[i, 2] = d[2]
        o += 24
    return 0, k, total_poses, total_points


_NONE_I = np.zeros(0, dtype=np.int64)
_NONE_2 = np.zeros((0, 2))
_NONE_3 = np.zeros((0, 3))
_NONE_7 = np.zeros((0, 7))


def fast_objects(raw) -> ObjectsRecord:
    """PredictedObjects from its bytes: one compiled pass to check and count, one to fill."""
    stamp = header_stamp(raw)
    buf = np.frombuffer(raw, np.uint8)
    status, k, n_poses, n_points = _walk_objects(
        buf,
        False,
        _NONE_I,
        _NONE_7,
        _NONE_3,
        _NONE_I,
        _NONE_I,
        _NONE_3,
        _NONE_I,
        _NONE_I,
        _NONE_7,
        _NONE_I,
        _NONE_2,
    )
    if status == -2:
        raise DecodeError(f"claims {k} objects in {len(raw)} bytes")
    if status < 0:
        raise DecodeError("the bytes end inside the message")
    uuid_at = np.empty(k, dtype=np.int64)
    pose, twist, dims = np.empty((k, 7)), np.empty((k, 3)), np.empty((k, 3))
    label, shape = np.zeros(k, dtype=np.int64), np.empty(k, dtype=np.int64)
    path_len, steps, poly_len = (np.zeros(k, dtype=np.int64) for _ in range(3))
    paths, poly = np.empty((n_poses, 7)), np.empty((n_points, 2))
    _walk_objects(
        buf, True, uuid_at, pose, twist, label, shape, dims, path_len, steps, paths, poly_len, poly
    )
    path_ends = np.cumsum(path_len).tolist()
    poly_ends = np.cumsum(poly_len).tolist()
    path_starts = [0, *path_ends[:-1]] if k else []
    poly_starts = [0, *poly_ends[:-1]] if k else []
    return ObjectsRecord(
        stamp,
        [bytes(raw[a : a + 16]) for a in uuid_at.tolist()],
        pose,
        twist,
        label,
        shape,
        dims,
        [poly[a:b] for a, b in zip(poly_starts, poly_ends, strict=True)],
        [paths[a:b] for a, b in zip(path_starts, path_ends, strict=True)],
        steps,
    )


def warm_up() -> None:
    """Compile (or load from the cache) the objects walker before a bag's first message: an
    empty PredictedObjects message (stamp 0, frame_id "", no objects)."""
    fast_objects(b"\x00\x01\x00\x00" + bytes(8) + b"\x01\x00\x00\x00\x00" + bytes(3) + bytes(4))


def fast_trajectory(raw) -> TrajectoryRecord:
    stamp = header_stamp(raw)
    o = _align(_skip_string(raw, _BASE + 8), 4)
    (n,) = _U32.unpack_from(raw, o)
    o += 4
    if n * 88 > len(raw):
        raise DecodeError(f"claims {n} plan points in {len(raw)} bytes")
    tfs = np.empty(n, dtype=np.int64)
    pose = np.empty((n, 7))
    speed = np.empty(n)
    if n and (o + 8 - _BASE) % 8:  # the first point's pose is padded to 8 bytes, the rest not
        sec, nsec = _STAMP.unpack_from(raw, o)
        tfs[0] = sec * 1_000_000_000 + nsec
        pose[0] = _doubles(raw, o + 12, 7)
        (speed[0],) = _F32.unpack_from(raw, o + 68)
        o, first = o + 92, 1
    else:
        first = 0
    rest = np.frombuffer(raw, _TRAJ_POINT, n - first, o)
    tfs[first:] = rest["sec"].astype(np.int64) * 1_000_000_000 + rest["nsec"]
    pose[first:] = rest["pose"]
    speed[first:] = rest["speed"]
    return TrajectoryRecord(stamp, tfs, pose, speed)


FAST: dict[str, Callable[[Any], Record]] = {
    ODOMETRY: fast_odometry,
    OBJECTS: fast_objects,
    TRAJECTORY: fast_trajectory,
}


def decode_fast(raw, msgtype: str) -> Record:
    """Decode with the layout-specific reader; any inconsistency is a `DecodeError`."""
    if bytes(raw[:2]) != _CDR_LE:
        raise DecodeError(f"not little-endian CDR (encapsulation {bytes(raw[:4]).hex()})")
    try:
        return FAST[msgtype](raw)
    except (struct.error, ValueError, IndexError) as exc:
        if isinstance(exc, DecodeError):
            raise
        raise DecodeError(f"the bytes end or break inside the message ({exc})") from None


# -- the generic path: rosbags objects, read by field name ------------------------------------


def _pose(p) -> list[float]:
    return [
        p.position.x,
        p.position.y,
        p.position.z,
        p.orientation.x,
        p.orientation.y,
        p.orientation.z,
        p.orientation.w,
    ]


def _ns(t) -> int:
    return int(t.sec) * 1_000_000_000 + int(t.nanosec)


def generic_record(msg, msgtype: str) -> Record:
    """The record of an already deserialised rosbags message (AttributeError when a field the
    reader needs is missing from the bag's definition)."""
    if msgtype == ODOMETRY:
        lin, ang = msg.twist.twist.linear, msg.twist.twist.angular
        return OdometryRecord(
            _ns(msg.header.stamp), np.array(_pose(msg.pose.pose)), np.array([lin.x, lin.y, ang.z])
        )
    if msgtype == TRAJECTORY:
        pts = msg.points
        return TrajectoryRecord(
            _ns(msg.header.stamp),
            np.array([_ns(p.time_from_start) for p in pts], dtype=np.int64),
            np.array([_pose(p.pose) for p in pts], dtype=float).reshape(len(pts), 7),
            np.array([p.longitudinal_velocity_mps for p in pts], dtype=float),
        )
    objs = msg.objects
    k = len(objs)
    rec = ObjectsRecord(
        _ns(msg.header.stamp),
        [],
        np.empty((k, 7)),
        np.empty((k, 3)),
        np.zeros(k, dtype=np.int64),
        np.empty(k, dtype=np.int64),
        np.empty((k, 3)),
        [],
        [],
        np.zeros(k, dtype=np.int64),
    )
    for i, ob in enumerate(objs):
        rec.uuids.append(bytes(np.asarray(ob.object_id.uuid, dtype=np.uint8)))
        if len(ob.classification):
            rec.label[i] = ob.classification[
                _first_best(np.array([c.probability for c in ob.classification], dtype=float))
            ].label
        kin = ob.kinematics
        rec.pose[i] = _pose(kin.initial_pose_with_covariance.pose)
        twist = kin.initial_twist_with_covariance.twist
        rec.twist[i] = (twist.linear.x, twist.linear.y, twist.angular.z)
        paths = [p for p in kin.predicted_paths if len(p.path)]
        if paths:
            top = max(range(len(paths)), key=lambda j: _rank(paths[j].confidence))
            rec.paths.append(np.array([_pose(p) for p in paths[top].path], dtype=float))
            rec.steps[i] = _ns(paths[top].time_step)
        else:
            rec.paths.append(np.zeros((0, 7)))
        rec.shape[i] = ob.shape.type
        rec.footprints.append(
            np.array([[p.x, p.y] for p in ob.shape.footprint.points], dtype=float).reshape(-1, 2)
        )
        d = ob.shape.dimensions
        rec.dims[i] = (d.x, d.y, d.z)
    return rec
