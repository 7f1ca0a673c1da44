"""The live page's HTTP server: aiohttp in its own thread, so judging never waits on a page.

Routes: `/` the page (one self-contained HTML file), `/state` the state so far as JSON, and
`/events` a server-sent-event stream: a `snapshot` when a page connects, then an `update`
every broadcast interval with what changed (new ticks, statuses when they changed, the event
lists when an event arrived), and the final verdict when the stream ends.

The judge never touches a page: it writes `LiveState`, whose deltas the broadcaster serialises
once per interval for all pages. Each page has a bounded queue; a page that falls behind (a
slow reader, a stalled tab) has its queue emptied and gets one fresh snapshot instead, so
memory stays bounded and the judge's cost does not grow with the number of pages.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import threading
from dataclasses import dataclass, field
from typing import Any

from aiohttp import web

try:
    import orjson
except ImportError:  # pragma: no cover - orjson is a dependency; json is the fallback
    orjson = None  # type: ignore[assignment]

from casewatch.errors import CasewatchError
from casewatch.live.address import ServeAddress
from casewatch.live.state import Cursor, LiveState

#: Seconds between broadcasts: a page lags the judge by at most this (plus the network).
INTERVAL_S = 0.1
#: Messages a page may have waiting before it is resynchronised with a snapshot.
QUEUE_SIZE = 32
#: Seconds between updates that only move the clock ("behind real time") while nothing changes.
IDLE_UPDATE_S = 1.0


class ServeError(CasewatchError):
    """The live page cannot be served (the port is taken, the address cannot be bound)."""


def sse(kind: str, body: dict[str, Any]) -> bytes:
    """One server-sent event: `event: KIND` and the body as one JSON data line.

    Through orjson when installed (a dependency of casewatch): it holds the interpreter lock
    a fraction of the time json.dumps does, and that lock is what the judge waits for."""
    if orjson is not None:
        data = orjson.dumps(body)  # NaN cannot occur: the state keeps only finite values
    else:
        data = json.dumps(body, separators=(",", ":"), allow_nan=False).encode()
    return b"event: " + kind.encode() + b"\ndata: " + data + b"\n\n"


@dataclass(eq=False)
class _Page:
    queue: asyncio.Queue = field(default_factory=lambda: asyncio.Queue(QUEUE_SIZE))
    resyncs: int = 0


class LiveServer:
    """Serves one run's live page from a daemon thread; `start()` returns its URL."""

    def __init__(
        self,
        state: LiveState,
        page_html: str,
        address: ServeAddress,
        interval: float = INTERVAL_S,
    ) -> None:
        self.state = state
        self.page = page_html.encode()
        self.address = address
        self.interval = interval
        self.url = ""
        self.pages: set[_Page] = set()
        self._loop: asyncio.AbstractEventLoop | None = None
        self._thread: threading.Thread | None = None
        self._runner: web.AppRunner | None = None
        self._stopping: asyncio.Event | None = None
        self._cursor = Cursor()
        self._last_sent = 0.0

    # -- lifecycle (caller's thread) ------------------------------------------------------

    def start(self) -> str:
        ready = threading.Event()
        failure: list[BaseException] = []
        self._thread = threading.Thread(
            target=self._serve, args=(ready, failure), name="casewatch-live", daemon=True
        )
        self._thread.start()
        ready.wait()
        if failure:
            exc = failure[0]
            raise ServeError(
                f"--serve {self.address.host}:{self.address.port}: cannot listen ({exc})"
            ) from None
        return self.url

    def stop(self) -> None:
        """Send what is left, close every page's stream and the listener."""
        if self._loop is None or self._thread is None or self._stopping is None:
            return
        self._loop.call_soon_threadsafe(self._stopping.set)
        self._thread.join(timeout=5.0)

    # -- the server thread ----------------------------------------------------------------

    def _serve(self, ready: threading.Event, failure: list[BaseException]) -> None:
        loop = asyncio.new_event_loop()
        self._loop = loop
        asyncio.set_event_loop(loop)
        try:
            loop.run_until_complete(self._main(ready, failure))
        finally:
            loop.close()

    async def _main(self, ready: threading.Event, failure: list[BaseException]) -> None:
        self._stopping = asyncio.Event()
        app = web.Application()
        app.router.add_get("/", self._index)
        app.router.add_get("/state", self._state)
        app.router.add_get("/events", self._events)
        runner = web.AppRunner(app, access_log=None, handle_signals=False)
        await runner.setup()
        try:
            site = web.TCPSite(runner, self.address.host, self.address.port)
            await site.start()
        except OSError as exc:
            failure.append(exc)
            await runner.cleanup()
            ready.set()
            return
        port = runner.addresses[0][1]
        self.url = self.address.url(port)
        self._runner = runner
        ready.set()
        broadcaster = asyncio.create_task(self._broadcast())
        await self._stopping.wait()
        broadcaster.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await broadcaster
        await self._push()  # the last changes (the final verdict) before closing
        for page in list(self.pages):
            self._offer(page, b"")  # b"": end of stream for this page
        await asyncio.sleep(0.05)
        await runner.cleanup()

    async def _index(self, request: web.Request) -> web.Response:
        return web.Response(
            body=self.page,
            content_type="text/html",
            charset="utf-8",
            headers={"Cache-Control": "no-store", "Content-Security-Policy": CSP},
        )

    async def _state(self, request: web.Request) -> web.Response:
        body, _ = self.state.snapshot()
        return web.json_response(body, headers={"Cache-Control": "no-store"})

    async def _events(self, request: web.Request) -> web.StreamResponse:
        response = web.StreamResponse(
            headers={
                "Content-Type": "text/event-stream",
                "Cache-Control": "no-store",
                "X-Accel-Buffering": "no",
            }
        )
        await response.prepare(request)
        page = _Page()
        body, _ = self.state.snapshot()
        self.pages.add(page)
        try:
            await response.write(sse("snapshot", body))
            while True:
                message = await page.queue.get()
                if not message:
                    break
                await response.write(message)
        except (ConnectionResetError, asyncio.CancelledError):
            pass
        finally:
            self.pages.discard(page)
        return response

    def _offer(self, page: _Page, message: bytes) -> None:
        """Queue a message for one page; a full queue is emptied and resynchronised."""
        try:
            page.queue.put_nowait(message)
            return
        except asyncio.QueueFull:
            pass
        while not page.queue.empty():
            page.queue.get_nowait()
        page.resyncs += 1
        body, _ = self.state.snapshot()
        page.queue.put_nowait(sse("snapshot", body))
        if not message:
            page.queue.put_nowait(message)

    async def _broadcast(self) -> None:
        while True:
            await self._push()
            await asyncio.sleep(self.interval)

    async def _push(self) -> None:
        loop = asyncio.get_running_loop()
        body, cursor = self.state.delta(self._cursor)
        if body is None:
            return
        moved = cursor != self._cursor
        now = loop.time()
        if not moved and now - self._last_sent < IDLE_UPDATE_S:
            return
        self._cursor, self._last_sent = cursor, now
        if not self.pages:
            return
        message = sse("final" if body.get("final") else "update", body)
        for page in list(self.pages):
            self._offer(page, message)


#: The page loads nothing: inline style and script only, no other origin, no network.
CSP = (
    "default-src 'none'; style-src 'unsafe-inline'; script-src 'unsafe-inline'; "
    "connect-src 'self'; img-src data:"
)
