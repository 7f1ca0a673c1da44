"""`result.json`: the canonical, versioned record of one run.

Reports are rendered from this value alone, so it carries everything a report shows: the case
structure (for the diagram), per-formula statistics, every episode with its trace, data gaps,
node status timelines, decimated signal series for plots, ground-truth scores and timings.
The schema is documented in `docs/results.md`; bump `RESULT_VERSION` on any incompatible change.
"""

from __future__ import annotations

import hashlib
from collections.abc import Mapping
from typing import Literal

from pydantic import BaseModel, ConfigDict, field_validator

from casewatch.safety_case.model import Case

RESULT_FORMAT = "casewatch-result"
RESULT_VERSION = 1

Status = Literal[
    "satisfied",
    "violated",
    "undermined",
    "in-doubt",
    "no-data",
    "outside-odd",
    "outside-assumption",
    "undeveloped",
    "external",
]

#: Worst first. `external` (evidence or context outside the monitor) never outranks a verdict.
#: `outside-odd` and `outside-assumption` (docs/odd.md, docs/contracts.md) are no verdict
#: either way: worse than a pass (nothing is claimed there), better than missing data.
STATUS_SEVERITY: dict[str, int] = {
    "violated": 8,
    "undermined": 7,
    "in-doubt": 6,
    "no-data": 5,
    "outside-odd": 4,
    "outside-assumption": 3,
    "undeveloped": 2,
    "satisfied": 1,
    "external": 0,
}


class _Record(BaseModel):
    # robustness can be infinite (`once` over no sample is -inf, `historically` +inf,
    # docs/formulas.md): JSON has no infinity, so it is written as the strings "Infinity",
    # "-Infinity" (and "NaN"), which these models read back as floats (docs/results.md)
    model_config = ConfigDict(extra="forbid", ser_json_inf_nan="strings")


class TraceStep(_Record):
    id: str
    text: str


class CaseNode(_Record):
    """A node of the safety case as the report needs it (structure, texts, bindings)."""

    id: str
    type: str  # G, S, Sn, C, A, J, CG, CSn
    text: str
    supported_by: list[str] = []
    in_context_of: list[str] = []
    challenges: list[str] = []
    undeveloped: bool = False
    url: str | None = None
    formula_id: str | None = None  # the monitored formula bound to this node, if any


class CaseInfo(_Record):
    """The safety case as a run records it: structure and texts, no verdicts."""

    path: str
    digest: str  # sha256 of the YAML bytes
    module: str
    brief: str = ""
    root_id: str
    channels: list[str]
    period: float
    nodes: list[CaseNode]

    @classmethod
    def from_case(cls, case: Case, root_id: str, formula_of: Mapping[str, str]) -> CaseInfo:
        """Record `case`; `formula_of` maps node ids to the ids of their monitored formulas."""
        return cls(
            path=case.path,
            digest=case.digest,
            module=case.module.name,
            brief=case.module.brief,
            root_id=root_id,
            channels=list(case.monitor.channels),
            period=case.monitor.period,
            nodes=[
                CaseNode(
                    id=n.id,
                    type=n.type.value,
                    text=n.text,
                    supported_by=list(n.supported_by),
                    in_context_of=list(n.in_context_of),
                    challenges=list(n.challenges),
                    undeveloped=n.undeveloped,
                    url=n.url,
                    formula_id=formula_of.get(n.id),
                )
                for n in case.nodes.values()
            ],
        )


class StreamDefect(_Record):
    line: int
    kind: str
    message: str


class StreamInfo(_Record):
    path: str  # "-" for standard input
    digest: str | None  # sha256 of the bytes read (None when the input could not be hashed)
    meta: dict[str, object] = {}  # the header's meta, verbatim
    frames_read: int = 0
    t_start: float | None = None
    t_end: float | None = None
    duration: float = 0.0  # seconds covered by frames
    defects: list[StreamDefect] = []
    defect_count: int = 0  # defects may be truncated in `defects`; this is the full count
    dropouts: dict[str, int] = {}  # channel -> frames in which it was absent
    # a ROS 2 bag's mapped topics: topic -> {missing_ticks, late_messages} (docs/bags.md)
    topics: dict[str, dict[str, int]] = {}


class Episode(_Record):
    """Consecutive violating ticks of one formula, merged across gaps shorter than merge_gap."""

    formula_id: str
    node_id: str
    kind: Literal["spi", "hazard"]
    start: float  # time of the first violating tick
    end: float  # time of the last violating tick
    ticks: int  # violating ticks inside [start, end]
    worst_robustness: float
    t_worst: float
    trace: list[list[TraceStep]]  # every path from node_id up to the root goal
    # the ego's position at `start` (the trusted channel's estimate, docs/results.md)
    x: float | None = None
    y: float | None = None


class NearMiss(_Record):
    """Ticks where a formula held, but by less than its warning margin (`warn:`): robustness in
    [0, warn). Formed like episodes (merge_gap, min_duration); reported, never a violation,
    never a change of any node's status."""

    formula_id: str
    node_id: str
    kind: Literal["spi", "hazard"]
    start: float
    end: float
    ticks: int
    least_robustness: float  # the smallest robustness inside the near miss (>= 0)
    t_least: float
    warn: float
    trace: list[list[TraceStep]]


class EpisodeOpen(_Record):
    """An episode announced at its onset: the tick `t` it became certain (it has lasted the
    formula's min_duration), with its first violating tick `start`. The episode itself follows
    as an `Episode` when it closes."""

    formula_id: str
    node_id: str
    kind: Literal["spi", "hazard"]
    start: float
    t: float
    trace: list[list[TraceStep]]


class OddChange(_Record):
    """The drive left an ODD (`outside`), its conditions stopped being reported (`unknown`) or
    it came back (`inside`), at tick `t` (docs/odd.md); `because` names the attribute."""

    node_id: str
    t: float
    state: Literal["inside", "outside", "unknown"]
    because: str | None = None


class DataGap(_Record):
    """Ticks where a formula could not be evaluated because an input had no value."""

    formula_id: str
    node_id: str
    start: float
    end: float
    ticks: int
    missing: list[str]  # the input signals that had no value (union over the gap)


class FormulaStats(_Record):
    id: str
    node_id: str
    node_text: str
    kind: Literal["spi", "hazard"]
    source: str
    rtamt: str
    signal: str | None = None
    threshold: str | None = None
    signals: list[str] = []
    ticks_evaluated: int = 0
    ticks_violated: int = 0
    ticks_no_data: int = 0
    episodes: int = 0
    episodes_dropped: int = 0  # shorter than min_duration
    worst_robustness: float | None = None
    t_worst: float | None = None
    merge_gap: float = 1.0
    min_duration: float = 0.0
    # a contract (`contract:`): its assumption's text, the library contract it instantiates,
    # and the ticks where the assumption failed (neither evaluated nor violated)
    assumption: str | None = None
    contract_use: str | None = None
    ticks_outside_assumption: int = 0
    rule: str | None = None  # the traffic rule a hazard instantiates (docs/traffic-rules.md)


class FormulaTally(_Record):
    """One formula's ticks under one combination of conditions: judged, violated, outside
    its assumption, without data (they add up to the ticks of the combination)."""

    evaluated: int = 0
    violated: int = 0
    outside_assumption: int = 0
    no_data: int = 0


class ConditionStats(_Record):
    """The ticks a run spent under one combination of reported conditions (`meta.odd` and
    frame `odd` updates, flattened: `environment.weather`), and each formula's tally there:
    what `casewatch odd` aggregates over runs."""

    attributes: dict[str, str | float | bool]
    ticks: int
    formulas: dict[str, FormulaTally]
    spans: list[list[float]] = []  # [first, last] tick times of each stretch under them


class OddSummary(_Record):
    """How a run stood against the ODD of one context node: ticks inside, outside, with a
    condition not reported (unknown), and per attribute the ticks it put outside or unknown."""

    node_id: str
    name: str = ""
    inside: int = 0
    outside: int = 0
    unknown: int = 0
    outside_by: dict[str, int] = {}
    unknown_by: dict[str, int] = {}


class StatusInterval(_Record):
    status: Status
    start: float  # first tick time with this status
    end: float  # last tick time with this status
    ticks: int


class NodeStatus(_Record):
    node_id: str
    worst: Status
    timeline: list[StatusInterval]
    ticks: dict[str, int] = {}  # status -> ticks


class Series(_Record):
    """A decimated series for plotting: per bucket the min and max of the value."""

    formula_id: str
    quantity: Literal["signal", "robustness"]
    name: str  # signal name, or "robustness"
    bucket: float  # seconds per bucket
    t: list[float]  # bucket start times
    lo: list[float | None]  # None: no value in the bucket
    hi: list[float | None]
    reference: float | None = None  # the threshold line (or 0.0 for robustness)


class HazardScore(_Record):
    hazard: str  # node id
    true_positives: int
    false_positives: int
    false_negatives: int
    precision: float | None  # None when undefined (no events)
    recall: float | None  # None when undefined (no labels)


class LabelInterval(_Record):
    """A labelled interval of a hazard of the case (its node id, resolved from the label)."""

    node_id: str
    start: float
    end: float


class EventMark(_Record):
    """A hazard event scored against the labels: a true or a false positive."""

    formula_id: str
    node_id: str
    start: float
    end: float
    match: Literal["TP", "FP"]


class GroundTruth(_Record):
    labels_path: str
    labels_digest: str
    per_hazard: list[HazardScore]
    overall: HazardScore
    unmatched_label_names: list[str] = []  # labels naming no hazard of the case
    labels: list[LabelInterval] = []  # the labels of the case's hazards (for the report's plots)
    marks: list[EventMark] = []  # every hazard event, TP or FP (the report marks them)


class ArbitrationInterval(_Record):
    channel: str | None
    start: float
    end: float
    ticks: int


class Timings(_Record):
    total_s: float = 0.0
    read_s: float = 0.0
    metrics_s: float = 0.0
    stl_s: float = 0.0
    episodes_status_s: float = 0.0
    frames_per_s: float = 0.0
    peak_rss_mib: float | None = None  # the process's peak resident memory (Linux VmHWM)


class RootNoData(_Record):
    """How much of the run the root goal could not be judged, against the run's limit.

    A run whose root goal is `no-data` on more than `limit` of its ticks is unusable input
    (exit code 2), not a pass: missing data is never a pass, not even when most of it is."""

    ticks: int  # root-goal ticks: frames plus the ticks of frames missing from the stream
    no_data_ticks: int
    share: float  # no_data_ticks / ticks; 1.0 for a run without any tick
    limit: float  # the largest share accepted (`casewatch run --max-no-data`)
    exceeded: bool  # share > limit


class RunResult(_Record):
    format: str = RESULT_FORMAT
    version: int = RESULT_VERSION
    casewatch_version: str
    created: str  # ISO 8601 UTC
    case: CaseInfo
    stream: StreamInfo
    verdict: Status  # the root goal's worst status over the run
    formulas: list[FormulaStats]
    episodes: list[Episode]  # every SPI episode and hazard event, by start time
    near_misses: list[NearMiss] = []  # formulas with `warn:`, by start time; never violations
    data_gaps: list[DataGap]
    status: list[NodeStatus]
    series: list[Series]
    arbitration: list[ArbitrationInterval] = []
    ground_truth: GroundTruth | None = None
    timings: Timings = Timings()
    complete: bool = True  # False when the run stopped early (interrupted, strict-mode defect)
    # which episodes fail the run (evaluator.policy): the exit code and JUnit's failures
    fail_on: Literal["any", "hazard", "spi", "never"] = "any"
    root_no_data: RootNoData | None = None  # None in results written before it existed
    conditions: list[ConditionStats] = []  # per combination of reported conditions
    # the ego's driven path, [t, x, y] (the trusted channel's estimate), at most TRACK_POINTS
    track: list[list[float]] = []
    # penalty and CARLA scores of the traffic-rule events (evaluator.scoring); None: no rules
    scores: dict | None = None

    @field_validator("scores")
    @classmethod
    def _scores_shape(cls, value: dict | None) -> dict | None:
        """The shape the reports read (evaluator.scoring writes it): a damaged or edited
        result.json is refused with the key at fault instead of crashing a report."""
        if value is not None:
            _check_scores(value)
        return value

    odd: list[OddSummary] = []  # per context node with an `odd:` specification
    #: the run options that shaped this result (`RunOptions.recorded()`): `--resume` reuses it
    #: only for a run with the same options; None in results written before it existed
    options: dict[str, str | bool | int | float | None] | None = None
    #: sha256 of this record's own JSON with this field null (`result_digest`): `--resume`
    #: re-judges a log whose result.json no longer matches it (edited, damaged); None in
    #: results written before it existed
    content_digest: str | None = None


def _check_scores(scores: dict) -> None:
    """Raise ValueError naming the first key of `scores` whose value the reports cannot read."""
    for key in ("penalty", "carla"):
        if key not in scores:
            raise ValueError(f"scores.{key}: missing (null when there is no such score)")
        if scores[key] is not None and not isinstance(scores[key], dict):
            raise ValueError(f"scores.{key}: expected an object or null")
    for key, number in (("penalty", "score"), ("carla", "driving_score")):
        part = scores[key]
        if part is not None and not _is_number(part.get(number)):
            raise ValueError(f"scores.{key}.{number}: expected a number")
    for where in (scores, scores["penalty"] or {}):
        rules = where.get("per_rule", {})
        rows = rules.values() if isinstance(rules, dict) else [None]
        if not all(
            isinstance(r, dict)
            and all(_is_number(r.get(k)) for k in ("events", "while_speeding", "penalty"))
            for r in rows
        ):
            raise ValueError(
                "scores per_rule: expected rule -> {events, while_speeding, penalty} numbers"
            )
    texts = [("scores.reason", scores.get("reason"))] + [
        (f"scores.{key}.made_of", (scores[key] or {}).get("made_of"))
        for key in ("penalty", "carla")
    ]
    for path, text in texts:
        if text is not None and not isinstance(text, str):
            raise ValueError(f"{path}: expected text or null")


def _is_number(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def result_digest(result: RunResult) -> str:
    """The sha256 of `result`'s compact JSON with `content_digest` null: what the field holds
    when casewatch writes the record, and what `--resume` recomputes from the file."""
    body = result.model_copy(update={"content_digest": None}).model_dump_json()
    return hashlib.sha256(body.encode("utf-8")).hexdigest()
