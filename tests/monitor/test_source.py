"""`open_source()`: one way in for JSON Lines files, gzip, shipped bytes, standard input and
bags, the format decided once (`source_kind`)."""

from __future__ import annotations

import gzip
import hashlib
import json

import pytest

from casewatch.monitor.source import SourceError, file_digest, open_source, source_kind
from tests.evaluator.streams import write_stream


def test_the_kind_comes_from_the_name_and_a_folder_s_metadata(tmp_path):
    bag = tmp_path / "bag"
    bag.mkdir()
    (bag / "metadata.yaml").write_text("rosbag2_bagfile_information: {}\n")
    plain = tmp_path / "plain"
    plain.mkdir()
    assert source_kind("-") == "stdin"
    assert source_kind(bag) == "bag"
    assert source_kind(plain) == "stream"  # a folder of logs is no bag
    assert source_kind(tmp_path / "x.mcap") == "bag"
    assert source_kind(tmp_path / "x.db3") == "bag"
    assert source_kind(tmp_path / "x.jsonl.gz") == "stream"


def test_plain_gzip_and_shipped_bytes_read_the_same_frames_and_hash_what_was_read(tmp_path):
    plain = write_stream(tmp_path / "s.jsonl")
    packed = tmp_path / "s.jsonl.gz"
    packed.write_bytes(gzip.compress(plain.read_bytes()))
    lines = len(plain.read_text().splitlines())
    seen = {}
    for name, source, payload in (
        ("plain", plain, None),
        ("gzip", packed, None),
        ("bytes", packed, packed.read_bytes()),
    ):
        with open_source(source, payload=payload) as opened:
            times = [f.t for f in opened.reader]
            assert opened.kind == "stream" and opened.path == str(source)
            seen[name] = (times, opened.digest())
    assert seen["plain"][0] == seen["gzip"][0] == seen["bytes"][0]
    assert len(seen["plain"][0]) == lines - 1  # every line but the header is a frame
    assert seen["plain"][1] == file_digest(plain)
    # the digest is of the bytes judged: the compressed ones, shipped or read from disk
    assert seen["gzip"][1] == seen["bytes"][1] == hashlib.sha256(packed.read_bytes()).hexdigest()


def test_an_unreadable_file_names_itself(tmp_path):
    with pytest.raises(SourceError, match=r"missing.jsonl: cannot read stream: No such file"):
        open_source(tmp_path / "missing.jsonl")


def test_a_bag_without_a_topic_mapping_says_how_to_give_one(tmp_path):
    with pytest.raises(SourceError, match=r"needs a topic mapping .* --topics"):
        open_source(tmp_path / "drive.mcap")


def test_strict_is_passed_to_the_reader(tmp_path):
    stream = write_stream(tmp_path / "s.jsonl")
    with stream.open("a") as fh:
        fh.write("{not json\n")
    with open_source(stream, strict=False) as opened:
        list(opened.reader)
        assert [d.kind for d in opened.reader.defects] == ["malformed-json"]
    from casewatch.monitor.reader import StreamError

    with open_source(stream, strict=True) as opened, pytest.raises(StreamError):
        list(opened.reader)


def test_the_header_is_read_through_the_source(tmp_path):
    stream = write_stream(tmp_path / "s.jsonl")
    header = json.loads(stream.read_text().splitlines()[0])["header"]
    with open_source(stream) as opened:
        next(iter(opened.reader))
        assert opened.reader.header is not None
        assert opened.reader.header.period == header["period"]
