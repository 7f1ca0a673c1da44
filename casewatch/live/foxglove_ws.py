"""`run --foxglove [HOST:]PORT`: the annotated recording's topics, live, to Foxglove.

The Foxglove SDK's WebSocket server (foxglove-sdk, its own Rust thread) publishes while judging
the same topics, schemas and messages `casewatch annotate` writes into an MCAP file
(`/casewatch/log`, `/casewatch/status`, `/casewatch/markers`, `/casewatch/scene/CHANNEL`;
docs/live.md), so Foxglove's "Open connection" shows a drive as it is judged exactly as it
later shows the annotated recording. Messages are built only for topics a Foxglove client has
subscribed to (`Channel.has_sinks`), so an idle server costs the judge nothing but a check.
Markers: a sphere and label where the ego was (the first channel's estimate) at the first tick
of each episode, published at its onset and removed when it closes, as the annotated file's.
"""

from __future__ import annotations

import json
from collections import deque
from typing import Any

from foxglove_schemas_protobuf.Log_pb2 import Log
from foxglove_schemas_protobuf.SceneEntity_pb2 import SceneEntity
from foxglove_schemas_protobuf.SceneEntityDeletion_pb2 import SceneEntityDeletion
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
from foxglove_schemas_protobuf.SpherePrimitive_pb2 import SpherePrimitive
from foxglove_schemas_protobuf.TextPrimitive_pb2 import TextPrimitive
from mcap_protobuf.schema import build_file_descriptor_set

from casewatch.annotate import foxglove as fx
from casewatch.annotate.scene import CHANNEL_COLOURS, SCENE_TOPIC, channel_entities
from casewatch.annotate.verdicts import (
    HAZARD_COLOUR,
    LOG_TOPIC,
    MARKER_TOPIC,
    SPI_COLOUR,
    STATUS_SCHEMA,
    STATUS_SCHEMA_NAME,
    STATUS_TOPIC,
    Timebase,
    log_message,
    status_value,
)
from casewatch.evaluator.eventlog import event_record
from casewatch.evaluator.result import Episode, EpisodeOpen
from casewatch.live.address import ServeAddress

#: Ego positions kept for placing markers: a minute at 10 Hz (an onset is announced once its
#: episode lasted min_duration, so its first tick is that long ago).
TRACK_TICKS = 600


class FoxgloveLive:
    """A Foxglove WebSocket server publishing one run's casewatch topics as it is judged."""

    def __init__(self, channels: list[str], root: str, period: float, address: ServeAddress):
        import foxglove

        self._foxglove = foxglove
        self.context = foxglove.Context()
        self.server = foxglove.start_server(
            name="casewatch", host=address.host, port=address.port, context=self.context
        )
        self.url = f"ws://{address.url(self.server.port)[7:]}"
        self.root = root
        self.period = period
        self.time = Timebase()  # stream time to log time, as the annotated file has it
        self._first_tick = True
        self.log = self._protobuf(LOG_TOPIC, Log)
        self.markers = self._protobuf(MARKER_TOPIC, SceneUpdate)
        self.status = foxglove.Channel(
            STATUS_TOPIC,
            schema=foxglove.Schema(
                name=STATUS_SCHEMA_NAME,
                encoding="jsonschema",
                data=json.dumps(STATUS_SCHEMA).encode(),
            ),
            message_encoding="json",
            context=self.context,
        )
        self.scenes = {
            c: self._protobuf(SCENE_TOPIC.format(channel=c), SceneUpdate) for c in channels
        }
        self.hues = {c: CHANNEL_COLOURS[i % len(CHANNEL_COLOURS)] for i, c in enumerate(channels)}
        # the ego's recent positions (t, x, y), to place a marker at its episode's first tick
        self._track: deque[tuple[float, float, float]] = deque(maxlen=TRACK_TICKS)
        self._pending: list[tuple[EpisodeOpen, int]] = []  # onsets awaiting this tick's position

    def _protobuf(self, topic: str, message_class: Any) -> Any:
        schema = self._foxglove.Schema(
            name=message_class.DESCRIPTOR.full_name,
            encoding="protobuf",
            data=build_file_descriptor_set(message_class).SerializeToString(),
        )
        return self._foxglove.Channel(
            topic, schema=schema, message_encoding="protobuf", context=self.context
        )

    def on_tick(self, frame: Any, statuses: Any, evaluator: Any, reader: Any) -> None:
        """After each judged frame: the statuses, and each channel's scene when watched."""
        if self._first_tick:  # a bag's frames count from its first tick at meta.t0_unix_ns
            self._first_tick = False
            t0 = reader.header.meta.get("t0_unix_ns") if reader.header is not None else None
            if isinstance(t0, int):
                self.time = Timebase(t0)
        ns = self.time.ns(frame.t)
        first = next(iter(frame.channels.values()), None)
        if first is not None:
            self._track.append((frame.t, first.ego.x, first.ego.y))
        for event, at in self._pending:  # announced while this frame was judged
            if self._track:
                self.markers.log(self._marker(event, at).SerializeToString(), log_time=at)
        self._pending.clear()
        if self.status.has_sinks():
            value = status_value(round(frame.t, 6), statuses, self.root)
            self.status.log(json.dumps(value, separators=(",", ":")), log_time=ns)
        for channel, state in frame.channels.items():
            publisher = self.scenes.get(channel)
            if publisher is not None and publisher.has_sinks():
                entities = channel_entities(state, ns, 2 * self.period, self.hues[channel])
                publisher.log(SceneUpdate(entities=entities).SerializeToString(), log_time=ns)

    def on_event(self, event: Any) -> None:
        """Every event as a log line; onsets and closes as markers."""
        record = event_record(event)
        ns, line = log_message(record, self.time)
        self.log.log(line.SerializeToString(), log_time=ns)
        if isinstance(event, EpisodeOpen):
            self._pending.append((event, ns))  # placed once this tick's position is known
        elif isinstance(event, Episode):
            gone = SceneEntityDeletion(
                timestamp=fx.timestamp(ns),
                type=SceneEntityDeletion.MATCHING_ID,
                id=f"open-{event.formula_id}",
            )
            self.markers.log(SceneUpdate(deletions=[gone]).SerializeToString(), log_time=ns)

    def _position(self, t: float) -> tuple[float, float]:
        """The ego's position at the last tick at or before `t` (the oldest kept if earlier)."""
        place = self._track[0]
        for tick in self._track:
            if tick[0] > t + 1e-9:
                break
            place = tick
        return place[1], place[2]

    def _marker(self, event: EpisodeOpen, ns: int) -> SceneUpdate:
        x, y = self._position(event.start)
        hue = HAZARD_COLOUR if event.kind == "hazard" else SPI_COLOUR
        what = "hazard" if event.kind == "hazard" else "SPI"
        entity = SceneEntity(
            timestamp=fx.timestamp(ns),
            frame_id=fx.WORLD_FRAME,
            id=f"open-{event.formula_id}",
            spheres=[
                SpherePrimitive(
                    pose=fx.pose(x, y, 1.0), size=fx.size(3, 3, 3), color=fx.color(hue, 0.6)
                )
            ],
            texts=[
                TextPrimitive(
                    pose=fx.pose(x, y, 4.0),
                    billboard=True,
                    font_size=14.0,
                    scale_invariant=True,
                    color=fx.color(hue),
                    text=f"{event.node_id} {what} from {event.start:.1f} s",
                )
            ],
            metadata=fx.metadata(node_id=event.node_id, kind=event.kind, start=event.start),
        )
        return SceneUpdate(entities=[entity])

    def stop(self) -> None:
        self.server.stop()
