"""One run's live page: the state, the server and the hooks the run calls.

Front-door composition: `LiveView` ties the run's observer hooks (`RunSinks.on_tick`,
`on_event`) to a `LiveState`, renders the page once, and serves both from `LiveServer`'s own
thread. The judge only writes the state (microseconds a frame); pages read it. docs/live.md.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from casewatch.evaluator.result import RunResult
from casewatch.evaluator.session import case_info
from casewatch.live.address import ServeAddress
from casewatch.live.page import render_live_page
from casewatch.live.server import LiveServer
from casewatch.live.state import LiveState
from casewatch.safety_case.model import Case
from casewatch.spec.model import CompiledSpec


class LiveView:
    """One run's live page: its state, its server, and the hooks the run calls."""

    def __init__(
        self, case: Case, spec: CompiledSpec, stream_name: str, address: ServeAddress
    ) -> None:
        self.state = LiveState(spec, case.monitor.period)
        page = render_live_page(case_info(case, spec), spec, stream_name)
        self.server = LiveServer(self.state, page, address)
        self.url = ""

    def start(self) -> str:
        """Listen (raises `ServeError` when the address cannot be bound); the page's URL."""
        self.url = self.server.start()
        return self.url

    def on_event(self, then: Callable[[Any], None] | None) -> Callable[[Any], None]:
        """An event sink that updates the page, then calls `then` (the terminal's printer)."""

        def sink(event: Any) -> None:
            self.state.on_event(event)
            if then is not None:
                then(event)

        return sink

    def finish(self, result: RunResult | None, message: str = "", linger: float = 0.0) -> None:
        """Show the final verdict (or `message`), keep serving `linger` seconds (Ctrl-C ends
        it early) so late pages still get it, then stop."""
        self.state.finish(result, message)
        try:
            if linger > 0:
                time.sleep(linger)
        except KeyboardInterrupt:
            pass
        finally:
            self.server.stop()
