"""Writing small bags with hand-chosen stamps and recording times, for the bag reader tests."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from rosbags.rosbag2 import StoragePlugin, Writer

from casewatch.monitor.bags.mapping import LoadedMapping, TopicMapping
from casewatch.monitor.bags.types import OBJECTS, ODOMETRY, TRAJECTORY
from casewatch.monitor.bags.writer import DEFAULT_T0_NS, MessageBuilder
from casewatch.monitor.frames import ChannelState, Ego, Objects, box_footprint

T0 = DEFAULT_T0_NS
MS = 1_000_000  # ns

TOPICS = {
    "odometry": "/lav/localization/kinematic_state",
    "objects": "/lav/perception/object_recognition/objects",
    "plan": "/lav/planning/scenario_planning/trajectory",
}


def mapping(with_plan: bool = False, **extra) -> LoadedMapping:
    """One channel, lav; its plan topic only `with_plan` (a mapped topic must be in the bag)."""
    topics = dict(TOPICS) if with_plan else {k: TOPICS[k] for k in ("odometry", "objects")}
    plain = {"ego": {"length": 4.0, "width": 2.0}, "channels": {"lav": topics}, **extra}
    return LoadedMapping(TopicMapping.model_validate(plain), "test-mapping")


def ego_state(x: float, vx: float = 10.0, yaw: float = 0.0, vy: float = 0.0) -> ChannelState:
    ego = Ego(x=x, y=0.0, yaw=yaw, vx=vx, vy=vy, footprint=box_footprint(4.0, 2.0))
    return ChannelState(ego=ego, plan=np.zeros((0, 3)), objects=Objects.empty())


def one_object(x: float, pred: np.ndarray | None = None) -> Objects:
    pred = np.zeros((1, 0, 3)) if pred is None else pred[None]
    return Objects(
        ids=["7"],
        cls=["car"],
        pos=np.array([[x, 3.0]]),
        yaw=np.zeros(1),
        vel=np.array([[5.0, 0.0]]),
        footprints=box_footprint(4.5, 1.8)[None],
        pred=pred,
        pred_len=np.array([pred.shape[1]]),
        convex=np.ones(1, bool),
        half=np.array([[2.25, 0.9]]),
    )


class BagKit:
    """Messages at chosen (stamp, recording time) pairs; `close()` writes the bag."""

    def __init__(self, path: Path, storage: str = "mcap"):
        plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
        self.build = MessageBuilder()
        self.store = self.build.store
        self.writer = Writer(path, version=9, storage_plugin=plugin)
        self.writer.open()
        self.conns: dict[str, object] = {}
        self.path = path

    def _conn(self, topic: str, msgtype: str, **kw):
        if topic not in self.conns:
            if kw:
                self.conns[topic] = self.writer.add_connection(topic, msgtype, **kw)
            else:
                self.conns[topic] = self.writer.add_connection(topic, msgtype, typestore=self.store)
        return self.conns[topic]

    def raw(self, topic: str, msgtype: str, raw: bytes, log_ns: int, **kw) -> None:
        self.writer.write(self._conn(topic, msgtype, **kw), log_ns, raw)

    def odometry(
        self,
        stamp_ms: float,
        x: float,
        log_ms: float | None = None,
        topic: str = TOPICS["odometry"],
    ) -> None:
        stamp = T0 + round(stamp_ms * MS)
        msg = self.build.odometry(stamp, ego_state(x))
        self.raw(
            topic,
            ODOMETRY,
            self.store.serialize_cdr(msg, ODOMETRY),
            T0 + round((stamp_ms if log_ms is None else log_ms) * MS),
        )

    def objects(
        self, stamp_ms: float, x: float, log_ms: float | None = None, pred: np.ndarray | None = None
    ) -> None:
        topic = TOPICS["objects"]
        stamp = T0 + round(stamp_ms * MS)
        msg = self.build.objects(stamp, one_object(x, pred))
        self.raw(
            topic,
            OBJECTS,
            self.store.serialize_cdr(msg, OBJECTS),
            T0 + round((stamp_ms if log_ms is None else log_ms) * MS),
        )

    def plan(self, stamp_ms: float, plan: np.ndarray, log_ms: float | None = None) -> None:
        stamp = T0 + round(stamp_ms * MS)
        msg = self.build.trajectory(stamp, plan)
        self.raw(
            TOPICS["plan"],
            TRAJECTORY,
            self.store.serialize_cdr(msg, TRAJECTORY),
            T0 + round((stamp_ms if log_ms is None else log_ms) * MS),
        )

    def scalar(self, topic: str, log_ms: float, value: float) -> None:
        self.raw(
            topic,
            "std_msgs/msg/Float64",
            self.store.serialize_cdr(self.build.scalar(value), "std_msgs/msg/Float64"),
            T0 + round(log_ms * MS),
        )

    def close(self) -> Path:
        self.writer.close()
        return self.path
