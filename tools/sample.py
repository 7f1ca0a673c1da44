"""Synthetic `RunResult` values shaped like a run of the reference safety case.

Reports must be developed, tested, benchmarked and screenshotted without a real run (the
evaluator is built in parallel and real drive logs are large). This module fabricates a
plausible result: the reference case's structure (root goal, one strategy, four sub-goals,
fifteen pieces of evidence, three hazards, two contexts and an assumption), signals with dips
and dropouts, and the episodes, data gaps, status timelines and decimated series a run of the
evaluator would record for them. It is a fixture generator, not an evaluator: nothing here is
used to judge a real stream.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import networkx as nx
import numpy as np

from casewatch.evaluator.result import (
    STATUS_SEVERITY,
    CaseInfo,
    CaseNode,
    DataGap,
    Episode,
    FormulaStats,
    GroundTruth,
    HazardScore,
    NodeStatus,
    RunResult,
    Series,
    StatusInterval,
    StreamDefect,
    StreamInfo,
    Timings,
    TraceStep,
)
from casewatch.safety_case.model import Case

#: The structure of `examples/reference-case.yaml` (a test keeps the two in step), so reports
#: can be rendered where the examples folder is not installed.
#: (id, type, text, supported_by, in_context_of, challenges, (signal, op, threshold) or hazard)
_REFERENCE_NODES: list[tuple[str, str, str, list[str], list[str], list[str], object]] = [
    ("G1", "G", "EGO vehicle goes from Point A to Point B safely", ["S1"], ["C1", "C2"], [], None),
    (
        "C1",
        "C",
        "Two independent driving channels run side by side: lav (LiDAR-based stack) and tfuse (camera/sensor-fusion stack), each producing ego state, detected objects and a planned path every 0.1 s",  # noqa: E501
        [],
        [],
        [],
        None,
    ),
    (
        "C2",
        "C",
        "Operating domain: urban and suburban roads of the simulated towns, daylight and adverse weather, speed limits up to 50 km/h, other traffic present",  # noqa: E501
        [],
        [],
        [],
        None,
    ),
    (
        "S1",
        "S",
        "Argue over the capabilities every channel needs, judged by agreement between channels",
        ["G2", "G3", "G4", "G5"],
        ["A1", "J1"],
        [],
        None,
    ),
    (
        "A1",
        "A",
        "The two channels fail independently: a fault rarely makes both channels wrong in the same way at the same time, so disagreement reveals a faulty channel",  # noqa: E501
        [],
        [],
        [],
        None,
    ),
    (
        "J1",
        "J",
        "The SPIs and reference thresholds are those of the study's Table 4.5, which separated hazardous from nominal driving on about 8 h of simulated driving in six towns",  # noqa: E501
        [],
        [],
        [],
        None,
    ),
    (
        "G2",
        "G",
        "Channels locate and orient the ego vehicle accurately and consistently",
        ["Sn1", "Sn2", "Sn3"],
        [],
        [],
        None,
    ),
    (
        "Sn1",
        "Sn",
        "Ego location is consistent across channels (ELS)",
        [],
        [],
        [],
        ("els", ">=", 0.6),
    ),
    (
        "Sn2",
        "Sn",
        "Ego location similarity is stable over time (moving variance of ELS)",
        [],
        [],
        [],
        ("els_var", "<=", 0.05),
    ),
    (
        "Sn3",
        "Sn",
        "Ego orientation is consistent across channels (EOS)",
        [],
        [],
        [],
        ("eos", ">=", 0.8),
    ),
    (
        "G3",
        "G",
        "Channels perceive the surrounding objects consistently",
        ["Sn4", "Sn5", "Sn6", "Sn15"],
        ["C3"],
        [],
        None,
    ),
    (
        "C3",
        "C",
        "Objects of the two channels are paired by greedy nearest matching within 3 m, among the objects both channels can see (their declared coverage); object count similarity (ocs) is observed and reported but not judged",  # noqa: E501
        [],
        [],
        [],
        None,
    ),
    (
        "Sn4",
        "Sn",
        "Object locations are consistent across channels (OLS)",
        [],
        [],
        [],
        ("ols", ">=", 0.5),
    ),
    (
        "Sn5",
        "Sn",
        "Object orientations are consistent across channels (OOS)",
        [],
        [],
        [],
        ("oos", ">=", 0.6),
    ),
    (
        "Sn6",
        "Sn",
        "Object footprints are consistent across channels (OAS)",
        [],
        [],
        [],
        ("oas", ">=", 0.6),
    ),
    (
        "Sn15",
        "Sn",
        "Every object both channels can see is reported by both within 1.5 s (lone_age)",
        [],
        [],
        [],
        ("lone_age", "<=", 1.5),
    ),
    (
        "G4",
        "G",
        "Channels predict the motion of surrounding objects consistently and correctly",
        ["Sn7", "Sn8"],
        [],
        [],
        None,
    ),
    (
        "Sn7",
        "Sn",
        "Predicted object trajectories are consistent across channels (OTS)",
        [],
        [],
        [],
        ("ots", ">=", 0.6),
    ),
    (
        "Sn8",
        "Sn",
        "Objects follow the motion each channel predicted for them (OMPV)",
        [],
        [],
        [],
        ("ompv", ">=", 0.5),
    ),
    (
        "G5",
        "G",
        "Channels plan a path that is safe, stable and comfortable",
        ["Sn9", "Sn10", "Sn11", "Sn12", "Sn13", "Sn14", "Sn16"],
        [],
        [],
        None,
    ),
    (
        "Sn9",
        "Sn",
        "Planned ego trajectories are consistent across channels (ETS)",
        [],
        [],
        [],
        ("ets", ">=", 0.6),
    ),
    (
        "Sn10",
        "Sn",
        "Planned paths have the same shape across channels (CRPPS)",
        [],
        [],
        [],
        ("crpps", ">=", 0.5),
    ),
    (
        "Sn11",
        "Sn",
        "Each channel's plan is stable from one cycle to the next (CHPPS)",
        [],
        [],
        [],
        ("chpps", ">=", 0.7),
    ),
    ("Sn12", "Sn", "The driven history is comfortable (HCS)", [], [], [], ("hcs", ">=", 0.8)),
    ("Sn13", "Sn", "The planned path is comfortable (PPCS)", [], [], [], ("ppcs", ">=", 0.8)),
    (
        "Sn14",
        "Sn",
        "Every channel's plan keeps a safe margin to the objects every channel sees (SS)",
        [],
        [],
        [],
        ("ss", ">=", 0.5),
    ),
    (
        "Sn16",
        "Sn",
        "The channels plan the same lateral path (plan_lat)",
        [],
        [],
        [],
        ("plan_lat", "<=", 0.6),
    ),
    ("CSn1", "CSn", "Inconsistent ego localization identified", [], [], ["G2"], "els_var > 0.05"),
    (
        "CSn2",
        "CSn",
        "Ego tailgating identified (ego too close behind a lead vehicle)",
        [],
        [],
        ["G5"],
        "abs(ocs - ols) > 0.5 and ss >= 0.8 and ppcs < 0.9 and ppcs >= 0.7",
    ),
    (
        "CSn3",
        "CSn",
        "Ego tailgated identified (a follower too close behind ego)",
        [],
        [],
        ["G5"],
        "abs(ocs - ols) > 0.5 and ss < 0.8 and ppcs >= 0.8",
    ),
]


def case_info_from_case(case: Case) -> CaseInfo:
    """The `CaseInfo` a run of a loaded `Case` records (structure and texts, no verdicts)."""
    bound = {n.id: n.id for n in case.nodes.values() if n.spi is not None or n.hazard is not None}
    return CaseInfo.from_case(case, case.root_id(), bound)


def reference_case(*, hostile: bool = False) -> CaseInfo:
    """The reference safety case as `result.json` carries it.

    With `hostile=True` every text carries markup, quotes and ampersands, for escaping tests.
    """
    nodes = []
    for node_id, node_type, text, supported, context, challenges, binding in _REFERENCE_NODES:
        if hostile:
            text = f"{text} <script>alert(1)</script> \"q\" & 'a' | x"
        nodes.append(
            CaseNode(
                id=node_id,
                type=node_type,
                text=text,
                supported_by=supported,
                in_context_of=context,
                challenges=challenges,
                formula_id=node_id if binding is not None else None,
            )
        )
    return CaseInfo(
        path="examples/reference-case.yaml",
        digest="sha256:" + "3f" * 32,
        module="ego-a-to-b" if not hostile else 'ego <script>alert(1)</script> & "b"',
        brief="Reference case from the two-channel study",
        root_id="G1",
        channels=["lav", "tfuse"],
        period=0.1,
        nodes=nodes,
    )


def _traces(case: CaseInfo) -> dict[str, list[list[TraceStep]]]:
    """Every path from each node up to the root (challenges count as an upward edge)."""
    up = nx.DiGraph()
    for node in case.nodes:
        up.add_node(node.id)
        for child in node.supported_by:
            up.add_edge(child, node.id)
        for target in node.challenges:
            up.add_edge(node.id, target)
    text = {n.id: n.text for n in case.nodes}
    traces: dict[str, list[list[TraceStep]]] = {}
    for node in case.nodes:
        if node.id == case.root_id:
            paths = [[node.id]]
        else:
            paths = list(nx.all_simple_paths(up, node.id, case.root_id))
        traces[node.id] = [[TraceStep(id=i, text=text[i]) for i in p] for p in paths]
    return traces


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """(first, last) index of each run of True values."""
    padded = np.concatenate(([False], mask, [False])).astype(np.int8)
    edges = np.flatnonzero(np.diff(padded))
    return [(int(a), int(b) - 1) for a, b in zip(edges[::2], edges[1::2], strict=True)]


def _merge(runs: list[tuple[int, int]], gap_ticks: int) -> list[tuple[int, int]]:
    merged: list[tuple[int, int]] = []
    for a, b in runs:
        if merged and a - merged[-1][1] - 1 < gap_ticks:
            merged[-1] = (merged[-1][0], b)
        else:
            merged.append((a, b))
    return merged


@dataclass(frozen=True)
class _Signal:
    values: np.ndarray  # NaN = no value
    robustness: np.ndarray


def _synth_signal(
    rng: np.random.Generator, n: int, op: str, threshold: float, dips: int, gaps: int
) -> _Signal:
    """A noisy healthy signal with `dips` excursions across the threshold and `gaps` dropouts."""
    healthy = threshold + 0.25 if op == ">=" else threshold * 0.3
    noise = np.cumsum(rng.normal(0.0, 0.004, n))
    noise -= np.convolve(noise, np.ones(51) / 51, mode="same")
    values = healthy + noise
    for _ in range(dips):
        depth = float(rng.uniform(0.3, 1.6))  # how far past the threshold this dip goes
        bad = threshold - 0.2 * depth if op == ">=" else threshold * (1 + 1.5 * depth)
        start = int(rng.integers(0, max(1, n - 80)))
        width = int(rng.integers(5, 60))
        ramp = np.sin(np.linspace(0, np.pi, width)) ** 0.5
        values[start : start + width] = healthy + (bad - healthy) * ramp[: n - start]
    for _ in range(gaps):
        start = int(rng.integers(0, max(1, n - 40)))
        values[start : start + int(rng.integers(3, 30))] = np.nan
    robustness = values - threshold if op == ">=" else threshold - values
    return _Signal(values=values, robustness=robustness)


def _decimate(
    t: np.ndarray, values: np.ndarray, max_buckets: int
) -> tuple[float, list, list, list]:
    """Per-bucket min and max (None for an empty bucket), at most `max_buckets` buckets."""
    n = len(values)
    per = max(1, int(np.ceil(n / max_buckets)))
    pad = (-n) % per
    v = np.concatenate((values, np.full(pad, np.nan))).reshape(-1, per)
    starts = t[::per]
    all_nan = np.all(np.isnan(v), axis=1)
    with np.errstate(all="ignore"):
        lo = np.where(all_nan, 0.0, np.nanmin(np.where(all_nan[:, None], 0.0, v), axis=1))
        hi = np.where(all_nan, 0.0, np.nanmax(np.where(all_nan[:, None], 0.0, v), axis=1))
    lo_list = [None if e else round(float(x), 5) for x, e in zip(lo, all_nan, strict=True)]
    hi_list = [None if e else round(float(x), 5) for x, e in zip(hi, all_nan, strict=True)]
    period = float(t[1] - t[0]) if len(t) > 1 else 0.1
    return per * period, [round(float(s), 3) for s in starts], lo_list, hi_list


def _intervals(t: np.ndarray, codes: np.ndarray, names: list[str]) -> list[StatusInterval]:
    change = np.flatnonzero(np.diff(codes)) + 1
    bounds = np.concatenate(([0], change, [len(codes)]))
    return [
        StatusInterval(
            status=names[int(codes[a])],  # type: ignore[arg-type]
            start=round(float(t[a]), 3),
            end=round(float(t[b - 1]), 3),
            ticks=int(b - a),
        )
        for a, b in itertools.pairwise(bounds)
    ]


def sample_result(
    *,
    duration: float = 180.0,
    period: float = 0.1,
    seed: int = 7,
    dips_per_minute: float = 1.0,
    gaps_per_minute: float = 0.5,
    hostile: bool = False,
    max_buckets: int = 1000,
) -> RunResult:
    """A plausible run of the reference case with violations, hazards, gaps and labels."""
    rng = np.random.default_rng(seed)
    case = reference_case(hostile=hostile)
    n = round(duration / period)
    t = np.round(np.arange(n) * period, 3)
    minutes = duration / 60.0
    traces = _traces(case)
    by_id = {node.id: node for node in case.nodes}
    binding = {row[0]: row[6] for row in _REFERENCE_NODES}
    merge_ticks = round(1.0 / period)

    severity_names = sorted(STATUS_SEVERITY, key=STATUS_SEVERITY.__getitem__)
    code = {name: i for i, name in enumerate(severity_names)}
    status_codes: dict[str, np.ndarray] = {}
    formulas: list[FormulaStats] = []
    episodes: list[Episode] = []
    gaps: list[DataGap] = []
    series: list[Series] = []
    signals: dict[str, _Signal] = {}

    for node in case.nodes:
        spec = binding[node.id]
        if node.type == "Sn" and isinstance(spec, tuple):
            sig_name, op, threshold = spec
            dips = int(rng.poisson(dips_per_minute * minutes * (1.5 if sig_name == "els" else 0.6)))
            sig = _synth_signal(
                rng, n, op, threshold, dips, int(rng.poisson(gaps_per_minute * minutes))
            )
            signals[sig_name] = sig
            source = f"{sig_name} {op} {threshold:g}"
            rtamt = f"({sig_name} {op} {threshold:g})"
            threshold_text = f"{op} {threshold:g}"
            kind = "spi"
        elif node.type == "CSn" and isinstance(spec, str):
            sig = _synth_signal(
                rng,
                n,
                "<=",
                0.05,
                int(rng.poisson(dips_per_minute * minutes * 0.5)),
                int(rng.poisson(gaps_per_minute * minutes * 0.5)),
            )
            sig_name, threshold, source, rtamt, threshold_text = (
                None,
                None,
                spec,
                f"not ({spec})",
                None,
            )
            kind = "hazard"
        else:
            continue
        violating = np.nan_to_num(sig.robustness, nan=1.0) < 0
        missing = np.isnan(sig.values)
        runs = _merge(_runs(violating), merge_ticks)
        for a, b in runs:
            seg = sig.robustness[a : b + 1]
            k = int(np.nanargmin(seg))
            episodes.append(
                Episode(
                    formula_id=node.id,
                    node_id=node.id,
                    kind=kind,  # type: ignore[arg-type]
                    start=float(t[a]),
                    end=float(t[b]),
                    ticks=int(np.count_nonzero(violating[a : b + 1])),
                    worst_robustness=round(float(seg[k]), 4),
                    t_worst=float(t[a + k]),
                    trace=traces[node.id],
                )
            )
        for a, b in _runs(missing):
            gaps.append(
                DataGap(
                    formula_id=node.id,
                    node_id=node.id,
                    start=float(t[a]),
                    end=float(t[b]),
                    ticks=b - a + 1,
                    missing=[sig_name or "ss", "ppcs"][: 1 if sig_name else 2],
                )
            )
        rob = np.where(missing, np.inf, sig.robustness)
        worst_k = int(np.argmin(rob))
        formulas.append(
            FormulaStats(
                id=node.id,
                node_id=node.id,
                node_text=node.text,
                kind=kind,  # type: ignore[arg-type]
                source=source,
                rtamt=rtamt,
                signal=sig_name,
                threshold=threshold_text,
                signals=sorted({sig_name} if sig_name else {"ocs", "ols", "ss", "ppcs"}),
                ticks_evaluated=int(n - missing.sum()),
                ticks_violated=int(violating.sum()),
                ticks_no_data=int(missing.sum()),
                episodes=len(runs),
                worst_robustness=round(float(rob[worst_k]), 4)
                if np.isfinite(rob[worst_k])
                else None,
                t_worst=float(t[worst_k]) if np.isfinite(rob[worst_k]) else None,
            )
        )
        plotted = sig.values if kind == "spi" else sig.robustness
        bucket, starts, lo, hi = _decimate(t, plotted, max_buckets)
        series.append(
            Series(
                formula_id=node.id,
                quantity="signal" if kind == "spi" else "robustness",
                name=sig_name or "robustness",
                bucket=bucket,
                t=starts,
                lo=lo,
                hi=hi,
                reference=threshold if kind == "spi" else 0.0,
            )
        )
        status_codes[node.id] = np.where(
            missing, code["no-data"], np.where(violating, code["violated"], code["satisfied"])
        )

    # Status propagation bottom-up: support violated -> undermined; challenged -> in-doubt.
    order = list(
        reversed(
            list(
                nx.topological_sort(
                    nx.DiGraph([(p.id, c) for p in case.nodes for c in p.supported_by])
                )
            )
        )
    )
    for node_id in order:
        node = by_id[node_id]
        if node_id in status_codes:
            continue
        if node.type == "Sn":
            status_codes[node_id] = np.full(n, code["external"])
            continue
        child = np.max([status_codes[c] for c in node.supported_by], axis=0)
        mine = np.where(child >= code["violated"], code["undermined"], child)
        mine = np.maximum(mine, code["satisfied"])
        for counter in case.nodes:
            if node_id in counter.challenges and counter.id in status_codes:
                active = status_codes[counter.id] == code["violated"]
                mine = np.where(active, np.maximum(mine, code["in-doubt"]), mine)
        status_codes[node_id] = mine
    for node in case.nodes:
        if node.id not in status_codes:
            status_codes[node.id] = np.full(n, code["external"])
    statuses = []
    for node in case.nodes:
        codes = status_codes[node.id]
        counts = np.bincount(codes, minlength=len(severity_names))
        statuses.append(
            NodeStatus(
                node_id=node.id,
                worst=severity_names[int(codes.max())],  # type: ignore[arg-type]
                timeline=_intervals(t, codes, severity_names),
                ticks={severity_names[i]: int(c) for i, c in enumerate(counts) if c},
            )
        )
    episodes.sort(key=lambda e: (e.start, e.node_id))
    gaps.sort(key=lambda g: (g.start, g.node_id))

    hazard_scores = []
    for node_id in ("CSn1", "CSn2", "CSn3"):
        events = sum(1 for e in episodes if e.node_id == node_id)
        tp = max(0, events - 1)
        fp = events - tp
        fn = 1
        hazard_scores.append(
            HazardScore(
                hazard=node_id,
                true_positives=tp,
                false_positives=fp,
                false_negatives=fn,
                precision=tp / (tp + fp) if tp + fp else None,
                recall=tp / (tp + fn) if tp + fn else None,
            )
        )
    tp = sum(h.true_positives for h in hazard_scores)
    fp = sum(h.false_positives for h in hazard_scores)
    fn = sum(h.false_negatives for h in hazard_scores)
    overall = HazardScore(
        hazard="overall",
        true_positives=tp,
        false_positives=fp,
        false_negatives=fn,
        precision=tp / (tp + fp) if tp + fp else None,
        recall=tp / (tp + fn) if tp + fn else None,
    )
    meta: dict[str, object] = {"town": "Town01", "weather": "HardRainNoon"}
    defects = [
        StreamDefect(
            line=1 + int(i),
            kind="channel-missing",
            message=f"channel 'tfuse' absent at t={t[i]:.1f}",
        )
        for i in sorted(rng.choice(n, size=min(n, max(3, int(minutes * 2))), replace=False))
    ]
    if hostile:
        meta["object_classes"] = ["<script>alert(1)</script>", 'car "big" & <b>bold</b>']
        meta["<script>alert(1)</script>"] = "key & value"
        defects.append(
            StreamDefect(
                line=99,
                kind="bad-object",
                message='unknown class "<script>alert(1)</script>" & \x01\x1b',
            )
        )
    stream = StreamInfo(
        path="logs/town01-hardrain.jsonl",
        digest="sha256:" + "a7" * 32,
        meta=meta,
        frames_read=n,
        t_start=0.0,
        t_end=float(t[-1]),
        duration=round(n * period, 3),
        defects=defects,
        defect_count=len(defects),
        dropouts={"tfuse": len(defects)},
    )
    root = next(s for s in statuses if s.node_id == case.root_id)
    return RunResult(
        casewatch_version="0.1.0",
        created="2026-11-21T06:00:00Z",
        case=case,
        stream=stream,
        verdict=root.worst,
        formulas=formulas,
        episodes=episodes,
        data_gaps=gaps,
        status=statuses,
        series=series,
        ground_truth=GroundTruth(
            labels_path="logs/town01-labels.json",
            labels_digest="sha256:" + "5c" * 32,
            per_hazard=hazard_scores,
            overall=overall,
        ),
        timings=Timings(
            total_s=round(duration / 400, 3),
            read_s=0.1,
            metrics_s=0.2,
            stl_s=0.3,
            episodes_status_s=0.05,
            frames_per_s=round(n / max(duration / 400, 1e-9)),
        ),
    )


def long_run_result(*, duration: float = 3600.0, seed: int = 11) -> RunResult:
    """A 1-hour, 10 Hz run with hundreds of episodes and data gaps: the report-size benchmark."""
    return sample_result(
        duration=duration, period=0.1, seed=seed, dips_per_minute=1.0, gaps_per_minute=0.4
    )
