"""Many runs compared by group: which agent drives which scenario best, and where it broke rules.

`casewatch compare` reads the `result.json` of every run (from the file alone, as plain
dicts: results written before the traffic-rule fields existed still load) and groups the runs
by keys of their stream's `meta` (default `agent` and `scenario`). Per group it adds up hours,
the penalty score and the CARLA driving score (mean, min and max over the runs that carry
`scores`), and per traffic rule the events and penalty sums. It also gathers every hazard
episode that has a position (`episodes[].x`, `.y`: the ego at the episode's start) as a map
marker, with its distance to its run's driven `track`.

Results are plain values (`compare.json` is this dict written out); `reports.compare` renders
them and `reports.roadmap` adds the road-network check.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import shapely

COMPARE_FORMAT = "casewatch-compare"
COMPARE_VERSION = 1
#: The group value of a run whose stream meta lacks a `--by` key.
NONE = "(none)"
#: A marker farther than this from its run's track is reported: the track is decimated, so a
#: marker on a curve may lie a few decimetres off the chords, never metres.
TRACK_TOLERANCE_M = 1.0


def _number(v: object) -> float | None:
    if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
        return None
    return float(v)


def _score(scores: dict | None, system: str, key: str) -> float | None:
    part = (scores or {}).get(system)
    return _number(part.get(key)) if isinstance(part, dict) else None


def _stats(values: Sequence[float | None]) -> dict | None:
    """Mean, min and max over the runs with a value; None when no run has one."""
    have = [v for v in values if v is not None]
    if not have:
        return None
    return {
        "mean": round(sum(have) / len(have), 6),
        "min": round(min(have), 6),
        "max": round(max(have), 6),
        "runs": len(have),
    }


def _per_rule(data: dict, rule_of: dict[str, str]) -> dict[str, dict]:
    """{rule: {events, penalty}}: the scorer's tally when the run was scored, else the hazard
    episodes counted per rule (penalty None: no score without the scorer)."""
    scored = ((data.get("scores") or {}).get("penalty") or {}).get("per_rule")
    if isinstance(scored, dict) and scored:
        return {
            str(rule): {
                "events": int(row.get("events") or 0),
                "penalty": _number(row.get("penalty")),
            }
            for rule, row in scored.items()
            if isinstance(row, dict)
        }
    counts: dict[str, dict] = {}
    for e in data["episodes"]:
        rule = rule_of.get(e.get("formula_id"))
        if e.get("kind") == "hazard" and rule:
            counts.setdefault(rule, {"events": 0, "penalty": None})["events"] += 1
    return counts


def _summarise_run(name: str, folder: Path, data: dict, by: Sequence[str]) -> dict:
    meta = data["stream"].get("meta") or {}
    rule_of: dict[str, str] = {
        f["id"]: f["rule"]
        for f in data["formulas"]
        if isinstance(f, dict) and f.get("id") and f.get("rule")
    }
    scores = data.get("scores")
    carla = (scores or {}).get("carla") or {}
    infractions = carla.get("per_infraction") if isinstance(carla, dict) else None
    return {
        "name": name,
        "folder": str(folder),
        "group": {k: str(meta[k]) if meta.get(k) not in (None, "") else NONE for k in by},
        "agent": str(meta.get("agent") or NONE),
        "scenario": str(meta.get("scenario") or NONE),
        "verdict": data.get("verdict"),
        "hours": round((_number(data["stream"].get("duration")) or 0.0) / 3600.0, 6),
        "scored": isinstance(scores, dict),
        "penalty_score": _score(scores, "penalty", "score"),
        "driving_score": _score(scores, "carla", "driving_score"),
        "route_completion": _score(scores, "carla", "route_completion"),
        "hazard_events": sum(1 for e in data["episodes"] if e.get("kind") == "hazard"),
        "per_rule": _per_rule(data, rule_of),
        "per_infraction": {
            str(k): int(v.get("events") or 0) for k, v in infractions.items() if isinstance(v, dict)
        }
        if isinstance(infractions, dict)
        else {},
        "track_points": len(data.get("track") or []),
    }


def _markers(name: str, run: dict, data: dict) -> list[dict]:
    """The run's hazard episodes that have a position, with their distance to the track."""
    rule_of = {f.get("id"): f.get("rule") for f in data["formulas"] if isinstance(f, dict)}
    rows = []
    for e in data["episodes"]:
        x, y = _number(e.get("x")), _number(e.get("y"))
        if e.get("kind") != "hazard" or x is None or y is None:
            continue
        rows.append(
            {
                "run": name,
                "agent": run["agent"],
                "scenario": run["scenario"],
                "rule": rule_of.get(e.get("formula_id")) or e.get("node_id") or "?",
                "formula_id": e.get("formula_id"),
                "node_id": e.get("node_id"),
                "start": e.get("start"),
                "end": e.get("end"),
                "x": x,
                "y": y,
                "track_distance": None,
                "off_track": None,
                "network_distance": None,
                "off_road": None,
            }
        )
    track = np.asarray([p[1:] for p in data.get("track") or []], dtype=float).reshape(-1, 2)
    if rows and len(track):
        line = shapely.points(track[0]) if len(track) == 1 else shapely.linestrings(track)
        points = shapely.points([(m["x"], m["y"]) for m in rows])
        for m, d in zip(rows, shapely.distance(points, line), strict=True):
            m["track_distance"] = round(float(d), 3)
            m["off_track"] = bool(d > TRACK_TOLERANCE_M)
    return rows


def _matrix(runs: list[dict], by: Sequence[str]) -> dict:
    """Mean penalty score per (first key, second key): agents x scenarios by default."""
    row_key = by[0]
    col_key = by[1] if len(by) > 1 else None
    rows = sorted({r["group"][row_key] for r in runs})
    cols = sorted({r["group"][col_key] for r in runs}) if col_key else ["all"]
    cells = []
    for row in rows:
        line = []
        for col in cols:
            inside = [
                r
                for r in runs
                if r["group"][row_key] == row and (col_key is None or r["group"][col_key] == col)
            ]
            line.append(_stats([r["penalty_score"] for r in inside]) if inside else None)
        cells.append(line)
    return {"rows_key": row_key, "cols_key": col_key, "rows": rows, "cols": cols, "cells": cells}


def compare_runs(runs: Sequence[tuple[str, Path, dict]], by: Sequence[str]) -> dict:
    """The comparison of `runs` ((name, folder, result.json dict) each) grouped by `by`."""
    summaries = [_summarise_run(name, folder, data, by) for name, folder, data in runs]
    markers = [
        m
        for (name, _, data), s in zip(runs, summaries, strict=True)
        for m in _markers(name, s, data)
    ]
    groups: dict[tuple, list[dict]] = {}
    for s in summaries:
        groups.setdefault(tuple(s["group"][k] for k in by), []).append(s)
    rules = sorted({rule for s in summaries for rule in s["per_rule"]})
    rows = []
    for key in sorted(groups):
        members = groups[key]
        per_rule = {}
        for rule in rules:
            tallies = [s["per_rule"][rule] for s in members if rule in s["per_rule"]]
            penalties = [t["penalty"] for t in tallies if t["penalty"] is not None]
            per_rule[rule] = {
                "events": sum(t["events"] for t in tallies),
                "penalty": round(sum(penalties), 6) if penalties else None,
            }
        infractions: dict[str, int] = {}
        for s in members:
            for name, n in s["per_infraction"].items():
                infractions[name] = infractions.get(name, 0) + n
        rows.append(
            {
                "key": dict(zip(by, key, strict=True)),
                "label": " / ".join(key),
                "runs": len(members),
                "run_names": [s["name"] for s in members],
                "hours": round(sum(s["hours"] for s in members), 6),
                "scored_runs": sum(1 for s in members if s["scored"]),
                "penalty_score": _stats([s["penalty_score"] for s in members]),
                "driving_score": _stats([s["driving_score"] for s in members]),
                "route_completion": _stats([s["route_completion"] for s in members]),
                "hazard_events": sum(s["hazard_events"] for s in members),
                "per_rule": per_rule,
                "per_infraction": dict(sorted(infractions.items())),
            }
        )
    with_distance = [m for m in markers if m["track_distance"] is not None]
    off_track = [i for i, m in enumerate(markers) if m["off_track"]]
    return {
        "format": COMPARE_FORMAT,
        "version": COMPARE_VERSION,
        "by": list(by),
        "without_key": {k: [s["name"] for s in summaries if s["group"][k] == NONE] for k in by},
        "runs": summaries,
        "groups": rows,
        "rules": rules,
        "table": _matrix(summaries, by),
        "markers": markers,
        "checks": {
            "hazard_events": sum(s["hazard_events"] for s in summaries),
            "markers": len(markers),
            "without_position": sum(s["hazard_events"] for s in summaries) - len(markers),
            "track": {
                "tolerance_m": TRACK_TOLERANCE_M,
                "checked": len(with_distance),
                "unchecked": len(markers) - len(with_distance),
                "max_distance": max((m["track_distance"] for m in with_distance), default=None),
                "off": len(off_track),
                "off_markers": off_track,
            },
            "network": None,
        },
    }


def unknown_keys(runs: Sequence[tuple[str, Path, dict]], by: Sequence[str]) -> list[str]:
    """The `--by` keys no run's stream meta has (a typo, not a run without the key)."""
    return [
        k for k in by if not any(k in (data["stream"].get("meta") or {}) for _, _, data in runs)
    ]
