"""Opening a stream so that its bytes are hashed as they are read.

The result records the sha256 of exactly the bytes judged (the compressed bytes of a `.gz`
file, or what arrived on standard input), computed in the same single pass as the reading, so a
live stream is never buffered to be hashed.
"""

from __future__ import annotations

import gzip
import hashlib
import io
import sys
from pathlib import Path
from typing import IO


class HashingReader(io.RawIOBase):
    """A raw binary stream that feeds every byte it returns into a sha256."""

    def __init__(self, raw: IO[bytes], name: str):
        self._raw = raw
        self.name = name  # readers above (buffer, gzip, text) report this name in messages
        self.sha256 = hashlib.sha256()

    def readable(self) -> bool:
        return True

    def readinto(self, buffer) -> int:  # type: ignore[override]
        read1 = getattr(self._raw, "read1", None)
        data = read1(len(buffer)) if read1 else self._raw.read(len(buffer))
        n = len(data)
        buffer[:n] = data
        self.sha256.update(data)
        return n

    def close(self) -> None:
        if self._raw is not sys.stdin.buffer:
            self._raw.close()
        super().close()


def open_hashed(source: str | Path) -> tuple[IO[bytes], HashingReader, str]:
    """Open a path or `-` (stdin) for reading frames; gzip is detected by its magic bytes.

    Returns the binary stream to parse, the hashing layer (read `.sha256` at the end) and the
    name to show in messages. Raises OSError when the file cannot be opened.
    """
    if str(source) == "-":
        raw: IO[bytes] = sys.stdin.buffer
        name = "<stdin>"
    else:
        raw = open(Path(source), "rb")  # noqa: SIM115 - closed through the returned stream
        name = str(source)
    hashing = HashingReader(raw, name)
    buffered = io.BufferedReader(hashing, buffer_size=1 << 16)
    if buffered.peek(2)[:2] == b"\x1f\x8b":  # gzip, from a file or piped in
        return gzip.GzipFile(fileobj=buffered, mode="rb"), hashing, name  # type: ignore[return-value]
    return buffered, hashing, name


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
