"""Copying a recording's own messages into the annotated MCAP, byte for byte.

An MCAP bag (a `.mcap` file, or a rosbag2 folder of them) keeps every schema, channel and
message as recorded: the annotated file is the recording plus casewatch's topics, so it
replaces the original in a review. A sqlite3 (`.db3`) bag has no MCAP records to copy.
"""

from __future__ import annotations

from pathlib import Path

from mcap.exceptions import McapError
from mcap.reader import make_reader

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


def copy_recording(recording: Path, out: McapOut) -> int:
    """Every message of the recording into `out` on its own topic and schema; the count."""
    copied = 0
    for path in mcap_files(recording):
        with open(path, "rb") as fh:
            try:
                for schema, channel, message in make_reader(fh).iter_messages(log_time_order=True):
                    described = (
                        None if schema is None else (schema.name, schema.encoding, schema.data)
                    )
                    out.raw_topic(
                        channel.topic, channel.message_encoding, dict(channel.metadata), described
                    )
                    out.write(channel.topic, message.log_time, message.data, message.publish_time)
                    copied += 1
            except McapError as exc:
                raise RecordingError(
                    f"{path}: the recording is damaged after {copied} messages ({exc})"
                ) from None
    return copied
