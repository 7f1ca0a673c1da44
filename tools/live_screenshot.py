"""The pictures in docs/live.md: the live page mid-drive, and an annotated recording read back.

    python -m tools.live_screenshot docs/img/live.png docs/img/annotate.png

1. `casewatch run reference-case.yaml - --serve 0` is fed highway-tailgating from 0 to 25 s at
   twice real time; the page is captured in headless Chromium at 21 s, the tailgating hazard
   open.
2. The same drive judged and annotated (`casewatch annotate`); the MCAP file is read back with
   the mcap reader and drawn as a page: its topics with schemas, counts and times, the scene
   of one channel from above at the hazard's onset with the episode markers live then, and the
   log lines around it. (Foxglove itself is a desktop or web application that cannot run
   here; this shows what it reads.)

Uses the system Chromium (Debian package `chromium`) through playwright, never a download.
"""

from __future__ import annotations

import argparse
import gzip
import html
import json
import os
import re
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

from tools.screenshot import CHROMIUM_ARGS, find_chromium

REPO = Path(__file__).resolve().parents[1]
CASE = REPO / "examples" / "reference-case.yaml"
DRIVE = REPO / "examples" / "data" / "highway-tailgating.jsonl.gz"


def _lines(until: float) -> tuple[str, list[tuple[float, str]]]:
    header, frames = "", []
    with gzip.open(DRIVE, "rt", encoding="utf-8") as fh:
        for line in fh:
            record = json.loads(line)
            if "header" in record:
                header = line
            elif record["t"] < until:
                frames.append((record["t"], line))
    return header, frames


def live_page(out: Path, speed: float = 2.0, at: float = 21.0) -> None:
    from playwright.sync_api import sync_playwright

    header, frames = _lines(at + 4.0)  # still running when the page is captured
    with tempfile.TemporaryDirectory() as tmp:
        process = subprocess.Popen(
            [
                *(sys.executable, "-m", "casewatch", "run", str(CASE), "-", "--serve", "0"),
                *("-o", tmp, "--format", "none", "--quiet", "--serve-linger", "2"),
            ],
            stdin=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            cwd=REPO,
            env=dict(os.environ, PYTHONUNBUFFERED="1"),
        )
        assert process.stdin is not None and process.stderr is not None
        url = ""
        while not url:
            line = process.stderr.readline()
            if not line:
                raise RuntimeError("casewatch run did not start its live page")
            found = re.search(r"live page at (http://\S+)", line)
            url = found.group(1) if found else ""
        reached = threading.Event()

        def feed() -> None:
            process.stdin.write(header)
            start = time.monotonic()
            for t, line in frames:
                time.sleep(max(0.0, start + t / speed - time.monotonic()))
                process.stdin.write(line)
                process.stdin.flush()
                if t >= at:
                    reached.set()
            process.stdin.close()

        with sync_playwright() as playwright:
            browser = playwright.chromium.launch(
                executable_path=find_chromium(), args=CHROMIUM_ARGS
            )
            page = browser.new_page(viewport={"width": 1400, "height": 1650})
            page.goto(url)
            threading.Thread(target=feed, daemon=True).start()
            reached.wait(timeout=120)
            time.sleep(0.4)  # the next broadcast
            out.parent.mkdir(parents=True, exist_ok=True)
            page.screenshot(path=str(out))
            browser.close()
        process.wait(timeout=60)
    print(f"screenshot: {out}")


def _scene_svg(update, markers: list, width: int = 860, height: int = 300) -> str:
    """One SceneUpdate (and markers) from above, x along the road, 60 m around the ego."""
    ego = next(e for e in update.entities if e.id == "ego").cubes[0].pose.position
    x0, y0, span = ego.x - 30.0, ego.y, 80.0
    scale = width / span

    def px(x: float, y: float) -> tuple[float, float]:
        return (x - x0) * scale, height / 2 - (y - y0) * scale

    parts = [f'<rect width="{width}" height="{height}" fill="#f4f1ea"/>']
    for entity in update.entities:
        for cube in entity.cubes:
            p, s = cube.pose.position, cube.size
            cx, cy = px(p.x, p.y)
            fill = "#1565c0" if entity.id == "ego" else "#607d8b"
            parts.append(
                f'<rect x="{cx - s.x * scale / 2:.1f}" y="{cy - s.y * scale / 2:.1f}" '
                f'width="{s.x * scale:.1f}" height="{s.y * scale:.1f}" fill="{fill}" '
                f'opacity="0.8"><title>{html.escape(entity.id)}</title></rect>'
            )
        for line in entity.lines:
            pts = " ".join("{:.1f},{:.1f}".format(*px(q.x, q.y)) for q in line.points)
            colour = "#1565c0" if entity.id == "plan" else "#90a4ae"
            parts.append(
                f'<polyline points="{pts}" fill="none" stroke="{colour}" stroke-width="2"/>'
            )
    for k, entity in enumerate(markers):
        for sphere in entity.spheres:
            cx, cy = px(sphere.pose.position.x, sphere.pose.position.y)
            c = sphere.color
            fill = f"rgb({c.r * 255:.0f},{c.g * 255:.0f},{c.b * 255:.0f})"
            parts.append(
                f'<circle cx="{cx:.1f}" cy="{cy:.1f}" r="{1.5 * scale:.1f}" fill="{fill}" '
                'opacity="0.5"/>'
            )
            for text in entity.texts:  # labels stacked above the road, one line each
                parts.append(
                    f'<line x1="{cx:.1f}" y1="{cy:.1f}" x2="{cx:.1f}" y2="{24 + 16 * k}" '
                    f'stroke="{fill}" stroke-width="0.8"/><text x="{cx + 4:.1f}" '
                    f'y="{22 + 16 * k}" fill="{fill}" font-size="13" font-weight="700">'
                    f"{html.escape(text.text)}</text>"
                )
    return f'<svg width="{width}" height="{height}">{"".join(parts)}</svg>'


def annotated_page(out: Path) -> None:
    from mcap.decoder import DecoderFactory as McapDecoderFactory
    from mcap.reader import make_reader
    from mcap_protobuf.decoder import DecoderFactory

    class JsonDecoders(McapDecoderFactory):
        def decoder_for(self, message_encoding, schema):
            return json.loads if message_encoding == "json" else None

    from playwright.sync_api import sync_playwright

    from casewatch.annotate import annotate

    with tempfile.TemporaryDirectory() as tmp:
        run = Path(tmp) / "run"
        subprocess.run(
            [
                *(sys.executable, "-m", "casewatch", "run", str(CASE), str(DRIVE)),
                *("-o", str(run), "--format", "none", "--quiet"),
            ],
            cwd=REPO,
            check=False,
        )
        mcap = annotate(run, DRIVE, Path(tmp) / "highway-tailgating.mcap").path
        result = json.loads((run / "result.json").read_text())
        hazard = next(e for e in result["episodes"] if e["kind"] == "hazard")
        at = round((hazard["start"] + 0.2) * 1e9)
        rows, logs, scene, markers, status = [], [], None, [], None
        with open(mcap, "rb") as fh:
            reader = make_reader(fh, decoder_factories=[DecoderFactory(), JsonDecoders()])
            summary = reader.get_summary()
            stats = summary.statistics
            for cid, channel in sorted(summary.channels.items(), key=lambda c: c[1].topic):
                schema = summary.schemas[channel.schema_id]
                rows.append(
                    (
                        channel.topic,
                        schema.name,
                        schema.encoding,
                        channel.message_encoding,
                        stats.channel_message_counts[cid],
                    )
                )
            for _schema, channel, message, decoded in reader.iter_decoded_messages():
                t = message.log_time
                if channel.topic == "/casewatch/log" and at - 3e9 <= t <= at + 15e9:
                    logs.append((t / 1e9, decoded.name, decoded.message))
                elif channel.topic == "/casewatch/scene/lav" and t <= at:
                    scene = decoded
                elif channel.topic == "/casewatch/markers":
                    for e in decoded.entities:
                        end = t + e.lifetime.seconds * 1e9 + e.lifetime.nanos
                        if e.spheres and t <= at <= end:
                            markers.append(e)
                elif channel.topic == "/casewatch/status" and t <= at:
                    status = decoded
        table = "".join(
            "<tr>" + "".join(f"<td>{html.escape(str(v))}</td>" for v in row) + "</tr>"
            for row in rows
        )
        log_rows = "".join(
            f"<tr><td>{t:.1f} s</td><td>{html.escape(n)}</td><td>{html.escape(m)}</td></tr>"
            for t, n, m in logs[:14]
        )
        root = status["root"] if status else "?"
        page_html = f"""<!DOCTYPE html><html><head><meta charset="utf-8"><style>
body {{ font-family: "DejaVu Sans", sans-serif; margin: 24px; color: #1d2430; }}
table {{ border-collapse: collapse; font-size: 13px; margin-bottom: 18px; }}
td, th {{ border-bottom: 1px solid #d9dee7; padding: 4px 10px; text-align: left; }}
h1 {{ font-size: 20px; }} h2 {{ font-size: 16px; margin-top: 18px; }}
</style></head><body>
<h1>{html.escape(mcap.name)}: casewatch annotate, read back with the mcap reader</h1>
<table><tr><th>topic</th><th>schema</th><th>schema encoding</th><th>message encoding</th>
<th>messages</th></tr>{table}</table>
<h2>/casewatch/scene/lav and /casewatch/markers at {at / 1e9:.1f} s (from above); root goal
{html.escape(result["case"]["root_id"])} on /casewatch/status: {html.escape(root)}</h2>
{_scene_svg(scene, markers)}
<h2>/casewatch/log around it</h2><table>{log_rows}</table></body></html>"""
        page_file = Path(tmp) / "annotated.html"
        page_file.write_text(page_html, encoding="utf-8")
        with sync_playwright() as playwright:
            browser = playwright.chromium.launch(
                executable_path=find_chromium(), args=CHROMIUM_ARGS
            )
            page = browser.new_page(viewport={"width": 940, "height": 900})
            page.goto(page_file.as_uri())
            out.parent.mkdir(parents=True, exist_ok=True)
            page.screenshot(path=str(out), full_page=True)
            browser.close()
    print(f"screenshot: {out}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m tools.live_screenshot", description=__doc__)
    parser.add_argument("live", type=Path, help="PNG of the live page")
    parser.add_argument("annotated", type=Path, help="PNG of the annotated recording")
    args = parser.parse_args(argv)
    if find_chromium() is None:
        print("live_screenshot: Chromium not found: install the Debian package `chromium`")
        return 2
    live_page(args.live)
    annotated_page(args.annotated)
    return 0


if __name__ == "__main__":
    sys.exit(main())
