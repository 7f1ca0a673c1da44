"""The fast CDR reader (`decode_fast`) against rosbags' deserialiser read by field name
(`generic_record`), on random messages of the three types casewatch reads; a few messages whose
decoded values are worked out by hand (stamps, the plan's first-point padding); and what the
fast reader does with bytes that are not a whole message (always `DecodeError`)."""

from __future__ import annotations

import contextlib
import dataclasses
import struct

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from casewatch.monitor.bags.decode import (
    DecodeError,
    ObjectsRecord,
    OdometryRecord,
    TrajectoryRecord,
    decode_fast,
    generic_record,
    header_stamp,
)
from casewatch.monitor.bags.types import OBJECTS, ODOMETRY, TRAJECTORY, base_typestore

STORE = base_typestore()
T = STORE.types
SETTINGS = settings(
    max_examples=80,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)

# -- building rosbags messages ------------------------------------------------------------------


def _time(sec: int, nanosec: int):
    return T["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec)


def _duration(sec: int, nanosec: int):
    return T["builtin_interfaces/msg/Duration"](sec=sec, nanosec=nanosec)


def _header(sec: int, nanosec: int, frame_id: str):
    return T["std_msgs/msg/Header"](stamp=_time(sec, nanosec), frame_id=frame_id)


def _vec(x: float, y: float, z: float):
    return T["geometry_msgs/msg/Vector3"](x=float(x), y=float(y), z=float(z))


def _pose(v) -> object:
    """A Pose from 7 numbers: x, y, z, qx, qy, qz, qw (the records' pose order)."""
    v = [float(a) for a in v]
    return T["geometry_msgs/msg/Pose"](
        position=T["geometry_msgs/msg/Point"](x=v[0], y=v[1], z=v[2]),
        orientation=T["geometry_msgs/msg/Quaternion"](x=v[3], y=v[4], z=v[5], w=v[6]),
    )


def _twist(v) -> object:
    return T["geometry_msgs/msg/Twist"](linear=_vec(*v[:3]), angular=_vec(*v[3:6]))


def _object(
    uuid: bytes,
    existence: float,
    classes,
    pose7,
    cov3,
    twist6,
    accel6,
    paths,
    shape_type: int,
    points,
    dims,
) -> object:
    """A PredictedObject; `classes` are (label, probability), `paths` (poses (n, 7), (sec,
    nanosec), confidence), `points` (n, 3) float32 polygon points."""
    accel = T["geometry_msgs/msg/Accel"](linear=_vec(*accel6[:3]), angular=_vec(*accel6[3:]))
    return T["autoware_perception_msgs/msg/PredictedObject"](
        object_id=T["unique_identifier_msgs/msg/UUID"](uuid=np.frombuffer(uuid, np.uint8).copy()),
        existence_probability=float(existence),
        classification=[
            T["autoware_perception_msgs/msg/ObjectClassification"](
                label=int(label), probability=float(p)
            )
            for label, p in classes
        ],
        kinematics=T["autoware_perception_msgs/msg/PredictedObjectKinematics"](
            initial_pose_with_covariance=T["geometry_msgs/msg/PoseWithCovariance"](
                pose=_pose(pose7), covariance=np.asarray(cov3[0], dtype=np.float64)
            ),
            initial_twist_with_covariance=T["geometry_msgs/msg/TwistWithCovariance"](
                twist=_twist(twist6), covariance=np.asarray(cov3[1], dtype=np.float64)
            ),
            initial_acceleration_with_covariance=T["geometry_msgs/msg/AccelWithCovariance"](
                accel=accel, covariance=np.asarray(cov3[2], dtype=np.float64)
            ),
            predicted_paths=[
                T["autoware_perception_msgs/msg/PredictedPath"](
                    path=[_pose(p) for p in poses],
                    time_step=_duration(*step),
                    confidence=float(conf),
                )
                for poses, step, conf in paths
            ],
        ),
        shape=T["autoware_perception_msgs/msg/Shape"](
            type=shape_type,
            footprint=T["geometry_msgs/msg/Polygon"](
                points=[
                    T["geometry_msgs/msg/Point32"](x=float(p[0]), y=float(p[1]), z=float(p[2]))
                    for p in points
                ]
            ),
            dimensions=_vec(*dims),
        ),
    )


def _plan_point(tfs: tuple[int, int], pose7, floats6) -> object:
    f = [float(a) for a in floats6]
    return T["autoware_planning_msgs/msg/TrajectoryPoint"](
        time_from_start=_duration(*tfs),
        pose=_pose(pose7),
        longitudinal_velocity_mps=f[0],
        lateral_velocity_mps=f[1],
        acceleration_mps2=f[2],
        heading_rate_rps=f[3],
        front_wheel_angle_rad=f[4],
        rear_wheel_angle_rad=f[5],
    )


# -- strategies ---------------------------------------------------------------------------------

F64 = st.floats(allow_nan=False, allow_infinity=False)
F32 = st.floats(width=32, allow_nan=False, allow_infinity=False)  # exact in a float32 field
SEC = st.integers(0, 2_000_000_000)
NSEC = st.integers(0, 999_999_999)
DURATION_SEC = st.integers(-(2**31), 2**31 - 1)  # Duration.sec is a signed int32
# Any text without NUL (a CDR string ends at its NUL); non-ASCII characters take 2-4 UTF-8
# bytes, so the byte length, and with it every later alignment, varies more than the length.
FRAME_ID = st.text(st.characters(codec="utf-8", exclude_characters="\x00"), max_size=20)
COV = arrays(np.float64, 36, elements=F64)  # drawn sparsely (a fill value plus a few others)


def _rows(n_max: int, width: int, elements=F64, dtype=np.float64, min_n: int = 0):
    """(n, width) arrays with every element drawn (no fill value: neighbouring values differ,
    so a reader that is off by one field would be seen)."""
    return st.integers(min_n, n_max).flatmap(
        lambda n: arrays(dtype, (n, width), elements=elements, fill=st.nothing())
    )


POSE7 = arrays(np.float64, 7, elements=F64, fill=st.nothing())
SIX = arrays(np.float64, 6, elements=F64, fill=st.nothing())


@st.composite
def odometries(draw):
    return T[ODOMETRY](
        header=_header(draw(SEC), draw(NSEC), draw(FRAME_ID)),
        child_frame_id=draw(FRAME_ID),
        pose=T["geometry_msgs/msg/PoseWithCovariance"](
            pose=_pose(draw(POSE7)), covariance=draw(COV)
        ),
        twist=T["geometry_msgs/msg/TwistWithCovariance"](
            twist=_twist(draw(SIX)), covariance=draw(COV)
        ),
    )


@st.composite
def predicted_objects(draw):
    objs = []
    for _ in range(draw(st.integers(0, 6))):
        classes = draw(st.lists(st.tuples(st.integers(0, 11), F32), max_size=3))
        paths = draw(
            st.lists(st.tuples(_rows(12, 7), st.tuples(DURATION_SEC, NSEC), F32), max_size=3)
        )
        objs.append(
            _object(
                draw(st.binary(min_size=16, max_size=16)),
                draw(F32),
                classes,
                draw(POSE7),
                [draw(COV), draw(COV), draw(COV)],
                draw(SIX),
                draw(SIX),
                paths,
                draw(st.sampled_from([0, 1, 2])),
                draw(_rows(6, 3, F32, np.float32)),
                draw(arrays(np.float64, 3, elements=F64, fill=st.nothing())),
            )
        )
    return T[OBJECTS](header=_header(draw(SEC), draw(NSEC), draw(FRAME_ID)), objects=objs)


@st.composite
def trajectories(draw):
    n = draw(st.integers(0, 40))
    poses = draw(arrays(np.float64, (n, 7), elements=F64, fill=st.nothing()))
    floats = draw(arrays(np.float32, (n, 6), elements=F32))
    times = draw(st.lists(st.tuples(DURATION_SEC, NSEC), min_size=n, max_size=n))
    points = [_plan_point(times[i], poses[i], floats[i]) for i in range(n)]
    return T[TRAJECTORY](header=_header(draw(SEC), draw(NSEC), draw(FRAME_ID)), points=points)


STRATEGIES = {ODOMETRY: odometries(), OBJECTS: predicted_objects(), TRAJECTORY: trajectories()}
ANY_MESSAGE = st.sampled_from(sorted(STRATEGIES)).flatmap(
    lambda t: STRATEGIES[t].map(lambda m: (t, m))
)


# -- comparing records --------------------------------------------------------------------------


def assert_same_record(fast, generic) -> None:
    """Field by field, exactly: arrays by value, shape and dtype; lists element-wise."""
    assert type(fast) is type(generic)
    for field in dataclasses.fields(fast):
        a, b = getattr(fast, field.name), getattr(generic, field.name)
        if isinstance(b, np.ndarray):
            assert isinstance(a, np.ndarray), field.name
            np.testing.assert_array_equal(a, b, strict=True, err_msg=field.name)
        elif isinstance(b, list):
            assert isinstance(a, list), field.name
            assert len(a) == len(b), field.name
            for i, (x, y) in enumerate(zip(a, b, strict=True)):
                if isinstance(y, np.ndarray):
                    np.testing.assert_array_equal(x, y, strict=True, err_msg=f"{field.name}[{i}]")
                else:
                    assert type(x) is type(y) and x == y, f"{field.name}[{i}]: {x!r} != {y!r}"
        else:
            assert a == b, f"{field.name}: {a!r} != {b!r}"


def _both(msg, msgtype: str):
    raw = STORE.serialize_cdr(msg, msgtype)
    generic = generic_record(STORE.deserialize_cdr(raw, msgtype), msgtype)
    return raw, generic


# -- 1. property tests: the fast reader agrees with the generic one ------------------------------


@SETTINGS
@given(odometries())
def test_odometry_fast_equals_generic(msg):
    raw, generic = _both(msg, ODOMETRY)
    assert_same_record(decode_fast(bytes(raw), ODOMETRY), generic)  # bytes, as the reader passes
    assert_same_record(decode_fast(raw, ODOMETRY), generic)  # and a memoryview


@SETTINGS
@given(predicted_objects())
def test_objects_fast_equals_generic(msg):
    raw, generic = _both(msg, OBJECTS)
    assert_same_record(decode_fast(bytes(raw), OBJECTS), generic)
    assert_same_record(decode_fast(raw, OBJECTS), generic)


@SETTINGS
@given(trajectories())
def test_trajectory_fast_equals_generic(msg):
    raw, generic = _both(msg, TRAJECTORY)
    assert_same_record(decode_fast(bytes(raw), TRAJECTORY), generic)
    assert_same_record(decode_fast(raw, TRAJECTORY), generic)


@SETTINGS
@given(ANY_MESSAGE)
def test_header_stamp_reads_the_stamp(typed):
    msgtype, msg = typed
    raw = STORE.serialize_cdr(msg, msgtype)
    stamp = msg.header.stamp
    assert header_stamp(bytes(raw)) == stamp.sec * 1_000_000_000 + stamp.nanosec


# -- 2. hand-computed messages ------------------------------------------------------------------

ZERO36 = np.zeros(36)


def _odometry(sec: int, nanosec: int, frame_id: str = "map", child: str = "base_link"):
    return T[ODOMETRY](
        header=_header(sec, nanosec, frame_id),
        child_frame_id=child,
        pose=T["geometry_msgs/msg/PoseWithCovariance"](
            pose=_pose([1.5, -2.25, 0.125, 0.0, 0.0, 0.6, 0.8]), covariance=np.arange(36.0)
        ),
        twist=T["geometry_msgs/msg/TwistWithCovariance"](
            twist=_twist([3.5, -0.5, 0.25, 0.01, 0.02, 0.03]), covariance=-np.arange(36.0)
        ),
    )


def test_odometry_by_hand():
    raw = bytes(STORE.serialize_cdr(_odometry(12, 345), ODOMETRY))
    assert header_stamp(raw) == 12_000_000_345
    rec = decode_fast(raw, ODOMETRY)
    assert isinstance(rec, OdometryRecord)
    assert rec.stamp == 12_000_000_345
    assert rec.pose.tolist() == [1.5, -2.25, 0.125, 0.0, 0.0, 0.6, 0.8]
    assert rec.twist.tolist() == [3.5, -0.5, 0.03]  # linear x, y; angular z (yaw rate)


def _plan(frame_id: str):
    points = [
        _plan_point((0, 0), [10.0, 20.0, 0.5, 0.0, 0.0, 0.1, 0.9], [5.5, 0.25, -1.0, 0, 0, 0]),
        _plan_point(
            (0, 500_000_000), [11.0, 21.0, 0.5, 0.0, 0.0, 0.2, 0.8], [6.0, 0.5, -2.0, 1, 2, 3]
        ),
        _plan_point((3, 7), [-12.0, 22.5, 1.5, 0.3, 0.1, 0.2, 0.7], [-0.75, 0, 0, 0, 0, 0]),
    ]
    return T[TRAJECTORY](header=_header(7, 8, frame_id), points=points)


# Where the first plan point's pose lands, counting offsets from the end of the 4-byte
# encapsulation header (CDR aligns relative to there): stamp at 0..8, frame_id's length (uint32)
# at 8..12, its L bytes plus the NUL end at 13 + L, the point count is aligned to 4 and takes 4
# bytes, so the first point (its time_from_start, two 4-byte ints) starts at
# p = align4(13 + L) + 4 and its pose (float64, aligned to 8) at p + 8, with 4 bytes of padding
# first when p % 8 == 4. L = 0..3 gives p = 20 (padded), 4..7 p = 24 (not), 8..11 p = 28
# (padded), 12..15 p = 32 (not): padded exactly when L // 4 is even ("map", "base_link": padded;
# "odom", "world": not). Later points are 88 bytes, a multiple of 8, so only the first point can
# be padded.
def _first_point(frame_id: str) -> tuple[int, bool]:
    n = len(frame_id.encode())
    p = -(-(13 + n) // 4) * 4 + 4
    return p, p % 8 == 4


@pytest.mark.parametrize(
    ("frame_id", "padded"),
    [
        ("", True),
        ("map", True),
        ("odom", False),
        ("base_link", True),
        ("world", False),
        ("map_origin_x", False),
    ],
)
def test_trajectory_first_point_padding(frame_id, padded):
    p, pad = _first_point(frame_id)
    assert pad == padded  # the parametrisation covers both cases
    raw = bytes(STORE.serialize_cdr(_plan(frame_id), TRAJECTORY))
    # the bytes confirm the reasoning: total size, and x of the first pose where we said it is
    assert len(raw) == 4 + p + (4 if padded else 0) + 3 * 88
    assert struct.unpack_from("<d", raw, 4 + p + 8 + (4 if padded else 0)) == (10.0,)
    rec = decode_fast(raw, TRAJECTORY)
    assert isinstance(rec, TrajectoryRecord)
    assert rec.stamp == 7_000_000_008
    assert rec.time_from_start.tolist() == [0, 500_000_000, 3_000_000_007]
    assert rec.pose.tolist() == [
        [10.0, 20.0, 0.5, 0.0, 0.0, 0.1, 0.9],
        [11.0, 21.0, 0.5, 0.0, 0.0, 0.2, 0.8],
        [-12.0, 22.5, 1.5, 0.3, 0.1, 0.2, 0.7],
    ]
    assert rec.speed.tolist() == [5.5, 6.0, -0.75]


def test_trajectory_padding_cases_both_occur():
    """Across frame_id lengths 0..20 (the property tests' range) both layouts occur."""
    assert {_first_point("x" * n)[1] for n in range(21)} == {True, False}


def _simple_object(
    label_probs,
    paths,
    pose7=(1.0, 2.0, 0.0, 0.0, 0.0, 0.0, 1.0),
    shape_type=0,
    points=(),
    uuid=bytes(range(16)),
):
    return _object(
        uuid,
        1.0,
        label_probs,
        pose7,
        [ZERO36] * 3,
        [4.0, -1.0, 0, 0, 0, 0.5],
        [0.0] * 6,
        paths,
        shape_type,
        np.asarray(points, np.float32).reshape(-1, 3),
        (4.5, 1.8, 1.5),
    )


def test_objects_by_hand():
    """Most probable class and most confident non-empty path, the first on ties."""
    path_a = np.array([[1.0, 2.0, 0, 0, 0, 0, 1], [2.0, 2.0, 0, 0, 0, 0, 1]])
    path_b = np.array([[1.0, 2.0, 0, 0, 0, 0, 1], [1.0, 3.0, 0, 0, 0, 0, 1]])
    objs = [
        _simple_object(
            [(1, 0.25), (7, 0.5), (2, 0.5)],  # tie at 0.5: pedestrian (7), first
            [
                (np.zeros((0, 7)), (9, 0), 1.0),  # empty, ignored however confident
                (path_a, (0, 100_000_000), 0.75),
                (path_b, (0, 200_000_000), 0.75),
            ],
        ),  # tie: path_a, first
        _simple_object(
            [],
            [],
            shape_type=2,
            points=[[0.5, 0.25, 9.0], [-0.5, 0.25, 9.0], [0.0, -0.75, 9.0]],
            uuid=b"\xff" * 16,
        ),
    ]
    raw = bytes(STORE.serialize_cdr(T[OBJECTS](header=_header(5, 6, "map"), objects=objs), OBJECTS))
    rec = decode_fast(raw, OBJECTS)
    assert isinstance(rec, ObjectsRecord)
    assert rec.stamp == 5_000_000_006
    assert rec.uuids == [bytes(range(16)), b"\xff" * 16]
    assert rec.label.tolist() == [7, 0]  # no classification: 0 (unknown)
    assert rec.pose.tolist() == [[1.0, 2.0, 0.0, 0.0, 0.0, 0.0, 1.0]] * 2
    assert rec.twist.tolist() == [[4.0, -1.0, 0.5]] * 2
    assert rec.shape.tolist() == [0, 2]
    assert rec.dims.tolist() == [[4.5, 1.8, 1.5]] * 2
    assert rec.footprints[0].shape == (0, 2)
    assert rec.footprints[1].tolist() == [[0.5, 0.25], [-0.5, 0.25], [0.0, -0.75]]
    assert rec.paths[0].tolist() == path_a.tolist()
    assert rec.paths[1].shape == (0, 7)
    assert rec.steps.tolist() == [100_000_000, 0]
    assert_same_record(rec, generic_record(STORE.deserialize_cdr(raw, OBJECTS), OBJECTS))


@pytest.mark.parametrize("classified", [False, True])
@pytest.mark.parametrize("count", [1, 2, 3, 5, 20])
def test_objects_without_predictions_decode(count, classified):
    """Objects with no predicted path and a box shape, as `casewatch convert` writes an object
    whose prediction is empty. On the wire such an object takes 1080 bytes (1084 when it starts
    4 bytes off an 8-byte boundary) plus 8 per classification: 16 uuid + 4 existence + 4 count,
    (pad) 1016 kinematics (127 float64), 4 path count, 1 type + 3 pad + 4 point count, (pad)
    24 dimensions. The writer gives it one class: 1088 bytes."""
    objs = [_simple_object([(1, 1.0)] if classified else [], []) for _ in range(count)]
    raw = bytes(STORE.serialize_cdr(T[OBJECTS](header=_header(5, 6, "map"), objects=objs), OBJECTS))
    generic = generic_record(STORE.deserialize_cdr(raw, OBJECTS), OBJECTS)
    assert_same_record(decode_fast(raw, OBJECTS), generic)


@pytest.mark.parametrize(
    ("conf", "prob"),
    [
        ((-np.inf, -np.inf), (0.5, 0.25)),
        ((np.nan, 0.5), (0.5, 0.25)),
        ((0.5, np.nan), (0.5, 0.25)),
        ((0.5, 0.25), (np.nan, 0.5)),
        ((0.5, 0.25), (0.5, np.nan)),
        ((0.5, 0.25), (-np.inf, -np.inf)),
    ],
)
def test_non_finite_confidence_and_probability_agree(conf, prob):
    """Confidences and probabilities a float32 field can hold but the definitions do not mean
    (NaN, -inf): whatever is picked, both readers pick the same path and class."""
    p = np.array([[1.0, 2.0, 0, 0, 0, 0, 1]])
    q = np.array([[5.0, 6.0, 0, 0, 0, 0, 1]])
    obj = _simple_object(
        [(3, prob[0]), (7, prob[1])], [(p, (0, 100), conf[0]), (q, (0, 200), conf[1])]
    )
    raw = bytes(
        STORE.serialize_cdr(T[OBJECTS](header=_header(5, 6, "map"), objects=[obj]), OBJECTS)
    )
    generic = generic_record(STORE.deserialize_cdr(raw, OBJECTS), OBJECTS)
    assert_same_record(decode_fast(raw, OBJECTS), generic)


# -- 3. bytes that are not a whole message ------------------------------------------------------


def _sample_objects():
    path = np.array([[1.0, 2.0, 0, 0, 0, 0, 1], [2.0, 2.0, 0, 0, 0, 0, 1]])
    return T[OBJECTS](
        header=_header(5, 6, "map"),
        objects=[
            _simple_object([(1, 0.9)], [(path, (0, 100_000_000), 1.0)]),
            _simple_object([(7, 0.9)], [], shape_type=2, points=[[0, 0, 0], [1, 0, 0], [0, 1, 0]]),
        ],
    )


SAMPLES = {ODOMETRY: _odometry(12, 345), OBJECTS: _sample_objects(), TRAJECTORY: _plan("map")}


@pytest.mark.parametrize("msgtype", sorted(SAMPLES))
@pytest.mark.parametrize("cut", ["half", "ten"])
def test_truncated_raises_decode_error(msgtype, cut):
    raw = bytes(STORE.serialize_cdr(SAMPLES[msgtype], msgtype))
    decode_fast(raw, msgtype)  # whole, it decodes
    short = raw[: len(raw) // 2] if cut == "half" else raw[:10]
    with pytest.raises(DecodeError):
        decode_fast(short, msgtype)


@SETTINGS
@given(ANY_MESSAGE, st.data())
def test_any_truncation_raises_decode_error(typed, data):
    """Every proper prefix of a message fails whole (CDR messages carry no trailing padding,
    so every byte is read): never a partial record, never another exception type."""
    msgtype, msg = typed
    raw = bytes(STORE.serialize_cdr(msg, msgtype))
    cut = data.draw(st.integers(0, len(raw) - 1), label="cut")
    with pytest.raises(DecodeError):
        decode_fast(raw[:cut], msgtype)


@SETTINGS
@given(ANY_MESSAGE, st.data())
def test_corrupt_bytes_raise_only_decode_error(typed, data):
    """Overwriting bytes after the encapsulation header (counts, lengths, values) gives a
    record or a `DecodeError`, nothing else."""
    msgtype, msg = typed
    raw = bytearray(STORE.serialize_cdr(msg, msgtype))
    for _ in range(data.draw(st.integers(1, 4), label="edits")):
        at = data.draw(st.integers(4, len(raw) - 1), label="at")
        value = data.draw(st.binary(min_size=1, max_size=4), label="value")
        raw[at : at + len(value)] = value[: len(raw) - at]
    with contextlib.suppress(DecodeError):
        decode_fast(bytes(raw), msgtype)


@pytest.mark.parametrize("msgtype", sorted(SAMPLES))
def test_big_endian_raises_decode_error(msgtype):
    big = bytes(STORE.serialize_cdr(SAMPLES[msgtype], msgtype, little_endian=False))
    assert big[:2] == b"\x00\x00"
    with pytest.raises(DecodeError, match="little-endian"):
        decode_fast(big, msgtype)
    # a little-endian message relabelled big-endian: refused on the label alone
    little = bytes(STORE.serialize_cdr(SAMPLES[msgtype], msgtype))
    with pytest.raises(DecodeError, match="little-endian"):
        decode_fast(b"\x00\x00" + little[2:], msgtype)


def _count_offset(frame_id: str) -> int:
    """Where the first sequence count after the header sits in the bytes: encapsulation (4),
    stamp (8), frame_id length (4) and bytes with NUL, aligned to 4 from after the header."""
    return 4 + -(-(13 + len(frame_id.encode())) // 4) * 4


@pytest.mark.parametrize("msgtype", [OBJECTS, TRAJECTORY])
@pytest.mark.parametrize("count", [2**32 - 1, 2**31, 1_000_000, "one more"])
def test_huge_count_raises_decode_error(msgtype, count):
    msg = SAMPLES[msgtype]
    n = len(msg.objects if msgtype == OBJECTS else msg.points)
    raw = bytearray(STORE.serialize_cdr(msg, msgtype))
    at = _count_offset("map")
    assert struct.unpack_from("<I", raw, at) == (n,)  # the offset is right
    struct.pack_into("<I", raw, at, n + 1 if count == "one more" else count)
    with pytest.raises(DecodeError):
        decode_fast(bytes(raw), msgtype)


def test_header_stamp_of_short_bytes():
    with pytest.raises(DecodeError):
        header_stamp(b"\x00\x01\x00\x00" + b"\x00" * 7)
