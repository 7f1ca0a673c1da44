"""Writing frames as a ROS 2 bag with Autoware messages (MCAP or sqlite3), through rosbags.

What `casewatch convert drive.jsonl.gz -o drive.mcap` runs, and how the test suite and
`make bench` make bags from the bundled drives. Every message is stamped at its frame's time
(`t0_unix_ns + t`) and recorded at that time, so reading the bag back gives the same frames;
a channel missing from a frame (a dropout) writes no message for it.

Lossy only where Autoware's messages cannot say what a frame says: a prediction is written on
one time step (`PredictedPath.time_step`), so a prediction with uneven or delayed times is
resampled linearly onto that step from its first time; an ego polygon is written as the
mapping's box. A prediction that starts after dt = 0 gets the object's position as its first
pose, as the metrics read it anyway. Object ids become UUIDs holding the id's UTF-8 bytes
(ids longer than 16 bytes: their first 16 bytes of sha256).
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Iterable
from pathlib import Path

import numpy as np
from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer, WriterError

from casewatch.errors import CasewatchError
from casewatch.monitor.bags.decode import CLASS_NAMES
from casewatch.monitor.bags.mapping import TopicMapping
from casewatch.monitor.bags.types import OBJECTS, ODOMETRY, TRAJECTORY, base_typestore
from casewatch.monitor.frames import ChannelState, Coverage, Frame, Objects, unpadded

#: Class name -> Autoware label.
LABELS = {name: label for label, name in CLASS_NAMES.items()}

#: Default start of a written bag's clock: 2026-01-01 00:00:00 UTC (a multiple of any period
#: that divides a second, so ticks fall on the frames).
DEFAULT_T0_NS = 1_767_225_600 * 1_000_000_000


class BagWriteError(CasewatchError, ValueError):
    """The bag cannot be written (the target exists, a signal is not mapped...)."""


def default_mapping(
    channels: list[str],
    signals: list[str],
    length: float,
    width: float,
    coverage: dict[str, Coverage] | None = None,
    period: float | None = None,
) -> dict:
    """Autoware-style topic names for each channel (`/<channel>/localization/kinematic_state`
    ...), as the plain mapping `casewatch convert` writes beside a bag it makes; `coverage`
    (a stream header's) is carried over, since a bag has no place for it. With `period`, the
    mapping's `max_age` is that period: a bag stamped exactly on its frames' ticks (as
    `write_bag` stamps) then reads back with the stream's dropouts, none bridged."""
    sight = {
        c: {"fov_deg": v.fov_deg, **({} if math.isinf(v.range_m) else {"range_m": v.range_m})}
        for c, v in (coverage or {}).items()
    }
    return {
        "ego": {"length": length, "width": width},
        "channels": {
            c: {
                "odometry": f"/{c}/localization/kinematic_state",
                "objects": f"/{c}/perception/object_recognition/objects",
                "plan": f"/{c}/planning/scenario_planning/trajectory",
            }
            for c in channels
        },
        "signals": {s: f"/casewatch/signals/{s}" for s in signals},
        **({"coverage": sight} if sight else {}),
        **({"max_age": period} if period is not None else {}),
    }


class MessageBuilder:
    """rosbags message objects of the shipped types, built from frame values (the writer's
    and the tests' way to make Autoware messages)."""

    def __init__(self) -> None:
        self.store = base_typestore()
        t = self.store.types
        self.T = t

    def stamp(self, ns: int):
        return self.T["builtin_interfaces/msg/Time"](
            sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000
        )

    def duration(self, ns: int):
        return self.T["builtin_interfaces/msg/Duration"](
            sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000
        )

    def header(self, ns: int):
        return self.T["std_msgs/msg/Header"](stamp=self.stamp(ns), frame_id="map")

    def pose(self, x: float, y: float, yaw: float):
        T = self.T
        return T["geometry_msgs/msg/Pose"](
            position=T["geometry_msgs/msg/Point"](x=float(x), y=float(y), z=0.0),
            orientation=T["geometry_msgs/msg/Quaternion"](
                x=0.0, y=0.0, z=float(np.sin(yaw / 2)), w=float(np.cos(yaw / 2))
            ),
        )

    def vector(self, x: float = 0.0, y: float = 0.0):
        return self.T["geometry_msgs/msg/Vector3"](x=float(x), y=float(y), z=0.0)

    def odometry(self, ns: int, state: ChannelState):
        T = self.T
        e = state.ego
        c, s = np.cos(e.yaw), np.sin(e.yaw)
        body = (c * e.vx + s * e.vy, -s * e.vx + c * e.vy)  # the twist goes in the body frame
        cov = np.zeros(36)
        return T[ODOMETRY](
            header=self.header(ns),
            child_frame_id="base_link",
            pose=T["geometry_msgs/msg/PoseWithCovariance"](
                pose=self.pose(e.x, e.y, e.yaw), covariance=cov
            ),
            twist=T["geometry_msgs/msg/TwistWithCovariance"](
                twist=T["geometry_msgs/msg/Twist"](
                    linear=self.vector(*body), angular=self.vector()
                ),
                covariance=cov,
            ),
        )

    def trajectory(self, ns: int, plan: np.ndarray):
        T = self.T
        n = len(plan)
        if n:
            d = np.diff(plan[:, 1:], axis=0)
            heading = np.arctan2(d[:, 1], d[:, 0]) if n > 1 else np.zeros(0)
            yaw = np.concatenate([heading, heading[-1:]]) if n > 1 else np.zeros(1)
            ds = np.hypot(d[:, 0], d[:, 1])
            speed = np.concatenate([ds / np.diff(plan[:, 0]), [0.0]]) if n > 1 else np.zeros(1)
        points = [
            T["autoware_planning_msgs/msg/TrajectoryPoint"](
                time_from_start=self.duration(round(plan[i, 0] * 1e9)),
                pose=self.pose(plan[i, 1], plan[i, 2], yaw[i]),
                longitudinal_velocity_mps=float(speed[i]),
                lateral_velocity_mps=0.0,
                acceleration_mps2=0.0,
                heading_rate_rps=0.0,
                front_wheel_angle_rad=0.0,
                rear_wheel_angle_rad=0.0,
            )
            for i in range(n)
        ]
        return T[TRAJECTORY](header=self.header(ns), points=points)

    def objects(self, ns: int, objs: Objects):
        T = self.T
        cov = np.zeros(36)
        out = []
        for i in range(len(objs)):
            yaw = float(objs.yaw[i])
            c, s = np.cos(yaw), np.sin(yaw)
            vx, vy = objs.vel[i]
            body = (c * vx + s * vy, -s * vx + c * vy)
            half = objs.half[i]
            if np.isnan(half[0]):
                shape = T["autoware_perception_msgs/msg/Shape"](
                    type=2,
                    footprint=T["geometry_msgs/msg/Polygon"](
                        points=[
                            T["geometry_msgs/msg/Point32"](x=float(p[0]), y=float(p[1]), z=0.0)
                            for p in unpadded(objs.footprints[i])
                        ]
                    ),
                    dimensions=self.vector(),
                )
            else:
                size = T["geometry_msgs/msg/Vector3"](
                    x=float(2 * half[0]), y=float(2 * half[1]), z=1.5
                )
                shape = T["autoware_perception_msgs/msg/Shape"](
                    type=0, footprint=T["geometry_msgs/msg/Polygon"](points=[]), dimensions=size
                )
            paths = []
            n = int(objs.pred_len[i])
            if n:
                step_ns, xy = _on_one_step(objs.pred[i, :n], objs.pos[i])
                paths.append(
                    T["autoware_perception_msgs/msg/PredictedPath"](
                        path=[self.pose(p[0], p[1], yaw) for p in xy],
                        time_step=self.duration(step_ns),
                        confidence=1.0,
                    )
                )
            out.append(
                T["autoware_perception_msgs/msg/PredictedObject"](
                    object_id=T["unique_identifier_msgs/msg/UUID"](uuid=_uuid(objs.ids[i])),
                    existence_probability=1.0,
                    classification=[
                        T["autoware_perception_msgs/msg/ObjectClassification"](
                            label=LABELS.get(objs.cls[i], 0), probability=1.0
                        )
                    ],
                    kinematics=T["autoware_perception_msgs/msg/PredictedObjectKinematics"](
                        initial_pose_with_covariance=T["geometry_msgs/msg/PoseWithCovariance"](
                            pose=self.pose(objs.pos[i, 0], objs.pos[i, 1], yaw), covariance=cov
                        ),
                        initial_twist_with_covariance=T["geometry_msgs/msg/TwistWithCovariance"](
                            twist=T["geometry_msgs/msg/Twist"](
                                linear=self.vector(*body), angular=self.vector()
                            ),
                            covariance=cov,
                        ),
                        initial_acceleration_with_covariance=T[
                            "geometry_msgs/msg/AccelWithCovariance"
                        ](
                            accel=T["geometry_msgs/msg/Accel"](
                                linear=self.vector(), angular=self.vector()
                            ),
                            covariance=cov,
                        ),
                        predicted_paths=paths,
                    ),
                    shape=shape,
                )
            )
        return T[OBJECTS](header=self.header(ns), objects=out)

    def scalar(self, value: float):
        return self.T["std_msgs/msg/Float64"](data=float(value))


def _uuid(object_id: str) -> np.ndarray:
    data = object_id.encode()
    if len(data) > 16:
        data = hashlib.sha256(data).digest()[:16]
    return np.frombuffer(data.rjust(16, b"\0"), dtype=np.uint8).copy()


def _on_one_step(pred: np.ndarray, pos: np.ndarray) -> tuple[int, np.ndarray]:
    """A prediction `[dt, x, y]` as (time step in ns, points at 0, step, 2 step, ...).

    Autoware's first predicted pose is the object's pose now; a frame's prediction may start
    later, and the metrics then start it from the object's position (spi-reference,
    "Resampling"), so that position is written as the first pose: the same prediction."""
    if pred[0, 0] > 0:
        pred = np.concatenate([[[0.0, pos[0], pos[1]]], pred])
    if len(pred) == 1:
        return 0, pred[:, 1:]
    dt = pred[:, 0]
    step = float(np.median(np.diff(dt)))
    step_ns = round(step * 1e9)
    grid = np.arange(len(dt)) * step_ns / 1e9
    if dt[0] == 0.0 and np.allclose(dt, grid, rtol=0, atol=1e-6):
        return step_ns, pred[:, 1:]
    n = int(np.floor(dt[-1] / step + 1e-9)) + 1
    grid = np.arange(n) * step_ns / 1e9
    return step_ns, np.stack(
        [np.interp(grid, dt, pred[:, 1]), np.interp(grid, dt, pred[:, 2])], axis=1
    )


def write_bag(
    frames: Iterable[Frame],
    out: str | Path,
    mapping: TopicMapping,
    storage: str = "mcap",
    t0_ns: int = DEFAULT_T0_NS,
    compress: bool = False,
) -> int:
    """Write `frames` as a rosbag2 folder `out` (created; it must not exist). Returns the
    number of frames written. `storage` is `mcap` or `sqlite3`; `compress` zstd-compresses
    the chunks of an MCAP file (as `ros2 bag record --compression-mode storage` does)."""
    plugin = {"mcap": StoragePlugin.MCAP, "sqlite3": StoragePlugin.SQLITE3}[storage]
    if compress and storage != "mcap":
        raise BagWriteError("compression is written for MCAP storage only")
    build = MessageBuilder()
    store = build.store
    try:
        writer = Writer(Path(out), version=9, storage_plugin=plugin)
        if compress:
            writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
        writer.open()
    except WriterError as exc:
        raise BagWriteError(f"{out}: {exc}") from None
    count = 0
    try:
        conns = {}
        for name, ch in mapping.channels.items():
            conns[(name, "odometry")] = writer.add_connection(
                ch.odometry.topic, ODOMETRY, typestore=store
            )
            conns[(name, "objects")] = writer.add_connection(
                ch.objects.topic, OBJECTS, typestore=store
            )
            if ch.plan is not None:
                conns[(name, "plan")] = writer.add_connection(
                    ch.plan.topic, TRAJECTORY, typestore=store
                )
        for sname, sig in mapping.signals.items():
            conns[("signal", sname)] = writer.add_connection(
                sig.topic, "std_msgs/msg/Float64", typestore=store
            )
        for frame in frames:
            ns = t0_ns + round(frame.t * 1e9)
            for name, state in frame.channels.items():
                if (name, "odometry") not in conns:
                    raise BagWriteError(
                        f"frame t = {frame.t:g}: channel {name} is not in the topic mapping"
                    )
                messages = [
                    ("odometry", ODOMETRY, build.odometry(ns, state)),
                    ("objects", OBJECTS, build.objects(ns, state.objects)),
                ]
                if (name, "plan") in conns and len(state.plan):
                    messages.append(("plan", TRAJECTORY, build.trajectory(ns, state.plan)))
                for role, msgtype, msg in messages:
                    writer.write(conns[(name, role)], ns, store.serialize_cdr(msg, msgtype))
            for sname, value in frame.signals.items():
                if value is not None and ("signal", sname) in conns:
                    writer.write(
                        conns[("signal", sname)],
                        ns,
                        store.serialize_cdr(build.scalar(value), "std_msgs/msg/Float64"),
                    )
            count += 1
    finally:
        writer.close()
    return count
