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
from dataclasses import dataclass

import numpy as np

from monitor.bags.types import OBJECTS, ODOMETRY, TRAJECTORY

#: Autoware `ObjectClassification.label` -> casewatch object class.
CLASS_NAMES: dict[int, str] = {
    0: "unknown", 1: "car", 2: "truck", 3: "bus", 4: "trailer", 5: "motorcycle", 6: "bicycle",
    7: "pedestrian", 8: "animal", 9: "hazard", 10: "over_drivable", 11: "under_drivable",
}  # fmt: skip

#: `Shape.type` values.
BOUNDING_BOX, CYLINDER, POLYGON = 0, 1, 2


class DecodeError(ValueError):
    """A message whose bytes do not hold what its type promises (truncated, corrupt)."""


@dataclass(slots=True)
class OdometryRecord:
    """`nav_msgs/Odometry`: stamp (ns), pose (7: x, y, z, qx, qy, qz, qw) in the map frame,
    twist (2: linear x, y) in the body frame (`child_frame_id`)."""

    stamp: int
    pose: np.ndarray
    twist: np.ndarray


@dataclass(slots=True)
class ObjectsRecord:
    """`PredictedObjects`, one row per object.

    `pose` (K, 7) map frame; `twist` (K, 2) linear x, y in the object's frame; `label` (K,) the
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
_TRAJ_POINT = np.dtype([("sec", "<i4"), ("nsec", "<u4"), ("pose", "<f8", (7,)),
                        ("speed", "<f4"), ("rest", "<f4", (5,))])  # fmt: skip


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
    return OdometryRecord(stamp, values[:7].copy(), values[43:45].copy())


def fast_objects(raw) -> ObjectsRecord:
    stamp = header_stamp(raw)
    o = _align(_skip_string(raw, _BASE + 8), 4)
    (k,) = _U32.unpack_from(raw, o)
    o += 4
    if k * 1080 > len(raw):  # an object takes at least 1080 bytes (its covariances alone 1016)
        raise DecodeError(f"claims {k} objects in {len(raw)} bytes")
    uuids: list[bytes] = []
    pose = np.empty((k, 7))
    twist = np.empty((k, 2))
    label = np.zeros(k, dtype=np.int64)
    shape = np.empty(k, dtype=np.int64)
    dims = np.empty((k, 3))
    footprints: list[np.ndarray] = []
    paths: list[np.ndarray] = []
    steps = np.zeros(k, dtype=np.int64)
    buf = memoryview(raw)
    for i in range(k):
        uuids.append(bytes(buf[o : o + 16]))
        o = _align(o + 16, 4) + 4  # existence_probability
        (ncls,) = _U32.unpack_from(raw, o)
        o += 4
        if ncls:
            items = np.frombuffer(raw, np.dtype([("label", "u1"), ("pad", "V3"), ("p", "<f4")]),
                                  ncls, o)  # fmt: skip
            label[i] = items["label"][_first_best(items["p"])]
            o += 8 * ncls
        o = _align(o, 8)
        kin = _doubles(raw, o, 127)
        pose[i] = kin[:7]
        twist[i] = kin[43:45]
        o = _align(o + 127 * 8, 4)
        (npaths,) = _U32.unpack_from(raw, o)
        o += 4
        best, best_conf, best_step = None, -np.inf, 0
        for _ in range(npaths):
            (n,) = _U32.unpack_from(raw, _align(o, 4))
            o = _align(o, 4) + 4
            poses = None
            if n:
                o = _align(o, 8)
                poses = _doubles(raw, o, 7 * n).reshape(n, 7)
                o += 56 * n
            o = _align(o, 4)
            sec, nsec = _STAMP.unpack_from(raw, o)
            (conf,) = _F32.unpack_from(raw, o + 8)
            o += 12
            conf = _rank(conf)
            if poses is not None and (best is None or conf > best_conf):
                best, best_conf, best_step = poses, conf, sec * 1_000_000_000 + nsec
        paths.append(np.zeros((0, 7)) if best is None else best)
        steps[i] = best_step
        shape[i] = raw[o]
        o = _align(o + 1, 4)
        (npts,) = _U32.unpack_from(raw, o)
        o += 4
        footprints.append(np.frombuffer(raw, "<f4", 3 * npts, o).reshape(npts, 3)[:, :2]
                          .astype(float))  # fmt: skip
        o = _align(o + 12 * npts, 8)
        dims[i] = _doubles(raw, o, 3)
        o += 24
    return ObjectsRecord(stamp, uuids, pose, twist, label, shape, dims, footprints, paths, steps)


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


FAST = {ODOMETRY: fast_odometry, OBJECTS: fast_objects, TRAJECTORY: fast_trajectory}


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
    return [p.position.x, p.position.y, p.position.z,
            p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w]  # fmt: skip


def _ns(t) -> int:
    return int(t.sec) * 1_000_000_000 + int(t.nanosec)


def generic_record(msg, msgtype: str) -> Record:
    """The record of an already deserialised rosbags message (AttributeError when a field the
    reader needs is missing from the bag's definition)."""
    if msgtype == ODOMETRY:
        lin = msg.twist.twist.linear
        return OdometryRecord(_ns(msg.header.stamp), np.array(_pose(msg.pose.pose)),
                              np.array([lin.x, lin.y]))  # fmt: skip
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
    rec = ObjectsRecord(_ns(msg.header.stamp), [], np.empty((k, 7)), np.empty((k, 2)),
                        np.zeros(k, dtype=np.int64), np.empty(k, dtype=np.int64),
                        np.empty((k, 3)), [], [], np.zeros(k, dtype=np.int64))  # fmt: skip
    for i, ob in enumerate(objs):
        rec.uuids.append(bytes(np.asarray(ob.object_id.uuid, dtype=np.uint8)))
        if len(ob.classification):
            rec.label[i] = ob.classification[_first_best(np.array(
                [c.probability for c in ob.classification], dtype=float))].label
        kin = ob.kinematics
        rec.pose[i] = _pose(kin.initial_pose_with_covariance.pose)
        lin = kin.initial_twist_with_covariance.twist.linear
        rec.twist[i] = (lin.x, lin.y)
        paths = [p for p in kin.predicted_paths if len(p.path)]
        if paths:
            top = max(range(len(paths)), key=lambda j: _rank(paths[j].confidence))
            rec.paths.append(np.array([_pose(p) for p in paths[top].path], dtype=float))
            rec.steps[i] = _ns(paths[top].time_step)
        else:
            rec.paths.append(np.zeros((0, 7)))
        rec.shape[i] = ob.shape.type
        rec.footprints.append(np.array([[p.x, p.y] for p in ob.shape.footprint.points],
                                       dtype=float).reshape(-1, 2))  # fmt: skip
        d = ob.shape.dimensions
        rec.dims[i] = (d.x, d.y, d.z)
    return rec
