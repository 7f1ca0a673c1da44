"""The fleet page: one HTML overview of a fleet folder (`casewatch report FLEET_DIR`).

Reads only `summary.json` (and checks which per-log reports exist, to link them): episodes per
hour of every SPI and hazard across the logs, the worst logs, the verdict distribution, the
ground truth when the logs were judged with labels, and a row per log linking its own report.
Self-contained like the run report: inline CSS, no script, autoescaped.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

from casewatch.reports.page import render_page

#: Logs listed under "worst logs".
WORST = 10


def _natural(formula: dict) -> list:
    """Sn2 before Sn10."""
    return [int(p) if p.isdigit() else p for p in re.split(r"(\d+)", formula["node_id"])]


def _rate(episodes: int, hours: float) -> float | None:
    return round(episodes / hours, 2) if hours > 0 else None


def fleet_view(summary: dict, folder: Path) -> dict:
    """The plain values the page shows."""
    logs = []
    for log in summary.get("per_log", []):
        formulas = log.get("formulas", [])
        hours = (log.get("duration_s") or 0.0) / 3600.0
        spi = sum(f["episodes"] for f in formulas if f["kind"] == "spi")
        hazard = sum(f["episodes"] for f in formulas if f["kind"] == "hazard")
        report = Path(log["out_dir"]) / "report.html"
        link = None
        if report.is_file():
            link = os.path.relpath(report.resolve(), folder.resolve())
        logs.append(
            {
                "name": Path(log["out_dir"]).name,
                "stream": log["stream"],
                "ok": log.get("ok", True),
                "error": log.get("error", ""),
                "verdict": log.get("verdict", "failed"),
                "frames": log.get("frames", 0),
                "hours": round(hours, 4),
                "spi": spi,
                "hazard": hazard,
                "per_hour": _rate(spi + hazard, hours),
                "link": link,
                "too_little_data": log.get("too_little_data", False),
            }
        )
    worst = sorted(
        (x for x in logs if x["per_hour"] is not None), key=lambda x: (-x["per_hour"], x["name"])
    )[:WORST]
    formulas = summary.get("formulas", [])
    return {
        "case": summary.get("case", {}).get("path", ""),
        "logs": summary.get("logs", len(logs)),
        "hours": summary.get("hours", 0.0),
        "frames": summary.get("frames", 0),
        "failed": summary.get("logs_failed", 0),
        "crashed": summary.get("logs_crashed", 0),
        "without_data": summary.get("logs_without_data", 0),
        "verdicts": sorted(summary.get("verdicts", {}).items(), key=lambda kv: -kv[1]),
        "spis": sorted((f for f in formulas if f["kind"] == "spi"), key=_natural),
        "hazards": sorted((f for f in formulas if f["kind"] == "hazard"), key=_natural),
        "truth": summary.get("ground_truth"),
        "worst": worst,
        "rows": logs,
    }


def render_fleet(summary: dict, folder: Path) -> str:
    return render_page("fleet.html.j2", v=fleet_view(summary, folder))
