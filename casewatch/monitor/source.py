"""One way to open what a run judges: `open_source()` behind a small `Source` protocol.

A source is a JSON Lines stream (a file, gzip detected by its magic bytes, standard input as
`-`, or a log's bytes shipped to a worker) or a ROS 2 bag (a folder with `metadata.yaml`, or a
bare `.mcap`/`.db3` file). Whichever it is, the caller gets frames from `source.reader` (the
`StreamReader` surface: `header`, `defects`, `dropouts`, `frames_read`), the sha256 of what was
judged from `source.digest()` and the bag's per-topic report from `source.topic_report()`; the
format is decided here once (`source_kind`), not at every call site.

A stream's bytes are hashed as they are read, in the same single pass, so a live stream is never
buffered to be hashed; a bag's digest is that of its files (`path_digest`).
"""

from __future__ import annotations

import hashlib
import io
from collections.abc import Iterator
from pathlib import Path
from types import TracebackType
from typing import IO, Literal, Protocol

from casewatch.errors import CasewatchError
from casewatch.monitor.byte_stream import STDIN, open_hashed
from casewatch.monitor.frames import Frame, Header

#: What a source is: decided from its name and, for a folder, its `metadata.yaml`.
SourceKind = Literal["stdin", "bag", "stream"]

#: Storage files of a ROS 2 bag judged on their own.
BAG_SUFFIXES = (".mcap", ".db3")


class SourceError(CasewatchError, ValueError):
    """A source that cannot be opened (unreadable file, a bag without a usable mapping)."""


def source_kind(source: str | Path) -> SourceKind:
    """`stdin` for `-`, `bag` for a rosbag2 folder (with metadata.yaml) or an `.mcap`/`.db3`
    file, else `stream` (JSON Lines, plain or gzip)."""
    if str(source) == STDIN:
        return "stdin"
    p = Path(source)
    if p.is_dir():
        return "bag" if (p / "metadata.yaml").is_file() else "stream"
    return "bag" if p.suffix in BAG_SUFFIXES else "stream"


class FrameReader(Protocol):
    """What the evaluator reads frames through (`monitor.reader.StreamReader`, `BagReader`)."""

    @property
    def header(self) -> Header | None: ...

    @property
    def defects(self) -> list: ...

    @property
    def dropouts(self) -> dict[str, int]: ...

    @property
    def frames_read(self) -> int: ...

    def __iter__(self) -> Iterator[Frame]: ...


class Source(Protocol):
    """An opened source. `path` is what the result records (`-` for standard input), `name`
    what messages show; `digest()` is valid once the frames have been read."""

    path: str
    name: str
    kind: SourceKind
    reader: FrameReader

    def digest(self) -> str: ...

    def topic_report(self) -> dict[str, dict[str, int]]: ...

    def close(self) -> None: ...

    def __enter__(self) -> Source: ...

    def __exit__(
        self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None: ...


class _Closing:
    def close(self) -> None:  # pragma: no cover - overridden where there is something to close
        pass

    def __enter__(self):
        return self

    def __exit__(
        self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()


class StreamSource(_Closing):
    """JSON Lines frames from a file, gzip, standard input or bytes in memory, hashed as read."""

    kind: SourceKind

    def __init__(
        self,
        source: str | Path,
        strict: bool,
        channels: list[str] | None,
        period: float | None,
        payload: bytes | None = None,
    ) -> None:
        from casewatch.monitor.reader import read_stream

        self.path = str(source)
        self.kind = "stdin" if self.path == STDIN and payload is None else "stream"
        try:
            raw: IO[bytes] | None = io.BytesIO(payload) if payload is not None else None
            self._binary, self._digest, self.name = open_hashed(source, raw)
        except OSError as exc:
            raise SourceError(f"{source}: cannot read stream: {exc.strerror or exc}") from None
        # the reader splits the binary stream's lines itself (as a strict UTF-8 text stream
        # reads them; monitor.reader._byte_lines)
        self.reader: FrameReader = read_stream(
            self._binary, strict=strict, channels=channels, period=period
        )

    def digest(self) -> str:
        return self._digest()

    def topic_report(self) -> dict[str, dict[str, int]]:
        return {}

    def close(self) -> None:
        self._binary.close()


class BagSource(_Closing):
    """A ROS 2 bag read through a topic mapping (`--topics`, else the case's `monitor.topics`)."""

    kind: SourceKind = "bag"

    def __init__(
        self,
        source: str | Path,
        strict: bool,
        channels: list[str] | None,
        period: float,
        topics: str | Path | None,
        case_path: str | Path | None,
        case_topics: str | dict | None,
    ) -> None:
        from casewatch.monitor.bags.mapping import MappingError, resolve_mapping
        from casewatch.monitor.bags.reader import BagError, read_bag

        self.path = self.name = str(source)
        try:
            mapping = resolve_mapping(topics, case_path, case_topics)
            self.reader: FrameReader = read_bag(
                source, mapping, channels=channels, period=period, strict=strict
            )
            self._digest = path_digest(source)
        except (MappingError, BagError) as exc:
            raise SourceError(str(exc)) from None
        except OSError as exc:
            raise SourceError(f"{source}: cannot read the bag: {exc.strerror or exc}") from None

    def digest(self) -> str:
        return self._digest

    def topic_report(self) -> dict[str, dict[str, int]]:
        return self.reader.topic_report()  # type: ignore[attr-defined]

    def close(self) -> None:
        pass  # the bag reader closes its storage when iteration ends


def open_source(
    source: str | Path,
    *,
    channels: list[str] | None = None,
    period: float | None = None,
    strict: bool = False,
    topics: str | Path | None = None,
    case_path: str | Path | None = None,
    case_topics: str | dict | None = None,
    payload: bytes | None = None,
) -> Source:
    """Open a stream, standard input (`-`) or a bag for reading frames; nothing is parsed until
    `source.reader` is iterated. `topics`, `case_path` and `case_topics` choose a bag's topic
    mapping (ignored for streams); `payload` is a JSON Lines log's bytes, read from memory
    instead of `source` (which stays its name). Raises `SourceError`."""
    if payload is None and source_kind(source) == "bag":
        bag_period = 0.1 if period is None else period
        return BagSource(source, strict, channels, bag_period, topics, case_path, case_topics)
    return StreamSource(source, strict, channels, period, payload)


def file_digest(path: Path | str) -> str:
    """The sha256 of a file's bytes, as a run records its stream's (`stream.digest`)."""
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def path_digest(path: Path | str) -> str:
    """The sha256 of a file, or of a folder (a rosbag2 bag: metadata.yaml and its storage
    files) as the names and bytes of its files in name order."""
    path = Path(path)
    if not path.is_dir():
        return file_digest(path)
    digest = hashlib.sha256()
    for item in sorted(p for p in path.rglob("*") if p.is_file()):
        digest.update(str(item.relative_to(path)).encode() + b"\0")
        digest.update(bytes.fromhex(file_digest(item)))
    return digest.hexdigest()
