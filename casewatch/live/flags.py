"""The `run` command's live options: `--serve`, `--foxglove`, `--serve-public`,
`--serve-linger` and `--annotate`, and the few steps `run` takes with them.

Import-light on purpose: `casewatch run` imports this for its options; the server (aiohttp)
and the MCAP writer (protobuf) are imported only when their option is given, and a missing
`live` extra is one clear line, exit 2.
"""

from __future__ import annotations

import argparse
import sys
import time
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
        "--foxglove",
        metavar="[HOST:]PORT",
        help="publish the annotate topics live on a Foxglove WebSocket server while judging "
        "(one stream; HOST defaults to 127.0.0.1; docs/live.md)",
    )
    p.add_argument(
        "--serve-public",
        action="store_true",
        help="allow --serve or --foxglove on an address other than loopback (no login)",
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
    serving = args.serve is not None or args.foxglove is not None
    if not serving and args.annotate is None:
        if args.serve_public or args.serve_linger:
            return "--serve-public and --serve-linger go with --serve or --foxglove"
        return None
    if not single:
        return "--serve, --foxglove and --annotate go with one stream"
    if serving and args.stl_engine not in ("auto", "rtamt"):
        # auto: a run with a live page is judged tick by tick (session: a tick observer)
        return (
            "--serve and --foxglove show ticks as they are judged: they need --stl-engine "
            "rtamt or auto"
        )
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


class LiveOutputs:
    """The live page and the Foxglove server of one run (either may be absent)."""

    def __init__(self, page: Any, fox: Any) -> None:
        self.page, self.fox = page, fox

    def on_event(self, then: Callable[[Any], None] | None) -> Callable[[Any], None]:
        def sink(event: Any) -> None:
            if self.page is not None:
                self.page.state.on_event(event)
            if self.fox is not None:
                self.fox.on_event(event)
            if then is not None:
                then(event)

        return sink

    def on_tick(self, frame: Any, statuses: Any, evaluator: Any, reader: Any) -> None:
        if self.page is not None:
            self.page.state.on_tick(frame, statuses, evaluator, reader)
        if self.fox is not None:
            self.fox.on_tick(frame, statuses, evaluator, reader)

    def finish(self, result: Any, message: str, linger: float) -> None:
        try:
            if self.page is not None:
                self.page.finish(result, message, linger=linger)
            elif linger > 0:
                time.sleep(linger)
        except KeyboardInterrupt:
            pass
        finally:
            if self.fox is not None:
                self.fox.stop()


def _missing(option: str, exc: ImportError) -> LiveExtraMissing:
    return LiveExtraMissing(f"{option} needs the live extra ({exc.name} is missing): {EXTRA_HINT}")


def start_view(args: argparse.Namespace, case: Any, spec: Any, stream: str) -> Any:
    """The live page and the Foxglove server of this run, listening (their addresses printed
    to standard error), or None without --serve and --foxglove."""
    if args.serve is None and args.foxglove is None:
        return None
    from casewatch.live.address import parse_address

    page = fox = None
    if args.serve is not None:
        address = parse_address(args.serve, public=args.serve_public)
        try:
            from casewatch.live.view import LiveView
        except ImportError as exc:
            raise _missing("--serve", exc) from None
        page = LiveView(case, spec, "standard input" if stream == "-" else stream, address)
        print(f"casewatch run: live page at {page.start()}", file=sys.stderr, flush=True)
    if args.foxglove is not None:
        address = parse_address(args.foxglove, public=args.serve_public)
        try:
            from casewatch.live.foxglove_ws import FoxgloveLive
        except ImportError as exc:
            raise _missing("--foxglove", exc) from None
        channels = list(case.monitor.channels)
        fox = FoxgloveLive(channels, spec.root_id, case.monitor.period, address)
        print(f"casewatch run: Foxglove WebSocket at {fox.url}", file=sys.stderr, flush=True)
    return LiveOutputs(page, fox)


def chain(view: Any, on_event: Callable[[Any], None]) -> Callable[[Any], None]:
    """The run's event sink: the live outputs' first when serving, then the terminal's."""
    return on_event if view is None else view.on_event(on_event)


def tick_hook(view: Any) -> Callable[..., None] | None:
    return None if view is None else view.on_tick


def finish(view: Any, result: Any, args: argparse.Namespace, message: str = "") -> None:
    """The final verdict (or why there is none) on the page; linger; stop serving."""
    if view is not None:
        view.finish(result, message, args.serve_linger)


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
