"""`casewatch convert SRC -o OUT`: ROS 2 bags to JSON Lines streams and back.

- A bag (`.mcap`, `.db3` or a bag folder) -> `OUT.jsonl` or `OUT.jsonl.gz`: the frames the
  evaluator would judge, with a header (channels, period, the bag's start time), so the rest
  of the toolchain and users' own scripts work on them.
- A stream -> a bag folder `OUT` (`--storage mcap` or `sqlite3`) with Autoware messages; without
  `--topics`, Autoware-style topic names are used and the mapping is written beside the bag
  as `OUT.topics.yaml`, ready for `casewatch run CASE OUT --topics OUT.topics.yaml`.
- `--list-topics BAG`: the topics a bag holds, to write a mapping.

Exit codes: 0 written (stream defects and dropouts are counted, never hidden), 2 input that
cannot be used.
"""

from __future__ import annotations

import argparse
import gzip
import math
import sys
from pathlib import Path

import orjson
import yaml

from casewatch.monitor.bags.mapping import MappingError, TopicMapping, load_mapping, resolve_mapping
from casewatch.monitor.bags.reader import BagError
from casewatch.monitor.bags.storage import StorageError, open_storage
from casewatch.monitor.bags.writer import BagWriteError, default_mapping, write_bag
from casewatch.monitor.encode import frame_to_dict, header_to_dict
from casewatch.monitor.frames import Header
from casewatch.monitor.reader import StreamError
from casewatch.monitor.source import FrameReader, SourceError, open_source, source_kind
from casewatch.safety_case.findings import CaseError


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "convert",
        help="convert a ROS 2 bag to a JSON Lines stream, or a stream to a bag",
        description="Convert a ROS 2 bag (MCAP or sqlite3; Autoware messages) into casewatch "
        "frames (JSON Lines, .gz compressed when OUT ends in .gz), or a JSON Lines "
        "stream into a bag. Topics come from --topics or the --case's "
        "monitor.topics (docs/bags.md).",
    )
    p.add_argument("source", metavar="SRC", help="a bag (.mcap, .db3, bag folder) or a stream")
    p.add_argument(
        "-o",
        "--out",
        type=Path,
        help="output: a .jsonl(.gz) file for a bag, a new bag folder for a stream",
    )
    p.add_argument("--topics", type=Path, metavar="FILE", help="the topic mapping (YAML)")
    p.add_argument(
        "--case",
        metavar="CASE",
        help="take channels, period and monitor.topics from this safety case",
    )
    p.add_argument(
        "--period",
        type=float,
        default=None,
        help="seconds between frames (default: the case's monitor.period, else 0.1)",
    )
    p.add_argument(
        "--storage",
        choices=("mcap", "sqlite3"),
        default="mcap",
        help="storage of a bag written from a stream (default: mcap)",
    )
    p.add_argument(
        "--compress",
        action="store_true",
        help="zstd-compress the chunks of an MCAP bag written from a stream",
    )
    p.add_argument(
        "--ego-size",
        nargs=2,
        type=float,
        metavar=("LENGTH", "WIDTH"),
        default=None,
        help="ego footprint for the default mapping (default: the stream's first ego box)",
    )
    p.add_argument(
        "--list-topics",
        action="store_true",
        help="only list the bag's topics, types and message counts",
    )


def main(args: argparse.Namespace) -> int:
    try:
        if args.list_topics:
            return _list_topics(args.source)
        if args.out is None:
            raise _Usage("-o/--out is required (a .jsonl.gz file or a new bag folder)")
        _check_numbers(args)
        if source_kind(args.source) == "bag":
            return _bag_to_stream(args)
        return _stream_to_bag(args)
    except _Usage as exc:
        print(f"casewatch convert: {exc}", file=sys.stderr)
        return 2
    except (MappingError, BagError, BagWriteError, StreamError, SourceError) as exc:
        print(f"casewatch convert: {exc}", file=sys.stderr)
        return 2
    except CaseError as exc:
        for finding in exc.findings:
            print(finding.format(), file=sys.stderr)
        print(f"casewatch convert: {args.case} has errors", file=sys.stderr)
        return 2


class _Usage(Exception):
    pass


#: --period range: a tick per millisecond to one a minute (a negative period never ends).
PERIOD_RANGE = (0.001, 60.0)


def _check_numbers(args: argparse.Namespace) -> None:
    """--period and --ego-size are finite and within range, before anything is written."""
    low, high = PERIOD_RANGE
    if args.period is not None and not (math.isfinite(args.period) and low <= args.period <= high):
        raise _Usage(
            f"--period {args.period!r}: expected the seconds between frames, "
            f"from {low:g} to {high:g} (e.g. --period 0.1)"
        )
    if args.ego_size is not None:
        for name, value in zip(("LENGTH", "WIDTH"), args.ego_size, strict=True):
            if not (math.isfinite(value) and 0 < value <= 100):
                raise _Usage(
                    f"--ego-size {name} {value!r}: expected metres, more than 0 and "
                    "at most 100 (e.g. --ego-size 4.5 1.8)"
                )


def _list_topics(source: str) -> int:
    if source_kind(source) != "bag":
        raise _Usage(f"{source}: not a ROS 2 bag (an .mcap or .db3 file or a bag folder)")
    try:  # as `run` opens it: an MCAP file cut short is listed up to the cut
        storage = open_storage(Path(source))
    except StorageError as exc:
        raise _Usage(f"{source}: {exc}") from None
    try:
        rows = sorted((t.topic, t.msgtype, t.count) for t in storage.topics.values())
    finally:
        storage.close()
    if not rows:
        why = (
            "is cut short or damaged before it records any topic"
            if storage.recovered
            else "holds no topic (no channel is recorded in it)"
        )
        raise _Usage(f"{source}: the bag {why}, so there is nothing to map or judge")
    if storage.recovered:
        print(
            f"{source}: the file is cut short or damaged; the topics and message counts up "
            "to the break:",
            file=sys.stderr,
        )
    width = max(len(t) for t, _, _ in rows)
    for topic, msgtype, count in rows:
        print(f"{topic:<{width}}  {msgtype}  ({count} messages)")
    return 0


def _case_settings(args) -> tuple[list[str] | None, float, str | None, str | dict | None]:
    """Channels, period, case path and monitor.topics from `--case` (or defaults)."""
    if args.case is None:
        return None, args.period or 0.1, None, None
    from casewatch import api

    case, _spec = api.prepare(args.case)
    return (
        list(case.monitor.channels),
        args.period or case.monitor.period,
        case.path,
        case.monitor.topics,
    )


def _bag_to_stream(args) -> int:
    channels, period, case_path, case_topics = _case_settings(args)
    source = open_source(
        args.source,
        channels=channels,
        period=period,
        topics=args.topics,
        case_path=case_path,
        case_topics=case_topics,
    )
    reader = source.reader
    out: Path = args.out
    if not out.name.endswith((".jsonl", ".jsonl.gz", ".ndjson", ".ndjson.gz")):
        raise _Usage(f"{out}: a bag converts to a .jsonl or .jsonl.gz file")
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(out.name + ".part")
    opener = gzip.open if out.name.endswith(".gz") else open
    with opener(tmp, "wb") as fh:
        first = True
        for frame in reader:
            if first:  # the header carries the bag's start time, known at the first tick
                fh.write(orjson.dumps(header_to_dict(_bag_header(reader))) + b"\n")
                first = False
            fh.write(orjson.dumps(frame_to_dict(frame)) + b"\n")
        if first:
            fh.write(orjson.dumps(header_to_dict(_bag_header(reader))) + b"\n")
    tmp.replace(out)
    drop = ", ".join(f"{c} {n}" for c, n in reader.dropouts.items())
    print(
        f"{args.source}: {reader.frames_read} frames -> {out} ({len(reader.defects)} defects; "
        f"dropouts: {drop})",
        file=sys.stderr,
    )
    for d in reader.defects[:10]:
        print(f"  {d.format()}", file=sys.stderr)
    for topic, report in source.topic_report().items():
        if report["missing_ticks"] or report["late_messages"]:
            print(
                f"  {topic}: missing or stale at {report['missing_ticks']} ticks, "
                f"{report['late_messages']} late messages",
                file=sys.stderr,
            )
    return 0


def _stream_to_bag(args) -> int:
    source = args.source
    if not Path(source).is_file():
        raise _Usage(f"{source}: no such stream or bag")
    channels, period, case_path, case_topics = _case_settings(args)
    frames = _frames(source, channels, period)
    if args.topics is not None or case_topics is not None:
        mapping: TopicMapping = resolve_mapping(args.topics, case_path, case_topics).mapping
        written = write_bag(frames, args.out, mapping, args.storage, compress=args.compress)
        saved = None
    else:
        first, header = _peek(source, channels)
        if first is None:
            raise _Usage(f"{source}: no frames to convert")
        length, width = args.ego_size or _ego_box(first)
        names = header.channels if header is not None and header.channels else list(first.channels)
        plain = default_mapping(
            names,
            sorted(first.signals),
            length,
            width,
            coverage=header.coverage if header is not None else None,
            period=period,
        )
        mapping = TopicMapping.model_validate(plain)
        written = write_bag(
            _frames(source, channels, period),
            args.out,
            mapping,
            args.storage,
            compress=args.compress,
        )
        saved = args.out.with_name(args.out.name + ".topics.yaml")
        saved.write_text(
            "# written by casewatch convert: which topics are which channel\n"
            + yaml.safe_dump(plain, sort_keys=False),
            encoding="utf-8",
        )
        load_mapping(saved)  # what we wrote must read back
    print(f"{source}: {written} frames -> {args.out} ({args.storage})", file=sys.stderr)
    if saved is not None:
        print(
            f"  topic mapping: {saved}\n  judge it with: casewatch run CASE {args.out} "
            f"--topics {saved} -o OUT",
            file=sys.stderr,
        )
    return 0


def _frames(source: str, channels: list[str] | None, period: float | None):
    """A stream's frames, strictly (a converted bag holds only what was read), closed once
    read."""
    with open_source(source, channels=channels, period=period, strict=True) as opened:
        yield from opened.reader


def _peek(source: str, channels: list[str] | None):
    """The first frame and the header of a stream."""
    with open_source(source, channels=channels, strict=True) as opened:
        reader = opened.reader
        for frame in reader:
            return frame, reader.header
        return None, reader.header


def _bag_header(reader: FrameReader) -> Header:
    """A bag reader's header (it makes one when it opens the bag, before any frame)."""
    assert reader.header is not None
    return reader.header


def _ego_box(frame) -> tuple[float, float]:
    for state in frame.channels.values():
        if state.ego.half is not None:
            return 2.0 * state.ego.half[0], 2.0 * state.ego.half[1]
    raise _Usage("the stream's ego is a polygon; give --ego-size LENGTH WIDTH")
