"""Reading JSON Lines frame streams (file, `.gz` file, or `-` for standard input) lazily.

A bad line never disappears: it becomes a `StreamDefect` kept on the reader (the frame is
skipped), or, with `strict=True`, a `StreamError`. A channel missing from a frame is a dropout,
counted per channel; the frame is still used. `docs/streams.md` lists the defect kinds.
"""

from __future__ import annotations

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


def _open_text(source: str | Path | IO) -> tuple[IO[str], str, bool]:
    """(text stream, display name, whether we own it and must close it)."""
    if isinstance(source, (str, Path)):
        if str(source) == "-":
            raw = getattr(sys.stdin, "buffer", None)
            if raw is not None and hasattr(raw, "peek"):
                # Binary stdin can be gzip too (`zcat`-free pipes); look without consuming.
                if raw.peek(2)[:2] == b"\x1f\x8b":
                    return (
                        io.TextIOWrapper(gzip.open(raw, "rb"), encoding="utf-8"),
                        "<stdin>",
                        False,
                    )
                return io.TextIOWrapper(raw, encoding="utf-8"), "<stdin>", False
            return sys.stdin, "<stdin>", False
        path = Path(source)
        with open(path, "rb") as fh:
            magic = fh.read(2)
        if magic == b"\x1f\x8b":
            return io.TextIOWrapper(gzip.open(path, "rb"), encoding="utf-8"), str(path), True
        return open(path, encoding="utf-8"), str(path), True
    name = str(getattr(source, "name", "<stream>"))
    if isinstance(source, io.TextIOBase) or hasattr(source, "encoding"):
        return source, name, False  # type: ignore[return-value]
    return io.TextIOWrapper(source, encoding="utf-8"), name, False  # type: ignore[arg-type]


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
        fh, self.name, owned = _open_text(self._source)
        try:
            yield from self._frames(fh)
        finally:
            if owned:
                fh.close()

    def _lines(self, fh: IO[str]) -> Iterator[tuple[int, str]]:
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
                self._defect(
                    lineno,
                    "oversized-line",
                    f"line longer than {limit} characters; a frame is far smaller, so it was "
                    "skipped unread",
                )
                continue
            if not text:
                return
            yield lineno, text

    def _frames(self, fh: IO[str]) -> Iterator[Frame]:
        last_t: float | None = None
        first_content = True
        for lineno, text in self._lines(fh):
            # the common frame in one compiled pass; anything else, and anything wrong, the
            # careful route below (which names the defect)
            frame = fast_frame(text, self.channels, lineno)
            if frame is None:
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
