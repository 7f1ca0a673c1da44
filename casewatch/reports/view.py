"""What every report shows, gathered once from a `RunResult`.

HTML, Markdown and JUnit all present the same facts; this module extracts them (and the display
shares) so the three formats cannot disagree. It formats; it never judges: every verdict,
episode and status comes verbatim from `result.json`.
"""

from __future__ import annotations

import dataclasses
import json
import math
import re
from dataclasses import dataclass, field

from casewatch.evaluator.result import (
    STATUS_SEVERITY,
    CaseNode,
    DataGap,
    Episode,
    FormulaStats,
    HazardScore,
    NodeStatus,
    RunResult,
    StatusInterval,
    StreamDefect,
    TraceStep,
)
from casewatch.evaluator.status import summarize

#: Longest lists shown in full; the rest is counted ("and N more"), so reports stay readable
#: and bounded in size however long the run.
LIST_CAP = 200

STATUS_LABELS: dict[str, str] = {
    "violated": "violated",
    "undermined": "undermined",
    "in-doubt": "in doubt",
    "no-data": "no data",
    "outside-odd": "outside ODD",
    "outside-assumption": "outside assumption",
    "undeveloped": "undeveloped",
    "satisfied": "satisfied",
    "external": "external",
}

STATUS_MEANING: dict[str, str] = {
    "violated": "the SPI missed its threshold (or the hazard occurred)",
    "undermined": "supporting evidence below was violated",
    "in-doubt": "challenged by an active hazard",
    "no-data": "inputs missing, not judged",
    "outside-odd": "conditions outside the operational design domain: no claim made",
    "outside-assumption": "the contract's assumption failed: not judged",
    "undeveloped": "argument not developed",
    "satisfied": "held throughout",
    "external": "evidence outside the monitor",
}

TYPE_NAMES: dict[str, str] = {
    "G": "Goal",
    "S": "Strategy",
    "Sn": "Solution",
    "C": "Context",
    "A": "Assumption",
    "J": "Justification",
    "CG": "Counter-goal",
    "CSn": "Counter-solution",
}


def fmt_time(seconds: float | None) -> str:
    """Stream time for people: `12.3 s` below a minute, `m:ss.s` or `h:mm:ss.s` above."""
    if seconds is None or not math.isfinite(seconds):
        return "–"
    if abs(seconds) < 60:
        return f"{seconds:.1f} s"
    sign = "-" if seconds < 0 else ""
    total = abs(seconds)
    hours, rest = divmod(total, 3600)
    minutes, secs = divmod(rest, 60)
    if hours:
        return f"{sign}{int(hours)}:{int(minutes):02d}:{secs:04.1f}"
    return f"{sign}{int(minutes)}:{secs:04.1f}"


def fmt_duration(seconds: float | None) -> str:
    if seconds is None or not math.isfinite(seconds):
        return "–"
    if seconds < 60:
        return f"{seconds:.1f} s"
    minutes, secs = divmod(seconds, 60)
    if minutes < 60:
        return f"{int(minutes)} min {secs:.0f} s"
    hours, minutes = divmod(minutes, 60)
    return f"{int(hours)} h {int(minutes)} min"


def fmt_number(value: float | None, digits: int = 3) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "–"
    return f"{value:.{digits}f}"


def fmt_share(part: int, whole: int) -> str:
    """A share as a percentage; `–` when there is nothing to divide by (never 0 %)."""
    if whole <= 0:
        return "–"
    share = 100.0 * part / whole
    if 0 < share < 0.1:
        return "<0.1 %"
    return f"{share:.1f} %"


def fmt_ratio(value: float | None) -> str:
    return "–" if value is None else f"{100.0 * value:.1f} %"


@dataclass(frozen=True)
class Headline:
    verdict: str  # the root goal's colour (evaluator.status.summarize), as in the diagram
    verdict_label: str
    root_id: str
    root_text: str
    module: str
    brief: str
    created: str
    casewatch_version: str
    case_path: str
    case_digest: str
    stream_path: str
    stream_digest: str
    frames: int
    duration: str
    t_start: float | None
    t_end: float | None
    defects: int
    data_gaps: int
    episodes_spi: int
    episodes_hazard: int
    complete: bool
    root_shares: list[tuple[str, str, str]]  # (status, label, share of ticks)
    meta: list[tuple[str, str]]  # stream header meta, as text
    channels: str
    period: float
    dropouts: list[tuple[str, int]]
    # a ROS 2 bag's topics that were missing or stale at some ticks: (topic, ticks, late)
    topic_gaps: list[tuple[str, int, int]] = field(default_factory=list)
    worst_note: str = ""  # the run's verdict (worst tick status) when the colour differs


@dataclass(frozen=True)
class SpiRow:
    node_id: str
    node_text: str
    formula_id: str
    signal: str
    threshold: str
    ticks_violated: int
    ticks_evaluated: int
    share_violated: str
    episodes: int
    worst_robustness: str
    t_worst: str
    gap_share: str
    status: str
    has_plot: bool


@dataclass(frozen=True)
class HazardRow:
    node_id: str
    node_text: str
    formula_id: str
    condition: str
    challenges: list[str]
    events: int
    ticks_active: int
    share_active: str
    gap_share: str
    worst_robustness: str
    score: HazardScore | None
    precision: str
    recall: str
    status: str


#: Episodes starting within this many seconds of an incident's first one, and sharing a claim
#: below the root with it, join that incident (a fault seen by several SPIs at once).
INCIDENT_WINDOW = 1.0


@dataclass(frozen=True)
class EpisodeView:
    number: int  # 1-based position in result.episodes; the HTML anchor is episode-<number>
    kind: str
    node_id: str
    node_text: str
    formula_id: str
    start: str
    end: str
    duration: str
    ticks: int
    worst_robustness: str
    t_worst: str
    trace: list[list[TraceStep]]
    raw: Episode
    incident: int = 0  # the incident it belongs to (incidents of one episode included)
    mark: str | None = None  # "TP" or "FP" for a hazard event scored against labels


@dataclass(frozen=True)
class IncidentView:
    """Episodes that started together and challenge a common claim: one card in the report."""

    number: int
    start: str
    end: str
    members: list[EpisodeView]
    shared: list[str]  # the goals below the root that every member's trace passes through


def _claims(episode: Episode) -> set[str]:
    """The goals an episode's traces pass through below the root (strategies are left out:
    one strategy under the root would join everything)."""
    return {step.id for path in episode.trace for step in path[1:-1] if _GOAL.match(step.id)}


_GOAL = re.compile(r"G[0-9]")


def incidents(episodes: list[EpisodeView]) -> list[IncidentView]:
    """Group episodes (by start time) into incidents: an episode joins the earliest incident
    whose first episode started at most INCIDENT_WINDOW before it and one of whose members
    shares a goal below the root with it; otherwise it opens an incident of its own."""
    groups: list[list[EpisodeView]] = []
    claims: list[set[str]] = []
    for e in sorted(episodes, key=lambda v: (v.raw.start, v.number)):
        mine = _claims(e.raw)
        home = None
        for k in range(len(groups) - 1, -1, -1):  # the incidents still open, earliest wins
            if e.raw.start - groups[k][0].raw.start > INCIDENT_WINDOW + 1e-9:
                break
            if mine & claims[k]:
                home = k
        if home is None:
            groups.append([e])
            claims.append(set(mine))
        else:
            groups[home].append(e)
            claims[home] |= mine
    out = []
    for number, members in enumerate(groups, start=1):
        shared = set.intersection(*(_claims(m.raw) for m in members))
        out.append(
            IncidentView(
                number=number,
                start=fmt_time(min(m.raw.start for m in members)),
                end=fmt_time(max(m.raw.end for m in members)),
                members=members,
                shared=sorted(shared),
            )
        )
    return out


@dataclass(frozen=True)
class NodeView:
    id: str
    type: str
    type_name: str
    text: str
    status: str
    status_label: str
    node: CaseNode
    supports: list[str]  # parents by supportedBy
    formula: FormulaStats | None
    shares: list[tuple[str, str, str]]
    episode_numbers: list[int]
    timeline: list[StatusInterval]


@dataclass(frozen=True)
class Capped:
    """A list shown up to a cap, with the count of what was left out."""

    shown: list
    omitted: int


@dataclass(frozen=True)
class ReportView:
    result: RunResult
    headline: Headline
    spi_rows: list[SpiRow]
    hazard_rows: list[HazardRow]
    episodes: list[EpisodeView]
    incidents: list[IncidentView]
    gaps: Capped
    defects: Capped
    nodes: list[NodeView]
    status_of: dict[str, str]
    overall_score: HazardScore | None
    unmatched_labels: list[str]
    labels_path: str | None
    formula_of_node: dict[str, FormulaStats] = field(default_factory=dict)
    arbitration: list[tuple[str, str]] = field(default_factory=list)  # (channel, share of ticks)


def _shares(status: NodeStatus | None, period: float) -> list[tuple[str, str, str]]:
    """(status, label, share of the run) worst first; the `no-data` share says how much of it
    was warm-up (`evaluator.status.warmup_ticks`), e.g. `0.1 % (all warm-up)`."""
    if status is None or not status.ticks:
        return []
    summary = summarize(status, period)
    total = summary.total
    ordered = sorted(status.ticks.items(), key=lambda kv: -STATUS_SEVERITY.get(kv[0], -1))
    out = []
    for name, n in ordered:
        if not n:
            continue
        share = fmt_share(n, total)
        if name == "no-data" and summary.warmup_ticks:
            share += (
                " (all warm-up)"
                if summary.warmup_ticks == n
                else f" (warm-up {fmt_share(summary.warmup_ticks, total)})"
            )
        out.append((name, STATUS_LABELS.get(name, name), share))
    return out


def _worst_note(result: RunResult, root: NodeStatus | None) -> str:
    """`worst tick: no data (all warm-up)` when the run's verdict (the root goal's worst status
    on any tick, `result.verdict`) is not the colour the root goal's shares give it."""
    summary = summarize(root, result.case.period)
    if summary.status == result.verdict:
        return ""
    label = STATUS_LABELS.get(result.verdict, result.verdict)
    n = summary.ticks.get(result.verdict, 0)
    warm = " (all warm-up)" if result.verdict == "no-data" and n == summary.warmup_ticks else ""
    return (
        f"worst tick: {label}{warm}, {fmt_share(n, summary.total)} of the run "
        "(the verdict in result.json)"
    )


def _meta_text(value: object) -> str:
    if isinstance(value, str):
        return value
    try:
        return json.dumps(value, ensure_ascii=False, sort_keys=True, default=str)
    except (TypeError, ValueError):
        return repr(value)


def _gap_share(formula: FormulaStats) -> str:
    return fmt_share(formula.ticks_no_data, formula.ticks_evaluated + formula.ticks_no_data)


def _robustness(value: float | None) -> str:
    return "–" if value is None else f"{value:+.3f}"


def build_view(result: RunResult) -> ReportView:
    """Collect what the reports show, in display form."""
    case, stream = result.case, result.stream
    status_by_node = {s.node_id: s for s in result.status}
    # the colour of each node: evaluator.status.summarize's rule, not the worst tick's status
    status_of = {n.id: summarize(status_by_node.get(n.id), case.period).status for n in case.nodes}
    text_of = {n.id: n.text for n in case.nodes}
    formula_of_node = {f.node_id: f for f in result.formulas}
    plotted = {s.formula_id for s in result.series}
    episodes_by_node: dict[str, list[int]] = {}
    for number, episode in enumerate(result.episodes, start=1):
        episodes_by_node.setdefault(episode.node_id, []).append(number)

    headline = Headline(
        verdict=status_of[case.root_id],
        verdict_label=STATUS_LABELS.get(status_of[case.root_id], status_of[case.root_id]),
        worst_note=_worst_note(result, status_by_node.get(case.root_id)),
        root_id=case.root_id,
        root_text=text_of.get(case.root_id, ""),
        module=case.module,
        brief=case.brief,
        created=result.created,
        casewatch_version=result.casewatch_version,
        case_path=case.path,
        case_digest=case.digest,
        stream_path=stream.path,
        stream_digest=stream.digest or "not hashed",
        frames=stream.frames_read,
        duration=fmt_duration(stream.duration),
        t_start=stream.t_start,
        t_end=stream.t_end,
        defects=max(stream.defect_count, len(stream.defects)),
        data_gaps=len(result.data_gaps),
        episodes_spi=sum(1 for e in result.episodes if e.kind == "spi"),
        episodes_hazard=sum(1 for e in result.episodes if e.kind == "hazard"),
        complete=result.complete,
        root_shares=_shares(status_by_node.get(case.root_id), case.period),
        meta=[(str(k), _meta_text(v)) for k, v in stream.meta.items()],
        channels=", ".join(case.channels),
        period=case.period,
        dropouts=sorted(stream.dropouts.items()),
        topic_gaps=[
            (topic, r.get("missing_ticks", 0), r.get("late_messages", 0))
            for topic, r in sorted(stream.topics.items())
            if r.get("missing_ticks") or r.get("late_messages")
        ],
    )

    spi_rows = [
        SpiRow(
            node_id=f.node_id,
            node_text=f.node_text,
            formula_id=f.id,
            signal=f.signal or f.source,
            threshold=f.threshold or "(formula)",
            ticks_violated=f.ticks_violated,
            ticks_evaluated=f.ticks_evaluated,
            share_violated=fmt_share(f.ticks_violated, f.ticks_evaluated),
            episodes=f.episodes,
            worst_robustness=_robustness(f.worst_robustness),
            t_worst=fmt_time(f.t_worst),
            gap_share=_gap_share(f),
            status=status_of.get(f.node_id, "no-data"),
            has_plot=f.id in plotted,
        )
        for f in result.formulas
        if f.kind == "spi"
    ]

    scores: dict[str, HazardScore] = {}
    if result.ground_truth is not None:
        scores = {s.hazard: s for s in result.ground_truth.per_hazard}
    node_by_id = {n.id: n for n in case.nodes}
    hazard_rows = []
    for f in result.formulas:
        if f.kind != "hazard":
            continue
        score = scores.get(f.node_id)
        node = node_by_id.get(f.node_id)
        hazard_rows.append(
            HazardRow(
                node_id=f.node_id,
                node_text=f.node_text,
                formula_id=f.id,
                condition=f.source,
                challenges=list(node.challenges) if node else [],
                events=f.episodes,
                ticks_active=f.ticks_violated,
                share_active=fmt_share(f.ticks_violated, f.ticks_evaluated),
                gap_share=_gap_share(f),
                worst_robustness=_robustness(f.worst_robustness),
                score=score,
                precision=fmt_ratio(score.precision) if score else "–",
                recall=fmt_ratio(score.recall) if score else "–",
                status=status_of.get(f.node_id, "no-data"),
            )
        )

    marks = {
        (m.formula_id, m.start, m.end): m.match
        for m in (result.ground_truth.marks if result.ground_truth else [])
    }
    episodes = [
        EpisodeView(
            number=number,
            kind=e.kind,
            node_id=e.node_id,
            node_text=text_of.get(e.node_id, ""),
            formula_id=e.formula_id,
            start=fmt_time(e.start),
            end=fmt_time(e.end),
            duration=fmt_duration(e.end - e.start + case.period),
            ticks=e.ticks,
            worst_robustness=_robustness(e.worst_robustness),
            t_worst=fmt_time(e.t_worst),
            trace=e.trace,
            raw=e,
            mark=marks.get((e.formula_id, e.start, e.end)),
        )
        for number, e in enumerate(result.episodes, start=1)
    ]
    grouped = incidents(episodes)
    of_episode = {m.number: inc.number for inc in grouped for m in inc.members}
    episodes = [dataclasses.replace(e, incident=of_episode[e.number]) for e in episodes]
    grouped = [
        dataclasses.replace(inc, members=[episodes[m.number - 1] for m in inc.members])
        for inc in grouped
    ]

    supports: dict[str, list[str]] = {}
    for n in case.nodes:
        for child in n.supported_by:
            supports.setdefault(child, []).append(n.id)
    nodes = [
        NodeView(
            id=n.id,
            type=n.type,
            type_name=TYPE_NAMES.get(n.type, n.type),
            text=n.text,
            status=status_of[n.id],
            status_label=STATUS_LABELS.get(status_of[n.id], status_of[n.id]),
            node=n,
            supports=supports.get(n.id, []),
            formula=formula_of_node.get(n.id),
            shares=_shares(status_by_node.get(n.id), case.period),
            episode_numbers=episodes_by_node.get(n.id, []),
            timeline=status_by_node[n.id].timeline if n.id in status_by_node else [],
        )
        for n in case.nodes
    ]
    defects: list[StreamDefect] = list(stream.defects[:LIST_CAP])
    gaps: list[DataGap] = list(result.data_gaps[:LIST_CAP])
    truth = result.ground_truth
    chosen: dict[str, int] = {}
    for interval in result.arbitration:
        name = interval.channel or "none"
        chosen[name] = chosen.get(name, 0) + interval.ticks
    total = sum(chosen.values())
    arbitration = [(name, fmt_share(n, total)) for name, n in sorted(chosen.items())]
    return ReportView(
        result=result,
        headline=headline,
        spi_rows=spi_rows,
        hazard_rows=hazard_rows,
        episodes=episodes,
        incidents=grouped,
        gaps=Capped(gaps, len(result.data_gaps) - len(gaps)),
        defects=Capped(defects, max(stream.defect_count, len(stream.defects)) - len(defects)),
        nodes=nodes,
        status_of=status_of,
        overall_score=truth.overall if truth else None,
        unmatched_labels=list(truth.unmatched_label_names) if truth else [],
        labels_path=truth.labels_path if truth else None,
        formula_of_node=formula_of_node,
        arbitration=arbitration,
    )
