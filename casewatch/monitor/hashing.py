"""`HashingReader`: a raw binary stream that hashes every byte it passes on, and `hashed`,
the layers every stream is read through.

A stream's digest is taken in the same single pass that reads it (a live stream is never
buffered to be hashed): `monitor.byte_stream` and the gzip reader (`monitor.inflate`) put this
layer under their buffers.
"""

from __future__ import annotations

import hashlib
import io
import sys
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


#: The buffer over the hashing layer (the gzip reader's input, or a plain stream's lines).
BUFFER = 1 << 16


def hashed(raw: IO[bytes], name: str) -> tuple[HashingReader, io.BufferedReader]:
    """`raw` read through a hashing layer and a `BUFFER`-sized buffer: how a stream is read."""
    hashing = HashingReader(raw, name)
    return hashing, io.BufferedReader(hashing, buffer_size=BUFFER)
