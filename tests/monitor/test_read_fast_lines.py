"""The reader's own line splitting (`StreamReader._byte_lines`, for binary streams) against
the way it read lines before, through `io.TextIOWrapper(binary, encoding="utf-8")` and
`readline(max_line_chars)` (`StreamReader._lines`, still the route of text streams): on random
streams (line ends \\n, \\r\\n and a lone \\r, non-ASCII and invalid UTF-8, blank, long and
oversized lines; plain, gzip, truncated and corrupt gzip) the same lines with the same numbers,
the same defects, and the same UnicodeDecodeError (its reason) after the same lines."""

from __future__ import annotations

import gzip
import io
import random

from hypothesis import given, settings
from hypothesis import strategies as st

from casewatch.monitor.reader import StreamReader

PIECES = st.sampled_from(
    [
        b"x",
        b'{"t": 1}',
        b" ",
        b"\n",
        b"\r\n",
        b"\r",
        b"\xc3\xa9",  # é
        b"\xe2\x82\xac",  # €
        b"\xf0\x9f\x9a\x97",  # a car, four bytes
        b"\xc3",  # a character cut short: not UTF-8 unless a continuation follows
        b"\xa9",  # a lone continuation byte
        b"\xff",
        b"\x00",
        b"\x1c",
    ]
)


def _blob(draw: st.DrawFn) -> bytes:
    parts = draw(st.lists(st.one_of(PIECES, st.binary(max_size=3)), max_size=60))
    long_run = draw(st.sampled_from([0, 0, 50, 9000, 20000]))
    at = draw(st.integers(min_value=0, max_value=len(parts)))
    parts.insert(at, b"a" * long_run)
    return b"".join(parts)


@st.composite
def streams(draw: st.DrawFn) -> tuple[bytes, int]:
    data = _blob(draw)
    limit = draw(st.sampled_from([3, 8, 100, 8191, 8192, 10_000, 1 << 24]))
    return data, limit


def run(lines_of, limit: int) -> tuple[list, list, str | None]:
    """(lines, defects, the UnicodeDecodeError's reason) of one route."""
    reader = StreamReader(io.BytesIO(b""))  # only its line splitting and defects are used
    reader.max_line_chars = limit
    got: list[tuple[int, str]] = []
    error = None
    try:
        for number, line in lines_of(reader):
            text = line.decode("utf-8", "surrogateescape") if isinstance(line, bytes) else line
            got.append((number, text))  # (a line the route let through undecodable would differ)
    except UnicodeDecodeError as exc:
        error = exc.reason
    return got, [(d.line, d.kind, d.message) for d in reader.defects], error


def both(make_binary, limit: int) -> None:
    old = run(
        lambda r: r._lines(io.TextIOWrapper(make_binary(), encoding="utf-8", errors="strict")),
        limit,
    )
    new = run(lambda r: r._byte_lines(make_binary()), limit)
    assert new == old


@settings(max_examples=400, deadline=None)
@given(streams())
def test_plain_streams_split_as_the_text_layer_split_them(case: tuple[bytes, int]) -> None:
    data, limit = case
    both(lambda: io.BufferedReader(io.BytesIO(data)), limit)


@settings(max_examples=200, deadline=None)
@given(
    streams(), st.integers(min_value=0, max_value=10**6), st.sampled_from(["whole", "cut", "bad"])
)
def test_gzip_streams_whole_truncated_or_corrupt(
    case: tuple[bytes, int], seed: int, form: str
) -> None:
    data, limit = case
    packed = bytearray(gzip.compress(data * 3, mtime=0))
    rng = random.Random(seed)
    if form == "cut":
        packed = packed[: rng.randrange(len(packed) + 1)]
    elif form == "bad" and len(packed) > 20:
        at = rng.randrange(10, len(packed))
        packed[at : at + 4] = bytes(rng.randrange(256) for _ in range(4))
    blob = bytes(packed)
    both(lambda: gzip.GzipFile(fileobj=io.BufferedReader(io.BytesIO(blob)), mode="rb"), limit)


def test_a_stream_of_frames_in_large_gzip_pieces_gives_the_same_lines() -> None:
    """Many lines of a few kilobytes across 8 KiB reads, \\r\\n ends on some, a long line
    among them and a cut in the middle of the last member."""
    rng = random.Random(5)
    rows = []
    for i in range(400):
        pad = "y" * rng.randrange(0, 9000)
        body = f'{{"t": {i}, "pad": "{pad}"}}'.encode()
        rows.append(body + (b"\r\n" if i % 7 == 0 else b"\n"))
    blob = gzip.compress(b"".join(rows), mtime=0)
    for cut in (len(blob), len(blob) - 40, len(blob) // 2):
        for limit in (1 << 24, 5000):
            both(
                lambda cut=cut: gzip.GzipFile(
                    fileobj=io.BufferedReader(io.BytesIO(blob[:cut])), mode="rb"
                ),
                limit,
            )


def test_the_known_cases_by_hand() -> None:
    """A lone \\r is a line end, \\r\\n one line end (also split across two reads), the last
    line needs no end, a line of exactly the limit in characters is oversized and one below it
    is not (characters, not bytes: é is two bytes)."""
    reader = StreamReader(io.BytesIO(b""))
    lines = list(reader._byte_lines(io.BufferedReader(io.BytesIO(b"a\rb\r\nc\n\nd"))))
    assert lines == [(1, b"a\n"), (2, b"b\n"), (3, b"c\n"), (4, b"\n"), (5, b"d")]
    split = b"x" * 8191 + b"\r\ny"  # the \r ends the first read, its \n starts the second
    lines = list(reader._byte_lines(io.BufferedReader(io.BytesIO(split))))
    assert [n for n, _ in lines] == [1, 2] and lines[1][1] == b"y"
    reader = StreamReader(io.BytesIO(b""))
    reader.max_line_chars = 4
    text = "ééé\néééé\nab\n".encode()
    lines = list(reader._byte_lines(io.BufferedReader(io.BytesIO(text))))
    assert lines == [(1, "ééé\n".encode()), (3, b"ab\n")]
    assert [(d.line, d.kind) for d in reader.defects] == [(2, "oversized-line")]


def test_line_ends_and_characters_across_the_read_boundary() -> None:
    """Every awkward piece placed at each position around the 8 KiB boundary between reads."""
    pieces = [b"\r\n", b"\r", b"\r\r\n", b"\xc3\xa9", b"\xe2\x82\xac", b"\xf0\x9f\x9a\x97"]
    pieces += [b"\r\xc3\xa9", b"\r\xf0\x9f\x9a\x97\n", b"\xc3", b"\xe2\x82", b"\r\xc3"]
    for offset in range(8186, 8196):
        for piece in pieces:
            data = b"a" * offset + piece + b"b\nc"
            for limit in (8190, 8192, 1 << 24):
                both(lambda data=data: io.BufferedReader(io.BytesIO(data)), limit)
                blob = gzip.compress(data, mtime=0)
                both(
                    lambda blob=blob: gzip.GzipFile(
                        fileobj=io.BufferedReader(io.BytesIO(blob)), mode="rb"
                    ),
                    limit,
                )
