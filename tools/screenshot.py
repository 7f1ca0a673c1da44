"""Screenshot the HTML report in headless Chromium (the picture in docs/reports.md).

    python -m tools.screenshot docs/img/report.png            # the sample reference run
    python -m tools.screenshot OUT.png --result OUTDIR/result.json --full-page
    python -m tools.screenshot docs/img/fleet.png --page out/fleet/fleet.html --width 1280

Uses the system Chromium (Debian package `chromium`) through playwright's `executable_path`;
it never downloads a browser. The browser test drives the same helpers.
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from casewatch.reports.render import ResultError, load_result, render_reports
from tools.sample import sample_result

CHROMIUM_ARGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]


def find_chromium() -> str | None:
    """The system Chromium binary, or None when it is not installed."""
    for candidate in (
        "/usr/bin/chromium",
        shutil.which("chromium"),
        shutil.which("chromium-browser"),
    ):
        if candidate and Path(candidate).exists():
            return candidate
    return None


@contextmanager
def open_page(
    html_path: Path, width: int = 1600, height: int = 1000
) -> Iterator[tuple[Any, list[str]]]:
    """A playwright page showing `html_path`, and the list collecting console errors."""
    from playwright.sync_api import sync_playwright

    chromium = find_chromium()
    if chromium is None:
        raise RuntimeError("Chromium not found: install the Debian package `chromium`")
    errors: list[str] = []
    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=chromium, args=CHROMIUM_ARGS)
        try:
            page = browser.new_page(viewport={"width": width, "height": height})
            page.on("console", lambda msg: errors.append(msg.text) if msg.type == "error" else None)
            page.on("pageerror", lambda exc: errors.append(str(exc)))
            page.goto(html_path.resolve().as_uri())
            page.wait_for_load_state("load")
            yield page, errors
        finally:
            browser.close()


def screenshot(
    html_path: Path,
    out: Path,
    *,
    width: int = 1600,
    height: int | None = None,
    full_page: bool = True,
) -> Path:
    """Save a PNG of the report; `height` clips a full-page shot to its top part."""
    with open_page(html_path, width=width) as (page, _errors):
        out.parent.mkdir(parents=True, exist_ok=True)
        if height is not None:
            page.screenshot(
                path=str(out),
                full_page=True,
                clip={"x": 0, "y": 0, "width": width, "height": height},
            )
        else:
            page.screenshot(path=str(out), full_page=full_page)
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m tools.screenshot", description=__doc__)
    parser.add_argument("out", type=Path, help="PNG file to write")
    source = parser.add_mutually_exclusive_group()
    source.add_argument("--result", type=Path, help="a result.json (default: the sample run)")
    source.add_argument(
        "--page", type=Path, help="an HTML page as written (fleet, diff, tuning, odd, compare)"
    )
    parser.add_argument("--width", type=int, default=1600)
    parser.add_argument(
        "--height", type=int, default=None, help="clip to this many pixels from the top"
    )
    parser.add_argument(
        "--full-page", action="store_true", help="the whole page (default: clip at 2300 px)"
    )
    args = parser.parse_args(argv)
    if args.page is not None and not args.page.is_file():
        print(f"reports.screenshot: {args.page}: no such file", file=sys.stderr)
        return 2
    try:
        result = (
            None
            if args.page is not None
            else load_result(args.result)
            if args.result
            else sample_result()
        )
    except ResultError as exc:
        print(f"reports.screenshot: {exc}", file=sys.stderr)
        return 2
    if find_chromium() is None:
        print(
            "reports.screenshot: Chromium not found: install the Debian package `chromium`",
            file=sys.stderr,
        )
        return 2
    height = None if args.full_page else (args.height or 2300)
    if args.page is not None:
        screenshot(args.page, args.out, width=args.width, height=height)
        print(f"screenshot: {args.out}")
        return 0
    with tempfile.TemporaryDirectory() as tmp:
        html = render_reports(result, Path(tmp), ("html",))["html"]
        screenshot(html, args.out, width=args.width, height=height)
    print(f"screenshot: {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
