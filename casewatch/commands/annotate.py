"""`casewatch annotate RUN_DIR RECORDING -o OUT.mcap`: the verdicts inside the recording.

Writes an MCAP file holding the recording's own messages (an MCAP bag) or its frames drawn as
Foxglove scene entities (a JSON Lines drive), plus casewatch's topics: `/casewatch/log`
(foxglove.Log), `/casewatch/status` (every node's status per tick) and `/casewatch/markers`
(foxglove.SceneUpdate). docs/live.md. Exit codes: 0 written, 2 a run folder or recording that
cannot be used (not the stream the run judged, not MCAP, damaged), or the `live` extra missing.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

#: What to install when the Foxglove schemas or the MCAP protobuf support are missing.
EXTRA_HINT = "pip install 'casewatch[live]'"


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "annotate",
        help="write a run's verdicts into its recording (MCAP with Foxglove schemas)",
        description="Write OUT.mcap: the recording's messages (or a JSON Lines drive as "
        "Foxglove scene entities) plus the run's episodes and events as foxglove.Log, each "
        "node's status per tick and episode markers (docs/live.md).",
    )
    p.add_argument("run", type=Path, help="a run folder (with result.json and events.jsonl)")
    p.add_argument(
        "recording",
        type=Path,
        help="the stream the run judged: an MCAP bag (.mcap or a bag folder) or a JSON "
        "Lines stream (.jsonl, .jsonl.gz)",
    )
    p.add_argument("-o", "--out", required=True, type=Path, help="the MCAP file to write")


def load_annotate():
    """`casewatch.annotate.annotate`, or None with a message when the extra is missing."""
    try:
        from casewatch.annotate import annotate
    except ImportError as exc:
        print(
            f"casewatch annotate: needs the Foxglove schemas and MCAP protobuf support "
            f"({exc.name} is missing): {EXTRA_HINT}",
            file=sys.stderr,
        )
        return None
    return annotate


def write_annotated(run: Path, recording: Path, out: Path, command: str = "annotate") -> int:
    """Annotate and print what was written; the exit code (errors are CasewatchError, 2)."""
    annotate = load_annotate()
    if annotate is None:
        return 2
    done = annotate(run, recording, out)
    if done.damage:
        print(
            f"casewatch {command}: warning: {done.damage}; copied the messages before it",
            file=sys.stderr,
        )
    ours = {k: v for k, v in done.counts.items() if k in done.topics}
    print(
        f"{done.path}: {done.copied} messages of the recording, "
        + ", ".join(f"{topic} {n}" for topic, n in sorted(ours.items()))
    )
    return 0


def main(args: argparse.Namespace) -> int:
    if args.out.suffix != ".mcap":
        print(
            f"casewatch annotate: {args.out}: the output is an MCAP file (.mcap)", file=sys.stderr
        )
        return 2
    return write_annotated(args.run, args.recording, args.out)
