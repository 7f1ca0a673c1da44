"""Copying a recording's own messages into the annotated MCAP, byte for byte.

An MCAP bag (a `.mcap` file, or a rosbag2 folder of them) keeps every schema, channel and
message as recorded: the annotated file is the recording plus casewatch's topics, so it
replaces the original in a review. A sqlite3 (`.db3`) bag has no MCAP records to copy.
"""

from __future__ import annotations

import struct
from pathlib import Path

from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.records import Channel, Message, Schema
from mcap.stream_reader import StreamReader

from casewatch.annotate.mcap_out import McapOut
from casewatch.errors import CasewatchError


class RecordingError(CasewatchError):
    """A recording annotate cannot copy (not MCAP, unreadable, damaged)."""


def mcap_files(recording: Path) -> list[Path]:
    """The MCAP storage files of a recording: the file itself, or a bag folder's `*.mcap`."""
    if recording.is_dir():
        files = sorted(recording.glob("*.mcap"))
        if not files:
            kinds = sorted({p.suffix for p in recording.iterdir() if p.is_file()} - {".yaml"})
            found = ", ".join(kinds) or "none"
            raise RecordingError(
                f"{recording}: a bag folder without MCAP storage files (found {found});"
                " annotate copies MCAP recordings: convert a sqlite3 bag with "
                "`ros2 bag convert` (storage_id: mcap) first"
            )
        return files
    if recording.suffix != ".mcap":
        raise RecordingError(
            f"{recording}: annotate copies MCAP recordings (.mcap or a bag folder of them); "
            "convert a sqlite3 bag with `ros2 bag convert` (storage_id: mcap) first"
        )
    return [recording]


def recording_profile(recording: Path) -> str:
    """The MCAP profile of the recording's first file (`ros2` for a rosbag2 recording)."""
    with open(mcap_files(recording)[0], "rb") as fh:
        try:
            return make_reader(fh).get_header().profile
        except McapError as exc:
            raise RecordingError(f"{recording}: not a readable MCAP file ({exc})") from None


#: What reading a damaged MCAP file record by record can raise (a length field read from
#: garbage, a record cut short, a chunk that does not decompress).
DAMAGE = (McapError, EOFError, struct.error, ValueError, TypeError, OverflowError, MemoryError)


def copy_recording(recording: Path, out: McapOut) -> tuple[int, str | None]:
    """Every message of the recording into `out` on its own topic and schema, in file order,
    read record by record from the start (no summary needed): (the count, None), or for a
    recording damaged part-way (cut short by a crash, say) the messages before the damage and
    what the damage is, as a run judges such a bag up to it."""
    copied = 0
    for path in mcap_files(recording):
        schemas: dict[int, tuple[str, str, bytes]] = {}
        channels: dict[int, str] = {}
        limit = max(1, min(1 << 30, path.stat().st_size))  # no record is longer than the file
        with open(path, "rb") as fh:
            try:
                for record in StreamReader(fh, record_size_limit=limit).records:
                    if isinstance(record, Schema):
                        schemas[record.id] = (record.name, record.encoding, record.data)
                    elif isinstance(record, Channel):
                        channels[record.id] = record.topic
                        out.raw_topic(
                            record.topic,
                            record.message_encoding,
                            dict(record.metadata),
                            schemas.get(record.schema_id),
                        )
                    elif isinstance(record, Message) and record.channel_id in channels:
                        topic = channels[record.channel_id]
                        out.write(topic, record.log_time, record.data, record.publish_time)
                        copied += 1
            except DAMAGE as exc:
                what = str(exc) or "it ends inside a record"  # mcap's EndOfFile says nothing
                if copied == 0:
                    raise RecordingError(
                        f"{path}: not a readable MCAP recording ({what})"
                    ) from None
                return copied, f"{path}: damaged after {copied} messages ({what})"
    return copied, None
