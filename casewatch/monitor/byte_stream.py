"""`open_hashed`: a JSON Lines stream's bytes as the reader takes them, hashed as read.

One place decides how a file, standard input or a log's bytes in memory are read: through a
hashing layer (the digest a run records) and a buffer, gzip recognised by its magic bytes and
inflated by `monitor.inflate` (ISA-L, read exactly as the standard library reads it). A run's
source (`monitor.source`) and a `StreamReader` given a path (`monitor.reader`) both open
streams here.
"""

from __future__ import annotations

import io
import sys
from collections.abc import Callable
from pathlib import Path
from typing import IO

from casewatch.monitor.hashing import hashed
from casewatch.monitor.inflate import GzipStream

#: The name of standard input as a source.
STDIN = "-"


def open_hashed(
    source: str | Path, raw: IO[bytes] | None = None
) -> tuple[IO[bytes], Callable[[], str], str]:
    """Open a path or `-` (stdin), or read `raw` under `source`'s name, for reading frames;
    gzip is detected by its magic bytes and inflated by `monitor.inflate` (ISA-L, read as the
    standard library reads it).

    Returns the binary stream to parse, a function giving the sha256 (hex) of the bytes read
    so far, and the name to show in messages. Raises OSError when the file cannot be opened.
    """
    reopen: Callable[[], IO[bytes]] | None
    if raw is not None:
        name = str(source)
        payload = raw.getvalue() if isinstance(raw, io.BytesIO) else None
        reopen = (lambda: io.BytesIO(payload)) if payload is not None else None
    elif str(source) == STDIN:
        raw = sys.stdin.buffer
        name = "<stdin>"
        reopen = None  # read once: the standard library's route from the first byte
    else:
        path = Path(source)
        raw = open(path, "rb")  # noqa: SIM115 - closed through the returned stream
        name = str(source)
        reopen = lambda: open(path, "rb")  # noqa: E731, SIM115 - the gzip reader closes it
    hashing, buffered = hashed(raw, name)
    if buffered.peek(2)[:2] == b"\x1f\x8b":  # gzip, from a file or piped in
        stream = GzipStream(hashing, buffered, reopen)
        # the hashing layer the gzip reader reads through now (another after a replay)
        return stream, lambda: stream.hashing.sha256.hexdigest(), name  # type: ignore[return-value]
    return buffered, lambda: hashing.sha256.hexdigest(), name
