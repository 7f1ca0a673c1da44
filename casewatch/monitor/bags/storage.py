"""Where a bag's messages come from: rosbags for whole bags, an MCAP scan for cut-off ones.

rosbags reads rosbag2 folders, MCAP and sqlite3 files through their indexes, which live at the
end of an MCAP file. A recording cut short (the recorder killed, the disk full) has no end, and
rosbags refuses it; the `mcap` library's stream reader then reads the records from the start
up to the break, so the drive up to there can still be judged (the break is a defect).
"""

from __future__ import annotations

import sqlite3
import struct
from collections.abc import Iterator
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from rosbags.interfaces import MessageDefinitionFormat
from rosbags.rosbag2 import Reader, ReaderError

from casewatch.errors import CasewatchError

MCAP_MAGIC = b"\x89MCAP0\r\n"

#: What a broken storage file raises while its messages are read through rosbags.
#: rosbags' MCAP reader trusts the file's length fields: a damaged one gives TypeError (a file
#: that is only the magic), OverflowError or MemoryError (a huge length).
STORAGE_ERRORS = (
    ReaderError,
    sqlite3.DatabaseError,
    struct.error,
    EOFError,
    ValueError,
    KeyError,
    IndexError,
    OSError,
    TypeError,
    OverflowError,
    MemoryError,
)


class StorageError(CasewatchError, ValueError):
    """The storage cannot be opened at all (the message says why)."""


class StorageBreak(Exception):
    """The storage breaks off while its messages are read; what came before stands."""


@dataclass(frozen=True)
class BagTopic:
    """One topic of a bag: its message type and the definition the bag carries ('msg' or
    'idl' text; empty when the bag has none, as rosbag2 sqlite3 before Iron)."""

    topic: str
    msgtype: str
    definition_format: str
    definition: str
    count: int | None = None


class RosbagsStorage:
    """A whole bag, read through rosbags."""

    recovered = False

    def __init__(self, path: Path):
        self._reader = Reader(path)
        self._reader.open()
        self.topics: dict[str, BagTopic] = {}
        self._conns: dict[str, Any] = {}
        fmt = {MessageDefinitionFormat.MSG: "msg", MessageDefinitionFormat.IDL: "idl"}
        for c in self._reader.connections:
            if c.topic not in self.topics:
                self.topics[c.topic] = BagTopic(
                    c.topic,
                    c.msgtype,
                    fmt.get(c.msgdef.format, ""),
                    c.msgdef.data or "",
                    c.msgcount,
                )
            self._conns.setdefault(c.topic, []).append(c)

    def messages(self, topics: list[str]) -> Iterator[tuple[str, int, bytes]]:
        conns = [c for t in topics for c in self._conns.get(t, [])]
        try:
            for conn, logtime, raw in self._reader.messages(connections=conns):
                yield conn.topic, logtime, raw
        except STORAGE_ERRORS as exc:
            raise StorageBreak(f"{type(exc).__name__}: {exc}") from None

    def close(self) -> None:
        self._reader.close()


class McapScan:
    """An MCAP file read record by record from its start (no footer needed)."""

    recovered = True

    def __init__(self, path: Path):
        self.path = path
        self.topics: dict[str, BagTopic] = {}
        self._channels: dict[int, str] = {}
        schemas: dict[int, tuple[str, str, str]] = {}
        counts: dict[int, int] = {}
        for rec in self._records(stop_at_break=True):
            kind = type(rec).__name__
            if kind == "Schema":
                enc = {"ros2msg": "msg", "ros2idl": "idl"}.get(rec.encoding, "")
                schemas[rec.id] = (rec.name, enc, rec.data.decode("utf-8", "replace"))
            elif kind == "Channel" and rec.schema_id in schemas:
                name, enc, text = schemas[rec.schema_id]
                self._channels[rec.id] = rec.topic
                self.topics.setdefault(rec.topic, BagTopic(rec.topic, name, enc, text))
            elif kind == "Message":
                counts[rec.channel_id] = counts.get(rec.channel_id, 0) + 1
        for cid, topic in self._channels.items():  # messages up to the break, per topic
            known = self.topics[topic]
            self.topics[topic] = replace(known, count=(known.count or 0) + counts.get(cid, 0))

    def _records(self, stop_at_break: bool) -> Iterator[Any]:
        from mcap.exceptions import McapError
        from mcap.stream_reader import StreamReader

        with open(self.path, "rb") as fh:
            # no record is longer than the file: a damaged length field must not make the
            # reader allocate it (MemoryError) or overflow (OverflowError)
            limit = max(1, min(1 << 30, self.path.stat().st_size))
            try:
                yield from StreamReader(fh, record_size_limit=limit).records
            except (
                McapError,
                EOFError,
                struct.error,
                ValueError,
                TypeError,
                OverflowError,
                MemoryError,
                IndexError,
                KeyError,
            ) as exc:
                if not stop_at_break:
                    what = "ends inside a record" if type(exc).__name__ == "EndOfFile" else exc
                    raise StorageBreak(f"the MCAP file {what}") from None

    def messages(self, topics: list[str]) -> Iterator[tuple[str, int, bytes]]:
        wanted = {cid for cid, topic in self._channels.items() if topic in topics}
        for rec in self._records(stop_at_break=False):
            if type(rec).__name__ == "Message" and rec.channel_id in wanted:
                yield self._channels[rec.channel_id], rec.log_time, rec.data

    def close(self) -> None:
        pass


def open_storage(path: Path) -> RosbagsStorage | McapScan:
    """The bag at `path`; an MCAP file without its end is scanned from the start."""
    try:
        return RosbagsStorage(path)
    except FileNotFoundError:
        raise StorageError("no such bag") from None
    except STORAGE_ERRORS as exc:
        mcap = _mcap_file(path)
        if mcap is not None:  # it starts like MCAP: read what is there
            try:
                return McapScan(mcap)
            except OSError:
                pass
        raise StorageError(f"cannot open as a ROS 2 bag (MCAP or sqlite3): {exc}") from None


def _mcap_file(path: Path) -> Path | None:
    """The MCAP file of a bag (the file itself, or the one .mcap file of a bag folder) when it
    starts like an MCAP file."""
    files = sorted(path.glob("*.mcap")) if path.is_dir() else [path]
    if len(files) != 1:
        return None
    try:
        with open(files[0], "rb") as fh:
            return files[0] if fh.read(8) == MCAP_MAGIC else None
    except OSError:
        return None
