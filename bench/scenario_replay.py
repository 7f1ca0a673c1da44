"""`python -m bench.scenario_replay`: every hazard event of every bundled drive, exported as
OpenSCENARIO and replayed against its stream (too slow for the test suite, which checks two
drives: tests/reports/test_scenario_replay.py and test_scenario_export.py).

Per drive: judge it with the reference case, export its events, sample every file the way
OpenSCENARIO 1.2 times a FollowTrajectoryAction (`tests/reports/xosc_replay.py`) at every frame
of its window and halfway between, and count what a faithful player would show that the stream
did not: contacts (overlapping footprints), entities present while unobserved (or absent while
observed), and positions off the stream. Prints a table and writes
`out/bench/scenario_replay.json`; exit 1 when any file replays unfaithfully.
"""

from __future__ import annotations

import json
import sys
import tempfile
import time
from pathlib import Path

from casewatch import api
from casewatch.scenarios import ExportOptions, export_scenarios
from tests.reports.xosc_checks import replay_checks

REPO = Path(__file__).resolve().parents[1]
DATA = REPO / "examples" / "data"
CASE = REPO / "examples" / "reference-case.yaml"


def sweep(streams: list[Path]) -> list[dict]:
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for stream in streams:
            started = time.perf_counter()
            result = api.run(CASE, stream, formats=())
            out = Path(tmp) / stream.name
            report = export_scenarios(result, stream, out, ExportOptions())
            exported = time.perf_counter()
            checks = replay_checks(stream, out) if report.written else []
            before = replay_checks(stream, out, waiting=True) if report.written else []
            objects = [o for c, _ in checks for o in c["objects"].values()]
            rows.append(
                {
                    "drive": stream.name,
                    "events": len(report.entries),
                    "files": len(report.written),
                    "failed": len(report.failed),
                    "ego_only": sum(1 for c, _ in checks if c["ego_only"]),
                    "objects": len(objects),
                    "objects_added_late": sum(1 for o in objects if o["first_seen"] > 0),
                    "objects_with_pauses": sum(1 for o in objects if o["spans"] > 1),
                    "samples": sum(c.samples for _, c in checks),
                    "stream_contacts": sum(c.stream_contacts for _, c in checks),
                    "new_contacts": sum(len(c.new_contacts) for _, c in checks),
                    "presence_errors": sum(len(c.presence_errors) for _, c in checks),
                    # the same files played as exported before issue 33 (objects waiting at
                    # their first pose, staying at their last): instants with a new contact
                    "new_contacts_if_waiting": sum(len(c.new_contacts) for _, c in before),
                    "files_colliding_if_waiting": sum(1 for _, c in before if c.new_contacts),
                    "max_position_error_m": max(
                        (c.max_position_error for _, c in checks), default=0.0
                    ),
                    "seconds_run_and_export": round(exported - started, 2),
                    "seconds_replay_check": round(time.perf_counter() - exported, 2),
                }
            )
    return rows


def main() -> int:
    rows = sweep(sorted(DATA.glob("*.jsonl.gz")))
    columns = list(rows[0])
    print(" | ".join(columns))
    for row in rows:
        print(" | ".join(str(row[c]) for c in columns))
    out = REPO / "out" / "bench"
    out.mkdir(parents=True, exist_ok=True)
    (out / "scenario_replay.json").write_text(json.dumps(rows, indent=1), encoding="utf-8")
    bad = sum(r["new_contacts"] + r["presence_errors"] + r["failed"] for r in rows)
    bad += sum(1 for r in rows if r["max_position_error_m"] > 0.001)
    print(f"{sum(r['files'] for r in rows)} files; unfaithful findings: {bad}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
