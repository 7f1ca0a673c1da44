"""The `run` command's live options: `--serve`, `--serve-public`, `--serve-linger` and
`--annotate`, and the few steps `run` takes with them.

Import-light on purpose: `casewatch run` imports this for its options; the server (aiohttp)
and the MCAP writer (protobuf) are imported only when their option is given, and a missing
`live` extra is one clear line, exit 2.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from casewatch.errors import CasewatchError

#: What to install when aiohttp or the Foxglove schemas are missing.
EXTRA_HINT = "pip install 'casewatch[live]'"


class LiveExtraMissing(CasewatchError):
    """`--serve` or `--annotate` without the `live` extra installed."""


def add_options(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--serve",
        metavar="[HOST:]PORT",
        help="serve a live status page while judging (one stream; HOST defaults to "
        "127.0.0.1; PORT 0 picks a free one; docs/live.md)",
    )
    p.add_argument(
        "--serve-public",
        action="store_true",
        help="allow --serve on an address other than loopback (the page has no login)",
    )
    p.add_argument(
        "--serve-linger",
        type=float,
        default=0.0,
        metavar="SECONDS",
        help="with --serve: keep serving the final verdict this long after the stream ends "
        "(Ctrl-C ends it sooner; default 0)",
    )
    p.add_argument(
        "--annotate",
        type=Path,
        metavar="OUT.mcap",
        help="also write the recording with the verdicts as an MCAP file (one stream file "
        "or bag; as casewatch annotate, docs/live.md)",
    )


def refusal(args: argparse.Namespace, single: bool) -> str | None:
    """Why these live options cannot go with this command line, or None."""
    if args.serve is None and args.annotate is None:
        if args.serve_public or args.serve_linger:
            return "--serve-public and --serve-linger go with --serve"
        return None
    if not single:
        return "--serve and --annotate go with one stream"
    if args.serve is not None and args.stl_engine not in ("auto", "rtamt"):
        # auto: a run with a live page is judged tick by tick (session: a tick observer)
        return "--serve shows ticks as they are judged: it needs --stl-engine rtamt or auto"
    if args.serve_linger < 0:
        return "--serve-linger must be 0 or more seconds"
    if args.annotate is not None:
        if args.streams[0] == "-":
            return (
                "--annotate needs the recording; with '-' save the stream to a file and run "
                "casewatch annotate OUT FILE -o OUT.mcap"
            )
        if args.annotate.suffix != ".mcap":
            return f"--annotate {args.annotate}: the output is an MCAP file (.mcap)"
    return None


def start_view(args: argparse.Namespace, case: Any, spec: Any, stream: str) -> Any:
    """The live page of this run, listening (its URL printed to standard error), or None
    without --serve."""
    if args.serve is None:
        return None
    from casewatch.live.address import parse_address

    address = parse_address(args.serve, public=args.serve_public)
    try:
        from casewatch.live.view import LiveView
    except ImportError as exc:
        raise LiveExtraMissing(
            f"--serve needs aiohttp ({exc.name} is missing): {EXTRA_HINT}"
        ) from None
    view = LiveView(case, spec, "standard input" if stream == "-" else stream, address)
    url = view.start()
    print(f"casewatch run: live page at {url}", file=sys.stderr, flush=True)
    return view


def chain(view: Any, on_event: Callable[[Any], None]) -> Callable[[Any], None]:
    """The run's event sink: the page's first when serving, then the terminal's."""
    return on_event if view is None else view.on_event(on_event)


def tick_hook(view: Any) -> Callable[..., None] | None:
    return None if view is None else view.state.on_tick


def finish(view: Any, result: Any, args: argparse.Namespace, message: str = "") -> None:
    """The final verdict (or why there is none) on the page; linger; stop serving."""
    if view is not None:
        view.finish(result, message, linger=args.serve_linger)


def annotate_after(args: argparse.Namespace, stream: str) -> int:
    """`--annotate`: the recording with this run's verdicts; 0, or 2 when it cannot be written."""
    if args.annotate is None:
        return 0
    from casewatch.commands.annotate import write_annotated

    try:
        return write_annotated(args.out, Path(stream), args.annotate)
    except CasewatchError as exc:
        print(f"casewatch run: --annotate: {exc}", file=sys.stderr)
        return 2
