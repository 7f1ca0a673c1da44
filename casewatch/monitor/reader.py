"""Reading JSON Lines frame streams (file, `.gz` file, or `-` for standard input) lazily.

A bad line never disappears: it becomes a `StreamDefect` kept on the reader (the frame is
skipped), or, with `strict=True`, a `StreamError`. A channel missing from a frame is a dropout,
counted per channel; the frame is still used. `docs/streams.md` lists the defect kinds.
"""

from __future__ import annotations

import codecs
import gzip
import io
import json
import sys
import zlib
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import IO

from casewatch.errors import CasewatchError
from casewatch.monitor.byte_stream import open_hashed
from casewatch.monitor.fastparse import fast_frame
from casewatch.monitor.frames import Frame, Header
from casewatch.monitor.parse import FrameDefect, parse_frame, parse_header

try:  # optional: about five times faster on large frames; same results (see _decode)
    import orjson
except ImportError:  # pragma: no cover - depends on the environment
    orjson = None  # type: ignore[assignment]

#: The longest line read as one frame, in characters (bundled frames stay under 20 000). A
#: longer line is an `oversized-line` defect; its rest is skipped in chunks, never held whole.
MAX_LINE_CHARS = 16 * 1024 * 1024

#: A frame less than this share of the period after the previous frame is a `frame-spacing`
#: defect: rtamt counts samples, so a burst of close frames would shrink every time window.
MIN_SPACING = 0.5

#: Frame times beyond this many seconds from 0 are a `bad-time` defect: a float cannot resolve a
#: 0.1 s period much further out (its spacing is 1e-4 s at 1e12 s, 0.125 s at 1e15 s).
MAX_ABS_T = 1e12

#: What a compressed stream raises when it ends before its end marker or its data is corrupt.
_COMPRESSION_ERRORS: tuple[type[Exception], ...] = (EOFError, zlib.error, gzip.BadGzipFile)


def decode(text: str) -> object:
    """json.loads, through orjson when installed. orjson refuses what the standard library
    accepts (NaN, Infinity), so on any orjson error the standard parser decides: the defect
    kinds and messages never depend on which parser is installed."""
    if orjson is not None:
        try:
            return orjson.loads(text)
        except orjson.JSONDecodeError:
            pass
    return json.loads(text, parse_int=_integer)


def read_frame(text: str, channels: Iterable[str] | None = None, line: int = 0) -> Frame:
    """One frame line as the reader reads it: `parse_frame(decode(text), channels, line)`,
    through the compiled pass (`monitor.fastparse`) when the line has the common shape.
    Raises what that does (ValueError for a line that is not JSON, FrameDefect); for a caller
    that times or reads single lines (the live benchmark). A header line is not a frame."""
    declared = None if channels is None else list(channels)  # read twice at most
    frame = fast_frame(text, declared, line)
    if frame is None:
        frame = parse_frame(decode(text), declared, line)
    return frame


def _integer(digits: str) -> int | float:
    """A JSON integer; one beyond the range of a float (a 401-digit `t`) reads as infinity, so
    the frame's finiteness checks make it a `non-finite` defect instead of an OverflowError."""
    return int(digits) if len(digits) < 300 else float(digits)


@dataclass(frozen=True)
class StreamDefect:
    """One bad line: 1-based line number, a stable kind (see DEFECT_KINDS), a message."""

    line: int
    kind: str
    message: str
    source: str = "<stream>"

    def format(self) -> str:
        return f"{self.source}:{self.line}: {self.kind}: {self.message}"


class StreamError(CasewatchError):
    """Raised in strict mode on the first defect."""

    def __init__(self, defect: StreamDefect):
        super().__init__(defect.format())
        self.defect = defect


def keep_defect(defects: list[StreamDefect], strict: bool, defect: StreamDefect) -> None:
    """What every reader (JSON Lines, ROS 2 bag) does with a defect: raise it in strict mode,
    else keep it for the report."""
    if strict:
        raise StreamError(defect)
    defects.append(defect)


def _open(source: str | Path | IO) -> tuple[IO, str, bool, bool]:
    """(stream, display name, whether we own it and must close it, whether it is binary).

    A binary stream's lines are split here (`_byte_lines`) and a text stream's by its own
    readline; both give the same lines (see `_byte_lines`)."""
    if isinstance(source, (str, Path)):
        if str(source) == "-":
            raw = getattr(sys.stdin, "buffer", None)
            if raw is not None and hasattr(raw, "peek"):
                # Binary stdin can be gzip too (`zcat`-free pipes); look without consuming.
                if raw.peek(2)[:2] == b"\x1f\x8b":
                    return gzip.open(raw, "rb"), "<stdin>", False, True  # type: ignore[return-value]
                return raw, "<stdin>", False, True
            return sys.stdin, "<stdin>", False, False
        # a file as a run's source opens it (gzip by its magic bytes, through `monitor.inflate`)
        stream, _, name = open_hashed(source)
        return stream, name, True, True
    name = str(getattr(source, "name", "<stream>"))
    if isinstance(source, io.TextIOBase) or hasattr(source, "encoding"):
        return source, name, False, False
    return source, name, False, True


#: How much a binary stream is asked for at a time: what `io.TextIOWrapper` asks for (its
#: `_CHUNK_SIZE`), so a gzip stream is decompressed, and a file read and hashed, in the same
#: pieces as when the reader read through a TextIOWrapper; a corrupt stream then fails after
#: the same lines.
CHUNK = 8192


def _newlines(chunk: bytes, held_cr: bool) -> tuple[bytes, bool]:
    """`chunk` with its line ends translated as a text stream reads them (universal newlines:
    \\r\\n and a lone \\r become \\n), and whether its last byte was a \\r held back
    (the next chunk may start with the \\n of the same line end)."""
    if held_cr:
        chunk = b"\r" + chunk
    if b"\r" not in chunk:
        return chunk, False
    chunk = chunk.replace(b"\r\n", b"\n")
    if chunk.endswith(b"\r"):
        return chunk[:-1].replace(b"\r", b"\n"), True
    return chunk.replace(b"\r", b"\n"), False


def _chars(data: bytes) -> int:
    """Characters of valid UTF-8 `data` (an incomplete last character not counted)."""
    return len(data) if data.isascii() else len(codecs.utf_8_decode(data, "strict", False)[0])


class StreamReader:
    """Iterate to get frames, one per valid line, as they are read.

    After iteration (or during it): `header` (None when the stream has none), `defects`,
    `dropouts` (channel -> frames without it), `frames_read`, `channels` (the declared set:
    the caller's list, else the header's, else the channels of the first valid frame).
    """

    def __init__(
        self,
        source: str | Path | IO,
        strict: bool = False,
        channels: list[str] | None = None,
        period: float | None = None,
        max_line_chars: int = MAX_LINE_CHARS,
    ):
        self._source = source
        self.strict = strict
        # the caller's period (normally monitor.period), else the header's once read
        self.period: float | None = period
        self.max_line_chars = max_line_chars
        self.name = "<stdin>" if str(source) == "-" else str(getattr(source, "name", source))
        self.declared: list[str] | None = list(channels) if channels is not None else None
        self.channels: list[str] | None = self.declared
        #: `channels` as a set, for the compiled pass's check of a frame's channel names
        self._known: frozenset[str] | None = None if channels is None else frozenset(channels)
        self.header: Header | None = None
        self.defects: list[StreamDefect] = []
        self.dropouts: dict[str, int] = {c: 0 for c in channels or []}
        self.frames_read = 0
        self._started = False

    def _defect(self, line: int, kind: str, message: str) -> None:
        keep_defect(self.defects, self.strict, StreamDefect(line, kind, message, self.name))

    def __iter__(self) -> Iterator[Frame]:
        if self._started:
            raise RuntimeError("a StreamReader can be iterated once")
        self._started = True
        fh, self.name, owned, binary = _open(self._source)
        try:
            yield from self._frames(self._byte_lines(fh) if binary else self._lines(fh))
        finally:
            if owned:
                fh.close()

    def _lines(self, fh: IO[str]) -> Iterator[tuple[int, str | bytes]]:
        """(line number, text) of every line, with two limits: a line longer than
        `max_line_chars` is an `oversized-line` defect, and a compressed stream that ends early
        or is corrupt is a `truncated-stream` defect at the line it reached; reading stops
        there and the frames before it stand."""
        limit = self.max_line_chars
        lineno = 0
        while True:
            lineno += 1
            try:
                text = fh.readline(limit)
                oversized = len(text) >= limit and not text.endswith("\n")
                while oversized and text:  # skip the rest of the line without keeping it
                    text = fh.readline(limit)
                    if text.endswith("\n"):
                        break
            except _COMPRESSION_ERRORS as exc:
                self._defect(lineno, "truncated-stream", _compression_message(exc))
                return
            if oversized:
                self._oversized(lineno)
                continue
            if not text:
                return
            yield lineno, text

    def _oversized(self, lineno: int) -> None:
        self._defect(
            lineno,
            "oversized-line",
            f"line longer than {self.max_line_chars} characters; a frame is far smaller, so it "
            "was skipped unread",
        )

    def _byte_lines(self, fh: IO[bytes]) -> Iterator[tuple[int, str | bytes]]:
        """`_lines` for a binary stream, without a TextIOWrapper: the same lines, line
        numbers and defects, each line as its bytes (its line end translated to \\n).

        The stream is read in `CHUNK`s, as the text layer read it, and a chunk is read only
        when no whole line is left, as readline does; a chunk that is not ASCII is checked as
        UTF-8 when it is read, by the decoder the text layer used, so a stream that is not
        UTF-8 raises the same UnicodeDecodeError after the same lines. A line is held in
        memory only while it is within `max_line_chars`."""
        limit = self.max_line_chars
        read = getattr(fh, "read1", None) or fh.read
        utf8 = codecs.getincrementaldecoder("utf-8")()
        partial_char = False  # the decoder holds the start of a character
        carry = b""  # its bytes
        held_cr = False
        parts: list[bytes] = []  # the line being read, when it started in an earlier chunk
        size = 0
        skipping = False  # inside an oversized line
        lineno = 0
        while True:
            try:
                chunk = read(CHUNK)
            except _COMPRESSION_ERRORS as exc:
                self._defect(lineno + 1, "truncated-stream", _compression_message(exc))
                return
            if not chunk:
                if partial_char:
                    utf8.decode(b"", True)  # raises: the stream ends inside a character
                rest = b"".join(parts) + (b"\n" if held_cr else b"")
                if skipping or (rest and _chars(rest.rstrip(b"\n")) >= limit):
                    self._oversized(lineno + 1)
                elif rest:
                    yield lineno + 1, rest
                return
            if partial_char or not chunk.isascii():
                utf8.decode(chunk)  # raises UnicodeDecodeError as the text layer did
                held = utf8.getstate()[0]
                # an incomplete last character waits for the next chunk, as in the text
                # layer (a \r before it is then the last character and is held too)
                chunk = carry + chunk
                carry = held
                if held:
                    chunk = chunk[: -len(held)]
                partial_char = bool(held)
            chunk, held_cr = _newlines(chunk, held_cr)
            end = chunk.find(b"\n")
            if end < 0:
                if not skipping:
                    parts.append(chunk)
                    size += len(chunk)
                    if size >= limit and _chars(b"".join(parts)) >= limit:
                        skipping = True  # oversized whatever follows: drop it as it comes
                        parts = []
                continue
            if skipping:  # the oversized line ends here
                lineno += 1
                self._oversized(lineno)
                skipping = False
                chunk = chunk[end + 1 :]
            elif parts:
                parts.append(chunk)
                chunk = b"".join(parts)
            parts = []
            lines = chunk.split(b"\n")
            tail = lines.pop()
            for body in lines:
                lineno += 1
                if len(body) >= limit and _chars(body) >= limit:
                    self._oversized(lineno)
                    continue
                yield lineno, body + b"\n"
            if tail:
                parts.append(tail)
            size = len(tail)
            if size >= limit and _chars(tail) >= limit:
                skipping = True
                parts = []

    def _frames(self, lines: Iterator[tuple[int, str | bytes]]) -> Iterator[Frame]:
        last_t: float | None = None
        first_content = True
        for lineno, line in lines:
            # the common frame in one compiled pass; anything else, and anything wrong, the
            # careful route below (which names the defect)
            frame = fast_frame(line, self._known, lineno)
            if frame is None:
                # a line's bytes are valid UTF-8 (`_byte_lines` checked them)
                text = line.decode("utf-8") if isinstance(line, bytes) else line
                if not text.strip():
                    continue  # blank lines carry nothing (documented in docs/streams.md)
                try:
                    obj = decode(text)
                except ValueError as exc:
                    self._defect(lineno, "malformed-json", f"not valid JSON: {exc}")
                    first_content = False
                    continue
                except RecursionError:
                    self._defect(lineno, "malformed-json", _TOO_DEEP)
                    first_content = False
                    continue
                if isinstance(obj, dict) and "header" in obj:
                    if not first_content:
                        self._defect(
                            lineno, "bad-header", "a header is only allowed on the first line"
                        )
                        continue
                    first_content = False
                    try:
                        self.header = parse_header(obj)
                    except FrameDefect as d:
                        self._defect(lineno, d.kind, d.message)
                        continue
                    if self.header.conditions_problem is not None:
                        self._defect(lineno, "bad-header", self.header.conditions_problem)
                    self._adopt_header(lineno)
                    continue
                try:
                    frame = parse_frame(obj, self.channels, lineno)
                except FrameDefect as d:
                    self._defect(lineno, d.kind, d.message)
                    first_content = False
                    continue
                except RecursionError:  # a value nested so deeply that even describing it fails
                    self._defect(lineno, "malformed-json", _TOO_DEEP)
                    first_content = False
                    continue
            first_content = False
            if abs(frame.t) > MAX_ABS_T:
                self._defect(
                    lineno,
                    "bad-time",
                    f"t = {frame.t:g} is beyond {MAX_ABS_T:g} s, where seconds as floating point "
                    "no longer resolve the period; write t relative to the start of the drive",
                )
                continue
            if last_t is not None and frame.t <= last_t:
                self._defect(
                    lineno,
                    "non-increasing-t",
                    f"t = {frame.t:g} does not increase strictly (previous frame t = {last_t:g})",
                )
                continue
            if last_t is not None and self.period and frame.t - last_t < MIN_SPACING * self.period:
                self._defect(
                    lineno,
                    "frame-spacing",
                    f"t = {frame.t!r} comes {frame.t - last_t:.3g} s after the previous frame "
                    f"(t = {last_t!r}); with a period of {self.period:g} s frames closer than "
                    f"{MIN_SPACING * self.period:g} s are skipped",
                )
                continue
            if self.channels is None:
                self.channels = list(frame.channels)
                self._known = frozenset(self.channels)
                self.dropouts = {c: 0 for c in self.channels}
            for c in self.channels:
                if c not in frame.channels:
                    self.dropouts[c] += 1
            last_t = frame.t
            self.frames_read += 1
            yield frame

    def _adopt_header(self, lineno: int) -> None:
        assert self.header is not None
        if self.period is None:
            self.period = self.header.period
        if self.declared is None:
            if self.header.channels:
                self.channels = list(self.header.channels)
                self._known = frozenset(self.channels)
                self.dropouts = {c: 0 for c in self.channels}
            return
        extra = [c for c in self.header.channels if c not in self.declared]
        if extra:
            self._defect(
                lineno,
                "unknown-channel",
                f"header lists channel(s) {', '.join(extra)} not declared "
                f"(declared: {', '.join(self.declared)})",
            )


_TOO_DEEP = (
    "JSON nested too deeply (a frame needs about 7 levels of [ and {; the decoder stops at 1024)"
)


def _compression_message(exc: Exception) -> str:
    if isinstance(exc, EOFError):
        return (
            "the compressed stream ends before its end marker (a truncated .gz file?); the "
            "frames before this line were judged, nothing after it could be read"
        )
    return (
        f"the compressed stream is corrupt ({exc}); the frames before this line were judged, "
        "nothing after it could be read"
    )


def read_stream(
    source: str | Path | IO,
    strict: bool = False,
    channels: list[str] | None = None,
    period: float | None = None,
) -> StreamReader:
    """Open a frame stream: a path (gzip detected from its magic bytes), `-` for stdin, or an
    open text/binary file. Nothing is read until you iterate. `period` (seconds, normally the
    case's `monitor.period`; else the header's) sets the `frame-spacing` check."""
    return StreamReader(source, strict=strict, channels=channels, period=period)
