"""The gzip reader of `monitor.inflate` against the standard library's, piece for piece.

The reference is the route every gzip stream took before ISA-L: a hashing layer, a 64 KiB
buffer (peeked for the magic bytes) and `gzip.GzipFile`, read by `read1(8192)` as the frame
reader reads. On intact and damaged streams alike, the fast route must return the same
pieces, fail with the same error after the same pieces, and have hashed the same bytes.
"""

from __future__ import annotations

import gzip
import hashlib
import io
import random
import zlib
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from casewatch.monitor.inflate import GzipStream, hashed, isal_zlib
from casewatch.monitor.reader import CHUNK, StreamReader
from casewatch.monitor.source import file_digest, open_source

DRIVE = Path(__file__).resolve().parents[2] / "examples" / "data" / "highway-tailgating.jsonl.gz"

pytestmark = pytest.mark.skipif(isal_zlib is None, reason="python-isal is not installed")


def _reference(blob: bytes) -> tuple[object, object]:
    hashing, buffered = hashed(io.BytesIO(blob), "log.jsonl.gz")
    buffered.peek(2)
    return hashing, gzip.GzipFile(fileobj=buffered, mode="rb")


def _fast(blob: bytes) -> GzipStream:
    hashing, buffered = hashed(io.BytesIO(blob), "log.jsonl.gz")
    buffered.peek(2)
    return GzipStream(hashing, buffered, lambda: io.BytesIO(blob))


def _drain(read1, digest) -> tuple[list[tuple[int, int]], str | None, str]:
    """(length and CRC of every piece, the error that ended the reading, the digest then)."""
    pieces = []
    error = None
    while True:
        try:
            piece = read1(CHUNK)
        except (EOFError, zlib.error, gzip.BadGzipFile, OSError) as exc:
            error = f"{type(exc).__name__}: {exc}"
            break
        if not piece:
            break
        pieces.append((len(piece), zlib.crc32(piece)))
    return pieces, error, digest()


def _both(blob: bytes) -> tuple[tuple, tuple, GzipStream]:
    hashing, reference = _reference(blob)
    old = _drain(reference.read1, lambda: hashing.sha256.hexdigest())
    fast = _fast(blob)
    new = _drain(fast.read1, lambda: fast.hashing.sha256.hexdigest())
    return old, new, fast


def _log(rng: random.Random, lines: int, noise: int) -> bytes:
    """JSON Lines like a frame log, with some incompressible and non-ASCII stretches."""
    rows = []
    for i in range(lines):
        row = b'{"t": %.1f, "x": %.6f, "name": "car-%d"}\n' % (i / 10, rng.random() * 100, i % 7)
        if noise and rng.random() < 0.02:
            row = rng.randbytes(noise) + "é\n".encode()
        rows.append(row)
    return b"".join(rows)


def _damaged(rng: random.Random, blob: bytes, kind: str) -> bytes:
    b = bytearray(blob)
    if kind == "cut":
        return bytes(b[: rng.randrange(len(b))])
    if kind == "flip":
        b[rng.randrange(10, len(b))] ^= 1 << rng.randrange(8)
    elif kind == "overwrite":
        at = rng.randrange(10, len(b))
        b[at : at + rng.randrange(1, 40)] = rng.randbytes(rng.randrange(1, 40))
    elif kind == "tail":
        b += rng.randbytes(rng.randrange(1, 30))
    elif kind == "trailer":
        b[-rng.randrange(1, 9)] ^= 0xFF
    return bytes(b)


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    lines=st.integers(0, 4000),
    noise=st.sampled_from([0, 0, 300]),
    level=st.sampled_from([1, 6, 9]),
    members=st.integers(1, 3),
    kind=st.sampled_from(["intact", "cut", "flip", "overwrite", "tail", "trailer"]),
)
def test_the_same_pieces_error_and_digest_as_the_standard_library(
    seed: int, lines: int, noise: int, level: int, members: int, kind: str
) -> None:
    rng = random.Random(seed)
    blob = b"".join(
        gzip.compress(_log(rng, lines // members, noise), compresslevel=level, mtime=0)
        for _ in range(members)
    )
    if kind != "intact":
        blob = _damaged(rng, blob, kind)
    old, new, _ = _both(blob)
    assert new == old


def test_an_intact_log_is_read_by_isal_to_its_end_and_hashed_whole(tmp_path) -> None:
    data = _log(random.Random(3), 20000, 0)
    path = tmp_path / "log.jsonl.gz"
    path.write_bytes(gzip.compress(data, mtime=0))
    old, new, fast = _both(path.read_bytes())
    assert new == old and old[1] is None
    assert fast.route == "isal"  # never fell back
    assert sum(n for n, _ in new[0]) == len(data)
    assert new[2] == hashlib.sha256(path.read_bytes()).hexdigest() == file_digest(path)


def test_a_damaged_log_falls_back_and_ends_where_zlib_ends() -> None:
    data = _log(random.Random(4), 20000, 0)
    blob = bytearray(gzip.compress(data, mtime=0))
    blob[len(blob) // 2] ^= 0x10
    old, new, fast = _both(bytes(blob))
    assert new == old
    assert fast.route == "zlib"
    assert old[1] is not None  # the damage was found (an error or the CRC)


def test_without_a_second_reading_the_standard_library_reads_from_the_start() -> None:
    blob = gzip.compress(_log(random.Random(5), 3000, 0), mtime=0)
    hashing, buffered = hashed(io.BytesIO(blob), "<stdin>")
    buffered.peek(2)
    stream = GzipStream(hashing, buffered, None)
    assert stream.route == "zlib"
    assert stream.read() == gzip.decompress(blob)


def test_a_cut_log_through_the_frame_reader_reports_the_line_the_old_route_reached(
    tmp_path,
) -> None:
    rows = gzip.decompress(DRIVE.read_bytes()).splitlines(keepends=True)
    blob = gzip.compress(b"".join(rows), mtime=0)
    path = tmp_path / "cut.jsonl.gz"
    path.write_bytes(blob[: len(blob) * 2 // 3])
    source = open_source(path)
    lines = [frame.line for frame in source.reader]
    # the old route: the standard library's stream under the same frame reader
    _, reference = _reference(path.read_bytes())
    old = StreamReader(reference)
    old_lines = [frame.line for frame in old]
    assert lines == old_lines and 0 < len(lines) < len(rows)
    kinds = [(d.line, d.kind) for d in source.reader.defects]
    assert kinds == [(d.line, d.kind) for d in old.defects]
    assert kinds[-1] == (lines[-1] + 1, "truncated-stream")


def test_a_gzip_reader_of_another_make_keeps_the_standard_library(monkeypatch) -> None:
    """Where this Python's gzip reader is not the one the fast route wraps (Python 3.12
    changed it), every stream is read by the standard library alone, unchanged."""
    import casewatch.monitor.inflate as inflate

    monkeypatch.setattr(inflate, "_STDLIB_READER", None)
    blob = gzip.compress(_log(random.Random(6), 2000, 0), mtime=0)
    old, new, fast = _both(blob)
    assert fast.route == "zlib" and new == old and old[1] is None
