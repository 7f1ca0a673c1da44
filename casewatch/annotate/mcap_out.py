"""An MCAP file being written: Foxglove protobuf channels, JSON channels and copied ones.

The `mcap` writer keeps schemas and channels as numbered records; this keeps one number per
topic so each writer of messages (the verdicts, the scene, the copied recording) only names a
topic and a time. Protobuf schemas are registered as the FileDescriptorSet Foxglove reads
(`mcap_protobuf.schema.register_schema`), so every casewatch topic opens in Foxglove with its
published schema (foxglove.Log, foxglove.SceneUpdate).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, BinaryIO

from mcap.well_known import MessageEncoding, SchemaEncoding
from mcap.writer import CompressionType, Writer
from mcap_protobuf.schema import register_schema

#: The MCAP profile field: empty for a recording without ROS messages, as the spec asks.
PROFILE = ""


class McapOut:
    """One MCAP file open for writing; `close()` writes its summary and footer."""

    def __init__(self, path: Path, profile: str = PROFILE) -> None:
        path.parent.mkdir(parents=True, exist_ok=True)
        self._fh: BinaryIO = open(path, "wb")  # noqa: SIM115  (closed by close())
        self._writer = Writer(self._fh, compression=CompressionType.ZSTD)
        self._writer.start(profile=profile, library="casewatch annotate")
        self._channels: dict[str, int] = {}
        self._sequence: dict[int, int] = {}
        self.counts: dict[str, int] = {}

    def protobuf_topic(self, topic: str, message_class: type) -> None:
        """Declare `topic` as carrying `message_class` (a generated protobuf class)."""
        if topic in self._channels:
            return
        schema_id = register_schema(self._writer, message_class)
        self._channels[topic] = self._writer.register_channel(
            topic=topic, message_encoding=MessageEncoding.Protobuf, schema_id=schema_id
        )

    def json_topic(self, topic: str, schema_name: str, schema: dict[str, Any]) -> None:
        """Declare `topic` as carrying JSON messages described by a JSON Schema."""
        if topic in self._channels:
            return
        schema_id = self._writer.register_schema(
            name=schema_name,
            encoding=SchemaEncoding.JSONSchema,
            data=json.dumps(schema).encode(),
        )
        self._channels[topic] = self._writer.register_channel(
            topic=topic, message_encoding=MessageEncoding.JSON, schema_id=schema_id
        )

    def raw_topic(
        self,
        topic: str,
        message_encoding: str,
        metadata: dict[str, str],
        schema: tuple[str, str, bytes] | None,
    ) -> None:
        """Declare a topic copied from a recording, with its schema (name, encoding, data)."""
        if topic in self._channels:
            return
        schema_id = 0
        if schema is not None:
            name, encoding, data = schema
            schema_id = self._writer.register_schema(name=name, encoding=encoding, data=data)
        self._channels[topic] = self._writer.register_channel(
            topic=topic, message_encoding=message_encoding, schema_id=schema_id, metadata=metadata
        )

    def write(
        self, topic: str, log_time: int, data: bytes, publish_time: int | None = None
    ) -> None:
        """One message on a declared topic at `log_time` (ns since the Unix epoch)."""
        channel_id = self._channels[topic]
        sequence = self._sequence.get(channel_id, 0)
        self._sequence[channel_id] = sequence + 1
        self._writer.add_message(
            channel_id=channel_id,
            log_time=log_time,
            publish_time=log_time if publish_time is None else publish_time,
            data=data,
            sequence=sequence,
        )
        self.counts[topic] = self.counts.get(topic, 0) + 1

    def message(self, topic: str, log_time: int, message: Any) -> None:
        """A protobuf message, serialised, on a topic declared with `protobuf_topic`."""
        self.write(topic, log_time, message.SerializeToString())

    def json(self, topic: str, log_time: int, value: dict[str, Any]) -> None:
        """A JSON message on a topic declared with `json_topic`."""
        self.write(topic, log_time, json.dumps(value, separators=(",", ":")).encode())

    def metadata(self, name: str, data: dict[str, str]) -> None:
        self._writer.add_metadata(name=name, data=data)

    def close(self) -> None:
        self._writer.finish()
        self._fh.close()
