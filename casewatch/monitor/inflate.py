"""A gzip stream inflated by ISA-L, read exactly as the standard library reads it.

Why: inflating was about a tenth of the whole-log path's time per frame (issue 36: zlib gives
about 270 MB/s of JSON here, 23 us for a reference frame), and ISA-L (python-isal) inflates
the same deflate data about 2.9 times faster.

What "exactly" means. The reader (`monitor.reader`) takes a gzip stream in `read1(CHUNK)`
pieces, and three things depend on how those pieces fall, not only on the bytes: where a
corrupt or cut stream stops (the lines before it are judged, `truncated-stream` names the
line reached), where a stream that is not UTF-8 fails, and the digest of a damaged stream (the
bytes read until it failed). So the fast route is the standard library's own gzip reader,
header and trailer checks, CRC and all, with only its inflate object replaced, and it is
trusted only while the two cannot differ:

- every inflate call returns exactly the `max_length` bytes asked for, or ends the member. A
  deflate stream's output is defined by its bits, so both libraries then return the same
  bytes in the same pieces (zlib returns fewer only when the input runs out first);
- nothing fails.

On the first call that returns fewer bytes without ending the member, or on any error, the
stream is opened again and read by the standard library alone from its start, as the old route
read it: the pieces already returned are read again and dropped (they are the same pieces), so
from there on the reader gets what it always got, the same failure after the same lines and
the digest of the same bytes. That second read costs a damaged stream one more inflate of what
came before the damage; an intact stream never takes it.

The one case this cannot make exact: a stream that ISA-L inflates past a point where zlib
fails (an invalid deflate construct one library accepts and the other refuses; both check the
conditions RFC 1951 sets). The lines up to where ISA-L stopped were then already read; the
reader reports zlib's error at the line reached. No such stream is known (the property test
tests/monitor/test_inflate.py corrupts streams at random).

The CRC-32 of each member's output, which the reader checks against the member's trailer, is
summed by ISA-L too on the fast route (the same standard CRC: the same value).

Where the fast route is off: standard input (it cannot be read twice), Python versions whose
gzip reader is not the one this wraps (3.12 changed it: checked at run time), and an install
without python-isal.
"""

from __future__ import annotations

import gzip
import io
import zlib
from collections.abc import Callable
from typing import IO, Any

from casewatch.monitor.hashing import HashingReader, hashed

try:  # a declared dependency; without it every stream takes the standard library's route
    from isal import isal_zlib
except ImportError:  # pragma: no cover - the dependency is declared
    isal_zlib = None  # type: ignore[assignment]


class _Diverged(Exception):
    """ISA-L's inflate returned a piece zlib might have cut differently."""


class _CheckedInflate:
    """ISA-L's inflate object with zlib's interface, trusted only while its pieces are zlib's:
    a call returns `max_length` bytes or ends the member (the module docstring says why)."""

    __slots__ = ("_inflate",)

    def __init__(self, **args: Any) -> None:
        self._inflate = isal_zlib.decompressobj(**args)

    def decompress(self, data: bytes, max_length: int = 0) -> bytes:
        inflate = self._inflate
        out = inflate.decompress(data, max_length)
        if len(out) != max_length and not inflate.eof:
            raise _Diverged
        return out  # type: ignore[no-any-return]

    @property
    def eof(self) -> bool:
        return self._inflate.eof  # type: ignore[no-any-return]

    @property
    def unconsumed_tail(self) -> bytes:
        return self._inflate.unconsumed_tail  # type: ignore[no-any-return]

    @property
    def unused_data(self) -> bytes:
        return self._inflate.unused_data  # type: ignore[no-any-return]


def _fast_route_possible(gz: gzip.GzipFile) -> bool:
    """Whether this Python's gzip reader is the one the fast route wraps: a `_GzipReader` that
    makes its inflate objects with `zlib.decompressobj` (Python 3.11)."""
    reader = getattr(getattr(gz, "_buffer", None), "raw", None)
    return (
        isal_zlib is not None
        and _STDLIB_READER is not None
        and type(reader) is _STDLIB_READER
        and "_add_read_data" in vars(_STDLIB_READER)
        and getattr(reader, "_decomp_factory", None) is zlib.decompressobj
    )


#: The standard library's gzip reader class (private: checked before the fast route is taken).
_STDLIB_READER: type | None = getattr(gzip, "_GzipReader", None)


class _IsalCrcReader(_STDLIB_READER or object):  # type: ignore[misc]
    """The standard library's gzip reader with ISA-L's CRC-32 of what it inflated (the same
    standard CRC, the same value: about 8 times faster here, 0.26 against 2.1 us per 8 KiB)."""

    def _add_read_data(self, data: bytes) -> None:
        self._crc: int = isal_zlib.crc32(data, self._crc)  # type: ignore[has-type]
        self._stream_size: int = self._stream_size + len(data)  # type: ignore[has-type]


def _use_isal(gz: gzip.GzipFile) -> None:
    """Make `gz`'s reader (nothing read yet) inflate, and sum the CRC, with ISA-L."""
    reader = gz._buffer.raw  # type: ignore[attr-defined]
    reader.__class__ = _IsalCrcReader
    reader._decomp_factory = _CheckedInflate
    reader._decompressor = _CheckedInflate(**reader._decomp_args)


class GzipStream:
    """A gzip stream's decompressed bytes by `read1`, hashed as read (`hashing.sha256`: the
    compressed bytes the current route has read), ISA-L's route while it is exact and the
    standard library's after (the module docstring).

    `reopen` gives the compressed stream again from its start (None: it cannot, and the
    standard library reads it from the first byte)."""

    def __init__(
        self,
        hashing: HashingReader,
        buffered: io.BufferedReader,
        reopen: Callable[[], IO[bytes]] | None,
    ) -> None:
        self.name = hashing.name
        self._reopen = reopen
        self.hashing = hashing
        self._gz = gzip.GzipFile(fileobj=buffered, mode="rb")
        self._fast = reopen is not None and _fast_route_possible(self._gz)
        if self._fast:
            _use_isal(self._gz)
        #: the sizes the fast route was asked for, as [size, times] runs (a replay asks again)
        self._asked: list[list[int]] = []

    @property
    def route(self) -> str:
        """`isal` while the fast route reads, else `zlib` (for the tests and the benchmark)."""
        return "isal" if self._fast else "zlib"

    def readable(self) -> bool:
        return True

    def read1(self, size: int = -1) -> bytes:
        if not self._fast:
            return self._gz.read1(size)
        try:
            data = self._gz.read1(size)
        except Exception:
            return self._fall_back(size)
        asked = self._asked
        if asked and asked[-1][0] == size:
            asked[-1][1] += 1
        else:
            asked.append([size, 1])
        return data

    def read(self, size: int = -1) -> bytes:
        """`read1` until `size` bytes or the end (the reader itself reads by `read1`)."""
        parts = []
        left = size if size is not None and size >= 0 else -1
        while left != 0 and (chunk := self.read1(left if left > 0 else io.DEFAULT_BUFFER_SIZE)):
            parts.append(chunk)
            if left > 0:
                left -= len(chunk)
        return b"".join(parts)

    def _fall_back(self, size: int) -> bytes:
        """Switch to the standard library's route: read the stream again from its start,
        asking for the same sizes as before and dropping what comes back (the pieces the fast
        route returned), then return the piece asked for now, or raise its error, as the old
        route did there."""
        assert self._reopen is not None
        self._fast = False
        self.close()
        self.hashing, buffered = hashed(self._reopen(), self.name)
        buffered.peek(2)  # as `byte_stream.open_hashed` looked for the magic bytes
        self._gz = gzip.GzipFile(fileobj=buffered, mode="rb")
        # an error while replaying: zlib failed before where ISA-L reached (the module
        # docstring's one inexact case); the reader reports it at the line it has reached
        for asked, times in self._asked:
            for _ in range(times):
                self._gz.read1(asked)
        return self._gz.read1(size)

    def close(self) -> None:
        self._gz.close()
        self.hashing.close()

    @property
    def closed(self) -> bool:
        return self._gz.closed  # type: ignore[no-any-return]
