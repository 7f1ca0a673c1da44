"""Aggregating many runs (a fleet's logs) into `summary.json`.

Each run is first reduced to a `LogSummary` (small, picklable, sent back from worker
processes); `summarise` then adds them up per SPI and per hazard, with rates per hour of
monitored driving so logs of different lengths compare.
"""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ConfigDict

from casewatch.evaluator.result import RunResult

SUMMARY_FORMAT = "casewatch-summary"
SUMMARY_VERSION = 1


class FormulaCount(BaseModel):
    model_config = ConfigDict(extra="forbid")
    formula_id: str
    node_id: str
    kind: str
    episodes: int
    ticks_violated: int
    ticks_evaluated: int
    ticks_no_data: int


class HazardCount(BaseModel):
    model_config = ConfigDict(extra="forbid")
    hazard: str
    true_positives: int
    false_positives: int
    false_negatives: int


class LogSummary(BaseModel):
    model_config = ConfigDict(extra="forbid")
    stream: str
    out_dir: str
    ok: bool  # False when the log could not be judged (then `error` says why)
    error: str = ""
    crashed: bool = False  # the error was an internal one (a bug; traceback in the log folder)
    engines_disagree: bool = False  # the rtamt and numpy STL engines disagreed (a bug; exit 4)
    no_data_share: float | None = None  # share of ticks the root goal was `no-data`
    too_little_data: bool = False  # that share exceeded the run's --max-no-data
    verdict: str = ""
    frames: int = 0
    duration_s: float = 0.0
    defects: int = 0
    seconds: float = 0.0  # wall time spent on this log
    formulas: list[FormulaCount] = []
    ground_truth: list[HazardCount] | None = None  # when the log was judged with labels


class FleetFormula(FormulaCount):
    """One formula's totals over a fleet (summary.json `formulas[]`): a log's counts summed,
    and what only a fleet has."""

    model_config = ConfigDict(extra="allow")
    logs_with_episodes: int = 0
    episodes_per_hour: float | None = None
    violated_share: float | None = None


class FleetCase(BaseModel):
    model_config = ConfigDict(extra="allow")
    path: str
    digest: str


class FleetLog(BaseModel):
    """A `per_log` entry as read back: only `out_dir` is required (summaries written by hand or
    by older versions carry less), every field present must have its type."""

    model_config = ConfigDict(extra="allow")
    out_dir: str
    stream: str = ""
    ok: bool = True
    error: str = ""
    crashed: bool = False
    engines_disagree: bool = False
    no_data_share: float | None = None
    too_little_data: bool = False
    verdict: str = ""
    frames: int = 0
    duration_s: float = 0.0
    defects: int = 0
    seconds: float = 0.0
    formulas: list[FormulaCount] = []
    ground_truth: list[HazardCount] | None = None


class FleetSummary(BaseModel):
    """What `summarise` writes as summary.json, as its readers (report, diff, tune, calibrate,
    odd, compare) need it: `batch.read_summary` validates a file with it, so an edited or
    damaged summary is refused with the key at fault instead of crashing a reader."""

    model_config = ConfigDict(extra="allow")
    format: str = SUMMARY_FORMAT
    version: int = SUMMARY_VERSION
    case: FleetCase | None = None
    logs: int = 0
    logs_failed: int = 0
    logs_crashed: int = 0
    logs_engines_disagree: int = 0
    logs_damaged: int = 0
    logs_without_data: int = 0
    hours: float = 0.0
    frames: int = 0
    verdicts: dict[str, int] = {}
    ground_truth: dict | None = None
    formulas: list[FleetFormula] = []
    per_log: list[FleetLog]


def summarise_result(result: RunResult, out_dir: str, seconds: float) -> LogSummary:
    return LogSummary(
        stream=result.stream.path,
        out_dir=out_dir,
        ok=result.complete,
        verdict=result.verdict,
        frames=result.stream.frames_read,
        duration_s=result.stream.duration,
        defects=result.stream.defect_count,
        seconds=round(seconds, 3),
        no_data_share=None if result.root_no_data is None else result.root_no_data.share,
        too_little_data=result.root_no_data is not None and result.root_no_data.exceeded,
        formulas=[
            FormulaCount(
                formula_id=f.id,
                node_id=f.node_id,
                kind=f.kind,
                episodes=f.episodes,
                ticks_violated=f.ticks_violated,
                ticks_evaluated=f.ticks_evaluated,
                ticks_no_data=f.ticks_no_data,
            )
            for f in result.formulas
        ],
        ground_truth=None
        if result.ground_truth is None
        else [
            HazardCount(
                hazard=h.hazard,
                true_positives=h.true_positives,
                false_positives=h.false_positives,
                false_negatives=h.false_negatives,
            )
            for h in result.ground_truth.per_hazard
        ],
    )


def _ratio(num: int, den: int) -> float | None:
    return round(num / den, 6) if den else None


def _ground_truth(logs: list[LogSummary]) -> dict[str, object] | None:
    """TP/FP/FN added up over the logs that had labels; precision and recall from the sums."""
    labelled = [log for log in logs if log.ground_truth is not None]
    if not labelled:
        return None
    sums: dict[str, list[int]] = {}
    for log in labelled:
        for h in log.ground_truth or []:
            row = sums.setdefault(h.hazard, [0, 0, 0])
            row[0] += h.true_positives
            row[1] += h.false_positives
            row[2] += h.false_negatives

    def score(name: str, tp: int, fp: int, fn: int) -> dict[str, object]:
        return {
            "hazard": name,
            "true_positives": tp,
            "false_positives": fp,
            "false_negatives": fn,
            "precision": _ratio(tp, tp + fp),
            "recall": _ratio(tp, tp + fn),
        }

    per_hazard = [score(name, *row) for name, row in sorted(sums.items())]
    total = [sum(row[i] for row in sums.values()) for i in range(3)]
    return {"logs": len(labelled), "per_hazard": per_hazard, "overall": score("all", *total)}


def summarise(logs: list[LogSummary], case_path: str, case_digest: str) -> dict[str, object]:
    """The aggregate record written as summary.json."""
    judged = [log for log in logs if log.ok]
    hours = sum(log.duration_s for log in judged) / 3600.0
    per_formula: dict[str, dict[str, Any]] = {}
    for log in judged:
        for f in log.formulas:
            entry = per_formula.setdefault(
                f.formula_id,
                {
                    "formula_id": f.formula_id,
                    "node_id": f.node_id,
                    "kind": f.kind,
                    "episodes": 0,
                    "ticks_violated": 0,
                    "ticks_evaluated": 0,
                    "ticks_no_data": 0,
                    "logs_with_episodes": 0,
                },
            )
            entry["episodes"] += f.episodes
            entry["ticks_violated"] += f.ticks_violated
            entry["ticks_evaluated"] += f.ticks_evaluated
            entry["ticks_no_data"] += f.ticks_no_data
            entry["logs_with_episodes"] += 1 if f.episodes else 0
    for entry in per_formula.values():
        entry["episodes_per_hour"] = round(entry["episodes"] / hours, 4) if hours else None
        evaluated = entry["ticks_evaluated"]
        entry["violated_share"] = (
            round(entry["ticks_violated"] / evaluated, 6) if evaluated else None
        )
    verdicts: dict[str, int] = {}
    for log in judged:
        verdicts[log.verdict] = verdicts.get(log.verdict, 0) + 1
    return {
        "format": SUMMARY_FORMAT,
        "version": SUMMARY_VERSION,
        "case": {"path": case_path, "digest": case_digest},
        "logs": len(logs),
        "logs_failed": len(logs) - len(judged),
        "logs_crashed": sum(log.crashed for log in logs),
        "logs_engines_disagree": sum(log.engines_disagree for log in logs),
        "logs_damaged": sum(log.defects > 0 for log in judged),
        "logs_without_data": sum(log.too_little_data for log in judged),
        "hours": round(hours, 6),
        "frames": sum(log.frames for log in judged),
        "verdicts": verdicts,
        "ground_truth": _ground_truth(judged),
        "formulas": sorted(per_formula.values(), key=lambda e: str(e["formula_id"])),
        "per_log": [log.model_dump() for log in logs],
    }
