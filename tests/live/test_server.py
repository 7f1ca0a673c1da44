"""The live server: the page, the state as JSON, and the event stream, from its own thread."""

from __future__ import annotations

import asyncio
import http.client
import json
import re
import socket
import threading
import urllib.request

import pytest

from casewatch import api
from casewatch.evaluator.options import RunOptions, RunSinks
from casewatch.evaluator.session import evaluate_stream
from casewatch.live.address import ServeAddress
from casewatch.live.server import QUEUE_SIZE, LiveServer, ServeError, _Page, sse
from casewatch.live.state import LiveState
from casewatch.live.view import LiveView
from tests.evaluator.streams import write_case, write_stream


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    root = tmp_path_factory.mktemp("server")
    case, spec = api.prepare(str(write_case(root / "case.yaml")))
    return case, spec, write_stream(root / "s.jsonl")


class EventReader:
    """A page's event stream, read in a thread: every (event, data) in order."""

    def __init__(self, url: str) -> None:
        host, port = url.split("//")[1].rstrip("/").rsplit(":", 1)
        self.connection = http.client.HTTPConnection(host, int(port), timeout=30)
        self.connection.request("GET", "/events")
        self.response = self.connection.getresponse()
        self.events: list[tuple[str, dict]] = []
        self.thread = threading.Thread(target=self._read, daemon=True)
        self.thread.start()

    def _read(self) -> None:
        kind = ""
        for raw in self.response:
            line = raw.decode().rstrip("\n")
            if line.startswith("event: "):
                kind = line[7:]
            elif line.startswith("data: "):
                self.events.append((kind, json.loads(line[6:])))

    def join(self) -> list[tuple[str, dict]]:
        self.thread.join(timeout=30)
        assert not self.thread.is_alive(), "the event stream did not end"
        return self.events


def test_pages_get_the_run_as_it_is_judged_and_the_final_verdict(small):
    case, spec, stream = small
    view = LiveView(case, spec, str(stream), ServeAddress("127.0.0.1", 0))
    url = view.start()
    assert url.startswith("http://127.0.0.1:")
    page = urllib.request.urlopen(url, timeout=10)
    html = page.read().decode()
    assert page.headers["Content-Security-Policy"].startswith("default-src 'none'")
    assert 'id="diagram-Sn1"' in html and 'new EventSource("events")' in html
    # self-contained: no stylesheet, script or image from anywhere, links only within the page
    assert "<link" not in html and "@import" not in html
    assert all(ref.startswith("#") for ref in re.findall(r"url\(([^)]*)\)", html))
    assert all(ref.startswith("#") for ref in re.findall(r'(?:src|href)="([^"]*)"', html))
    early = EventReader(url)
    sinks = RunSinks(on_event=view.on_event(None), on_tick=view.state.on_tick)
    result = evaluate_stream(case, spec, str(stream), RunOptions(), sinks)
    state = json.loads(urllib.request.urlopen(url + "state", timeout=10).read())
    assert state["stream"]["frames"] == 100 and state["counts"]["episodes"] == 1
    late = EventReader(url)  # opened after the stream ended, before the verdict is in
    view.finish(result, linger=0.3)
    events = early.join()
    assert events[0][0] == "snapshot" and events[-1][0] == "final"
    assert events[-1][1]["final"]["verdict"] == "undermined"
    seen = [t for kind, body in events for t, _ in body.get("ticks", [])]
    assert [round(t, 6) for t in seen] == [round(k / 10, 6) for k in range(100)]  # each once
    statuses = [body["status"] for _, body in events if body.get("status")]
    assert statuses[-1] == {s.node_id: s.timeline[-1].status for s in result.status}
    closed = next(body["closed"] for _, body in reversed(events) if "closed" in body)
    assert [(e["node"], e["start"], e["end"]) for e in closed] == [("Sn1", 2.0, 3.0)]
    late_events = late.join()
    assert late_events[0][0] == "snapshot" and len(late_events[0][1]["ticks"]) == 100
    assert late_events[-1][1]["final"]["frames"] == 100


def test_a_page_that_falls_behind_gets_one_snapshot_instead_of_a_growing_queue(small):
    _, spec, _ = small
    server = LiveServer(LiveState(spec, 0.1), "", ServeAddress("127.0.0.1", 0))

    async def scenario() -> list[bytes]:
        page = _Page()
        for k in range(QUEUE_SIZE):
            server._offer(page, sse("update", {"k": k}))
        server._offer(page, sse("update", {"k": QUEUE_SIZE}))  # one too many
        assert page.resyncs == 1
        return [page.queue.get_nowait() for _ in range(page.queue.qsize())]

    queued = asyncio.run(scenario())
    assert len(queued) == 1 and queued[0].startswith(b"event: snapshot\n")


def test_a_taken_port_is_a_clear_error(small):
    _, spec, _ = small
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        server = LiveServer(LiveState(spec, 0.1), "", ServeAddress("127.0.0.1", port))
        with pytest.raises(ServeError, match=f"--serve 127.0.0.1:{port}: cannot listen"):
            server.start()
