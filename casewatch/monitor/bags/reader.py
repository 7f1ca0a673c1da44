"""Reading a ROS 2 bag (MCAP or sqlite3, a bag folder or a bare storage file) as frames.

The bag is read once, in order, with memory bounded by `max_delay`: ticks lie on the case's
period (on the absolute clock, so two bags of one drive tick together), and tick `T` is built
once messages stamped `T + max_delay` have been seen, from the latest message of every mapped
topic stamped at or before `T` and at most `max_age` old. Anything older or absent is a
dropout of that channel at that tick, never a reused value (docs/bags.md).

The reader has `StreamReader`'s surface (`header`, `defects`, `dropouts`, `frames_read`,
`channels`, `period`), so the evaluator judges a bag exactly as it judges JSON Lines.
"""

from __future__ import annotations

import bisect
import math
import struct
from collections.abc import Iterator
from dataclasses import dataclass
from dataclasses import field as _field
from functools import lru_cache
from pathlib import Path
from typing import cast

import numpy as np
from rosbags.serde import SerdeError
from rosbags.typesys import Stores, get_types_from_idl, get_types_from_msg, get_typestore
from rosbags.typesys.base import TypesysError
from rosbags.typesys.store import Typestore

from casewatch.errors import CasewatchError
from casewatch.monitor.bags.assemble import RecordDefect, ego_state, objects_state, plan_state
from casewatch.monitor.bags.decode import (
    DecodeError,
    ObjectsRecord,
    OdometryRecord,
    Record,
    TrajectoryRecord,
    decode_fast,
    generic_record,
    header_stamp,
)
from casewatch.monitor.bags.decode import warm_up as warm_up_decoder
from casewatch.monitor.bags.mapping import LoadedMapping, TopicMapping
from casewatch.monitor.bags.storage import (
    BagTopic,
    McapScan,
    RosbagsStorage,
    StorageBreak,
    StorageError,
    open_storage,
)
from casewatch.monitor.bags.types import ROLE_TYPES, base_typestore, field_layout
from casewatch.monitor.frames import ChannelState, Coverage, Frame, Header, box_footprint
from casewatch.monitor.reader import StreamDefect, keep_defect

#: A message stamped this much later than every channel message before it is a `bad-stamp`
#: defect, not a tick an hour ahead (ticks in between would all be built): a stack on another
#: clock (simulation time against wall time) would otherwise make billions of empty ticks.
MAX_JUMP_NS = 3600 * 1_000_000_000

#: The plan of a channel whose plan topic had nothing fresh: plan metrics then have no value.
_NO_PLAN = np.zeros((0, 3))


class BagError(CasewatchError, ValueError):
    """A bag that cannot be read with this mapping (the message says why and what to do)."""


@dataclass
class _Message:
    stamp: int
    number: int  # position among the mapped topics' messages, 1-based
    raw: bytes
    topic: str
    record: Record | None = None
    bad: bool = False


@dataclass
class _Topic:
    """A mapped topic: its connection, decoder, age limit and the messages still usable."""

    name: str
    role: str
    msgtype: str
    max_age_ns: int
    fast: bool
    field: str = "data"
    buffer: list[_Message] = _field(default_factory=list)
    stamps: list[int] = _field(default_factory=list)
    late: int = 0
    missing: int = 0

    def add(self, msg: _Message) -> None:
        i = bisect.bisect_right(self.stamps, msg.stamp)
        self.stamps.insert(i, msg.stamp)
        self.buffer.insert(i, msg)

    def pick(self, tick: int) -> _Message | None:
        """The latest message stamped in `(tick - max_age, tick]`; older ones are dropped (no
        later tick can want them). With max_age one period, a message serves one tick."""
        i = bisect.bisect_right(self.stamps, tick) - 1
        if i < 0:
            return None
        if i > 0:
            del self.stamps[:i]
            del self.buffer[:i]
        msg = self.buffer[0]
        return msg if tick - msg.stamp < self.max_age_ns else None


class BagReader:
    """Iterate to get frames (see the module docstring). Opening checks the mapping against
    the bag and raises `BagError`; problems with single messages become defects."""

    #: The defect kinds a bag can have (docs/bags.md documents each).
    DEFECT_KINDS = (
        "bad-message",
        "bad-stamp",
        "late-message",
        "truncated-bag",
        "non-finite",
        "out-of-range",
        "bad-trajectory",
        "bad-footprint",
        "duplicate-id",
    )

    def __init__(
        self,
        path: str | Path,
        mapping: LoadedMapping,
        channels: list[str] | None = None,
        period: float = 0.1,
        strict: bool = False,
    ):
        self.path = Path(path)
        self.name = str(path)
        self.strict = strict
        self.mapping: TopicMapping = mapping.mapping
        self.mapping_source = mapping.source
        self.period = period
        self.channels = list(channels) if channels is not None else list(self.mapping.channels)
        self._check_channels()
        self.defects: list[StreamDefect] = []
        self.dropouts: dict[str, int] = {c: 0 for c in self.channels}
        self.frames_read = 0
        self.origin_ns: int | None = None
        self.header = Header(
            channels=list(self.channels),
            period=period,
            meta={"source": "rosbag2", **self.mapping.meta},
            coverage={
                c: Coverage(v.fov_deg, v.range_m or math.inf)
                for c, v in self.mapping.coverage.items()
            },
        )
        self._started = False
        self._footprint = box_footprint(self.mapping.ego.length, self.mapping.ego.width)
        self._bag = self._open()
        self._topics = self._connect()
        # compiled (or loaded from numba's cache) here, not in monitor.warmup: a live stream
        # never needs it, and its start-up is what a live monitor waits for
        warm_up_decoder()

    # -- opening --------------------------------------------------------------------------

    def _check_channels(self) -> None:
        mapped = list(self.mapping.channels)
        extra = [c for c in mapped if c not in self.channels]
        if extra:
            raise BagError(
                f"{self.mapping_source}: channel(s) {', '.join(extra)} are not "
                f"channels of the case (monitor.channels: {', '.join(self.channels)})"
            )
        absent = [c for c in self.channels if c not in mapped]
        if absent:
            raise BagError(
                f"{self.mapping_source}: the case's channel(s) {', '.join(absent)} "
                "have no topics; map them under channels: (odometry, objects, plan)"
            )

    def _open(self) -> RosbagsStorage | McapScan:
        try:
            bag = open_storage(self.path)
        except StorageError as exc:
            raise BagError(f"{self.name}: {exc}") from None
        mcap = self.path.suffix == ".mcap" or (self.path.is_dir() and any(self.path.glob("*.mcap")))
        self.header.meta["storage"] = "mcap" if mcap else "sqlite3"
        return bag

    def _connect(self) -> dict[str, _Topic]:
        """Check every mapped topic against the bag and choose its decoder."""
        conns = self._bag.topics
        roles = self.mapping.topics()
        missing = [t for t in roles if t not in conns]
        if missing:
            have = "\n".join(f"  {c.topic}  ({c.msgtype})" for c in conns.values()) or "  (none)"
            self._bag.close()
            if self._bag.recovered:
                raise BagError(
                    f"{self.name}: the MCAP file is cut short before it names "
                    f"topic(s) {', '.join(missing)}; what it holds:\n{have}"
                )
            raise BagError(
                f"{self.name}: topic(s) {', '.join(missing)} from {self.mapping_source}"
                f" are not in the bag; it has:\n{have}"
            )
        self._check_roles(conns)  # before the definitions are parsed: the clearest message
        store = self._typestore([conns[t] for t in roles])
        base = base_typestore()
        topics: dict[str, _Topic] = {}
        for ch in self.mapping.channels.values():
            for role in ("odometry", "objects", "plan"):
                ref = getattr(ch, role)
                if ref is None:
                    continue
                conn = conns[ref.topic]
                want = ROLE_TYPES[role]
                if conn.msgtype != want:
                    self._bag.close()
                    raise BagError(
                        f"{self.name}: topic {ref.topic} carries {conn.msgtype}; as "
                        f"the {role} of a channel it must carry {want}"
                    )
                fast = field_layout(store, want) == field_layout(base, want)
                topics[ref.topic] = _Topic(
                    ref.topic, role, want, _ns(self.mapping.age_limit(ref, self.period)), fast
                )
        for sig in self.mapping.signals.values():
            conn = conns[sig.topic]
            topics[sig.topic] = _Topic(
                sig.topic,
                "signal",
                conn.msgtype,
                _ns(self.mapping.age_limit(sig, self.period)),
                False,
                sig.field,
            )
        self._store = store
        return topics

    def _check_roles(self, conns: dict[str, BagTopic]) -> None:
        """Every channel topic carries the type its role needs (an older `autoware_auto_*` or a
        Humble `TrackedObjects` is named as such, not as a definition that does not parse)."""
        for ch in self.mapping.channels.values():
            for role in ("odometry", "objects", "plan"):
                ref = getattr(ch, role)
                if ref is None:
                    continue
                have, want = conns[ref.topic].msgtype, ROLE_TYPES[role]
                if have != want:
                    self._bag.close()
                    old = (
                        " (the older autoware_auto_* messages are not read: record with "
                        "autoware_msgs 1.x, or convert the bag)"
                        if "autoware_auto" in have
                        else ""
                    )
                    raise BagError(
                        f"{self.name}: topic {ref.topic} carries {have}; as the "
                        f"{role} of a channel it must carry {want}{old}"
                    )

    def _typestore(self, conns: list[BagTopic]) -> Typestore:
        """The shipped types, overridden by the definitions the bag carries for its topics."""
        try:
            store = typestore_for(
                tuple((c.msgtype, c.definition_format, c.definition) for c in conns)
            )
        except (TypesysError, ValueError, IndexError) as exc:
            self._bag.close()
            named = ", ".join(
                sorted({f"{c.msgtype} (topic {c.topic})" for c in conns if c.definition})
            )
            raise BagError(
                f"{self.name}: the bag's message definitions cannot be parsed "
                f"({exc}); defined in the bag: {named}"
            ) from None
        for c in conns:
            if c.msgtype not in store.fielddefs:
                self._bag.close()
                raise BagError(
                    f"{self.name}: topic {c.topic} carries {c.msgtype}, an unknown "
                    "message type: the bag has no definition of it and casewatch "
                    "ships none (it reads nav_msgs/Odometry, autoware_perception_msgs"
                    "/PredictedObjects and autoware_planning_msgs/Trajectory)"
                )
        return store

    # -- reading --------------------------------------------------------------------------

    def _defect(self, number: int, kind: str, message: str) -> None:
        keep_defect(self.defects, self.strict, StreamDefect(number, kind, message, self.name))

    def __iter__(self) -> Iterator[Frame]:
        if self._started:
            raise RuntimeError("a BagReader can be iterated once")
        self._started = True
        try:
            yield from self._frames()
        finally:
            self._bag.close()

    def _frames(self) -> Iterator[Frame]:
        period = _ns(self.period)
        delay = _ns(self.mapping.max_delay)
        receive = self.mapping.time == "receive"
        topics = self._topics
        tick: int | None = None
        newest: int | None = None  # the latest stamp seen on a channel topic
        number = 0
        messages = self._bag.messages(list(topics))
        if self._bag.recovered:
            self.header.meta["recovered"] = "read record by record: the MCAP file has no end"
        while True:
            try:
                item = next(messages, None)
            except StorageBreak as exc:
                self._defect(
                    number + 1,
                    "truncated-bag",
                    f"the bag breaks off after message "
                    f"{number} ({exc}); the frames before were judged, nothing after "
                    "could be read",
                )
                break
            if item is None:
                break
            name, logtime, raw = item
            number += 1
            topic = topics[name]
            if receive or topic.role == "signal":
                stamp = logtime
            else:
                try:
                    stamp = header_stamp(raw)
                except DecodeError as exc:
                    self._defect(number, "bad-message", f"{name}: {exc}")
                    continue
                if stamp <= 0:
                    self._defect(
                        number,
                        "bad-stamp",
                        f"{name}: header stamp {stamp} ns "
                        "is not a time (time: receive uses the recording time)",
                    )
                    continue
                if newest is not None and stamp - newest > MAX_JUMP_NS:
                    self._defect(
                        number,
                        "bad-stamp",
                        f"{name}: stamped {(stamp - newest) / 1e9:g}"
                        " s after every message before it: a stack on another clock? "
                        "(time: receive aligns on the recording time)",
                    )
                    continue
            if tick is not None and tick > (self.origin_ns or 0) and stamp <= tick - period:
                topic.late += 1  # a tick it belonged to was built without it
            topic.add(_Message(stamp, number, bytes(raw), name))
            if topic.role == "signal":
                continue
            if tick is None:
                tick = -(-stamp // period) * period  # the first tick on the absolute grid
                self.origin_ns = tick
                self.header.meta["t0_unix_ns"] = tick
            newest = stamp if newest is None else max(newest, stamp)
            while tick + delay <= newest:
                yield self._frame(tick)
                tick += period
        if tick is not None and newest is not None:
            while tick <= newest:
                yield self._frame(tick)
                tick += period
        for t in topics.values():
            if t.late:
                self._defect(
                    0,
                    "late-message",
                    f"{t.name}: {t.late} message(s) arrived more "
                    f"than max_delay ({self.mapping.max_delay:g} s) after later stamps;"
                    " ticks built before they arrived went without them",
                )

    def _frame(self, tick: int) -> Frame:
        channels: dict[str, ChannelState] = {}
        footprint = self._footprint
        for name in self.channels:
            ch = self.mapping.channels[name]
            odom = self._take(ch.odometry.topic, tick)
            objs = self._take(ch.objects.topic, tick)
            plan = self._take(ch.plan.topic, tick) if ch.plan is not None else None
            state = None
            if odom is not None and objs is not None:
                try:
                    at_tick = self.mapping.poses_at_tick
                    ego = ego_state(
                        cast(OdometryRecord, odom.record),
                        footprint,
                        odom.stamp,
                        tick,
                        at_tick,
                    )
                    objects = objects_state(
                        cast(ObjectsRecord, objs.record),
                        objs.stamp,
                        tick,
                        at_tick,
                    )
                    planned = (
                        plan_state(
                            cast(TrajectoryRecord, plan.record),
                            plan.stamp,
                            tick,
                            self.mapping.plan_time,
                        )
                        if plan is not None
                        else _NO_PLAN
                    )
                    state = ChannelState(ego=ego, plan=planned, objects=objects)
                except RecordDefect as d:
                    self._defect(
                        self.frames_read + 1,
                        d.kind,
                        f"tick t = "
                        f"{(tick - (self.origin_ns or 0)) / 1e9:g} s, channel {name}: "
                        f"{d.message}",
                    )
            if state is None:
                self.dropouts[name] += 1
            else:
                channels[name] = state
        signals: dict[str, float | None] = {}
        for sname, sig in self.mapping.signals.items():
            msg = self._take(sig.topic, tick)
            signals[sname] = None if msg is None else msg.record  # type: ignore[assignment]
        self.frames_read += 1
        t = (tick - (self.origin_ns or tick)) / 1e9
        return Frame(t=t, channels=channels, signals=signals, line=self.frames_read)

    def _take(self, name: str, tick: int) -> _Message | None:
        """The message of topic `name` for this tick, decoded (None: stale, absent or bad)."""
        topic = self._topics[name]
        msg = topic.pick(tick)
        if msg is None:
            topic.missing += 1
            return None
        if msg.record is None and not msg.bad:
            try:
                msg.record = self._decode(topic, msg.raw)  # type: ignore[assignment]
            except (
                DecodeError,
                SerdeError,
                AttributeError,
                TypeError,
                ValueError,
                struct.error,
                IndexError,
            ) as exc:
                msg.bad = True
                self._defect(
                    msg.number,
                    "bad-message",
                    f"{name} (stamp {msg.stamp} ns): cannot decode {topic.msgtype}: {exc}",
                )
        if msg.bad:
            topic.missing += 1
            return None
        return msg

    def _decode(self, topic: _Topic, raw: bytes):
        if topic.role == "signal":
            value: object = self._store.deserialize_cdr(raw, topic.msgtype)
            for part in topic.field.split("."):
                value = getattr(value, part)
            if isinstance(value, bool):
                return 1.0 if value else 0.0
            if not isinstance(value, int | float):
                raise DecodeError(f"field {topic.field} is {type(value).__name__}, not a number")
            return float(value)
        if topic.fast:
            return decode_fast(raw, topic.msgtype)
        return generic_record(self._store.deserialize_cdr(raw, topic.msgtype), topic.msgtype)

    def topic_report(self) -> dict[str, dict[str, int]]:
        """Per mapped topic: ticks it was missing or stale for, and late messages."""
        return {
            t.name: {"missing_ticks": t.missing, "late_messages": t.late}
            for t in self._topics.values()
        }


@lru_cache(maxsize=16)
def typestore_for(definitions: tuple[tuple[str, str, str], ...]) -> Typestore:
    """The shipped types overridden by a bag's own (message type, 'msg'/'idl'/'', text)
    definitions; built once per set of definitions (a fleet of one stack's bags shares it)."""
    types = dict(base_typestore().fielddefs)
    for msgtype, fmt, text in definitions:
        if fmt == "msg" and text:
            types.update(get_types_from_msg(text, msgtype))
        elif fmt == "idl" and text:
            for part in text.split("=" * 80 + "\n"):
                body = part.split("\n", 1)[1] if part.startswith("IDL: ") else part
                # rosbag2 writes each IDL with its `#include` lines, which rosbags' parser
                # refuses; the included types are in the same text or shipped, so drop them
                body = "\n".join(
                    line for line in body.splitlines() if not line.lstrip().startswith("#")
                )
                if body.strip():
                    types.update(get_types_from_idl(body))
    store = get_typestore(Stores.EMPTY)
    store.register(types)
    return store


def _ns(seconds: float) -> int:
    return round(seconds * 1e9)


def read_bag(
    path: str | Path,
    mapping: LoadedMapping,
    channels: list[str] | None = None,
    period: float = 0.1,
    strict: bool = False,
) -> BagReader:
    """Open a bag for reading as frames (raises `BagError` when it cannot be read with this
    mapping). Nothing is decoded until you iterate."""
    return BagReader(path, mapping, channels=channels, period=period, strict=strict)
