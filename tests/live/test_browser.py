"""The live page in headless Chromium while a bundled drive is fed at real time.

highway-tailgating from 14.0 to 22.0 s (80 frames, 8 s at real time): the hazard rule CSn2
(tailgating) holds from 18.6 s and is announced as a hazard event once it lasted its 1 s
min_duration. The page must show CSn2 violated within one second of the 18.6 s frame being
written to casewatch's standard input, with 20 more pages open on the same run (event streams
read by another process), while judging keeps up with real time (less than 0.5 s behind at the
last frame), keep the final verdict after the stream ends, and give it to a page opened late.
"""

from __future__ import annotations

import json
import subprocess
import sys
import urllib.request

import pytest

from bench.live import READER
from tests.live.feed import DRIVE, LiveRun, drive_lines
from tools.screenshot import CHROMIUM_ARGS, find_chromium

pytestmark = [
    pytest.mark.browser,
    pytest.mark.skipif(find_chromium() is None, reason="needs Chromium (Debian package chromium)"),
]

ONSET = 18.6
EXTRA_PAGES = 20


def first_change(page, node: str, status: str) -> dict:
    return page.evaluate(
        "([node, status]) => window.casewatchChanges.find("
        "c => c.node === node && c.status === status)",
        [node, status],
    )


def test_the_page_follows_a_real_time_drive_and_keeps_the_verdict(tmp_path):
    from playwright.sync_api import sync_playwright

    header, frames = drive_lines(DRIVE, 14.0, 22.0)
    run = LiveRun(tmp_path / "out", "--serve-linger", "4")
    host, port = run.url.split("//")[1].rstrip("/").rsplit(":", 1)
    others = subprocess.Popen(
        [sys.executable, "-c", READER, host, port, str(EXTRA_PAGES)],
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert others.stdout is not None and others.stdout.readline().strip() == "open"
        with sync_playwright() as playwright:
            browser = playwright.chromium.launch(
                executable_path=find_chromium(), args=CHROMIUM_ARGS
            )
            try:
                page = browser.new_page(viewport={"width": 1400, "height": 1000})
                errors: list[str] = []
                page.on("pageerror", lambda exc: errors.append(str(exc)))
                page.goto(run.url)
                page.wait_for_selector("body[data-connection=live]", timeout=10_000)
                feeder = run.feed_in_background(header, frames)
                shown = None
                for _ in range(300):  # polled: the page's CSP forbids wait_for_function's eval
                    shown = first_change(page, "CSn2", "violated")
                    if shown is not None:
                        break
                    page.wait_for_timeout(100)
                assert shown is not None, "the page never showed CSn2 violated"
                lag = shown["at"] / 1000.0 - run.sent[ONSET]
                assert 0.0 < lag < 1.0, f"CSn2 shown {lag:.3f} s after its onset frame was sent"
                print(f"CSn2 violated on the page {lag:.3f} s after its onset frame was sent")
                assert shown["t"] >= ONSET
                # the open hazard event once announced (19.5 s), with its trace to the root goal
                page.wait_for_selector("#open li:has-text('CSn2 → G5 → S1 → G1')", timeout=5_000)

                feeder.join(timeout=30)
                page.wait_for_selector("body[data-connection=ended]", timeout=10_000)
                # the judge kept up with real time with 21 pages open: at the last frame it
                # was behind its most punctual frame by less than half a second
                state = json.loads(urllib.request.urlopen(run.url + "state", timeout=10).read())
                assert state["stream"]["frames"] == 80
                assert 0.0 <= state["stream"]["behind"] < 0.5, state["stream"]
                assert "final verdict over 80 frames" in page.inner_text("#verdict-note")
                late = browser.new_page()
                late.goto(run.url)
                late.wait_for_selector("body[data-connection=ended]", timeout=10_000)
                assert "final verdict over 80 frames" in late.inner_text("#verdict-note")
                assert late.get_attribute("#diagram-CSn2", "data-status") == "violated"
                assert run.wait(timeout=30) == 1  # a hazard event: findings
                result = json.loads((tmp_path / "out" / "result.json").read_text())
                verdict = result["verdict"].replace("-", " ").upper()
                for shown_page in (page, late):
                    assert shown_page.inner_text("#verdict-word") == verdict
                last = {s["node_id"]: s["timeline"][-1]["status"] for s in result["status"]}
                assert page.get_attribute("#diagram-G1", "data-status") == last["G1"]
                page.wait_for_timeout(500)  # the server is gone: the page keeps the verdict
                assert page.inner_text("#verdict-word") == verdict
                assert page.get_attribute("body", "data-connection") == "ended"
                assert errors == []
            finally:
                browser.close()
        out, _ = others.communicate(timeout=30)
        assert int(out.split()[-1]) > 0  # the 20 other pages got their events to the end
    finally:
        for process in (others, run.process):
            if process.poll() is None:
                process.kill()
