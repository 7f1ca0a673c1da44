"""A case as gsn2x YAML, optionally with a run's live status as CSS classes.

`casewatch export-gsn CASE [RUN_DIR] -o OUT` writes `OUT/<name>.gsn.yaml`, which gsn2x renders
(`gsn2x OUT/<name>.gsn.yaml -s casewatch-status.css`), and with a run `OUT/casewatch-status.css`:
each node gets the class `casewatch_<status>` of its worst status over the run
(`casewatch_violated`, `casewatch_undermined`, `casewatch_in-doubt`, ...).

The file is gsn2x input by gsn2x's own rules (`safety_case.gsn2x_schema`): `challenges` is one
node or one relation (`G2 -> CG1`), `classes` a list, layers and presentation attributes as
read. What gsn2x does not know is kept where it ignores it and casewatch reads it back:
`module.additionalInformation.casewatch` holds the `monitor` block and, per node, its `spi` /
`hazard` / `contract` / `odd` binding, and the whole list when a node challenges more than one
node (gsn2x's `challenges` holds one). Loading the exported file gives the same case
(`tests/reports/test_gsn_export.py`). The modules of a case are written as one file.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import yaml

from casewatch.safety_case.gsn2x import relation_text
from casewatch.safety_case.model import (
    Case,
    ContractBinding,
    HazardBinding,
    MonitorConfig,
    Node,
    SpiBinding,
)
from casewatch.safety_case.odd import odd_to_data

#: Worst status -> stroke and fill of its nodes in the exported CSS.
STATUS_STYLE: dict[str, tuple[str, str]] = {
    "violated": ("#b00020", "#fde7ea"),
    "undermined": ("#c2410c", "#fff1e6"),
    "in-doubt": ("#a16207", "#fef9c3"),
    "no-data": ("#6b7280", "#f3f4f6"),
    "outside-odd": ("#0e7490", "#e0f2f7"),
    "outside-assumption": ("#4b5563", "#eef2f7"),
    "undeveloped": ("#6b7280", "#ffffff"),
    "satisfied": ("#15803d", "#e8f5e9"),
    "external": ("#374151", "#ffffff"),
}

CSS_NAME = "casewatch-status.css"


def status_class(status: str) -> str:
    return f"casewatch_{status}"


def _seconds(value: float | None) -> float | None:
    return None if value is None else float(value)


def _spi(spi: SpiBinding) -> dict[str, Any]:
    out: dict[str, Any] = {}
    if spi.stl is not None:
        out["stl"] = spi.stl
    else:
        out["signal"] = spi.signal
        assert spi.threshold is not None
        out["threshold"] = f"{spi.threshold.op} {spi.threshold.value!r}"
        if spi.for_seconds is not None:
            out["for"] = _seconds(spi.for_seconds)
    for key in ("merge_gap", "min_duration", "warn"):
        if (value := getattr(spi, key)) is not None:
            out[key] = float(value)
    return out


def _hazard(hazard: HazardBinding) -> dict[str, Any]:
    out: dict[str, Any] = {"when": hazard.when}
    for key in ("merge_gap", "min_duration", "warn"):
        if (value := getattr(hazard, key)) is not None:
            out[key] = float(value)
    return out


def _contract(contract: ContractBinding) -> dict[str, Any]:
    """As written: a library contract by name and (resolved) parameters, plus what the case
    wrote over it; or the hand-written pair."""
    out: dict[str, Any] = {}
    if contract.use is not None:
        out["use"] = contract.use
        out["params"] = dict(contract.params)
    if contract.assume is not None and not contract.assume_from_library:
        out["assume"] = contract.assume
    if not contract.guarantee_from_library:
        out["guarantee"] = contract.guarantee
    for key in ("merge_gap", "min_duration", "warn"):
        if (value := getattr(contract, key)) is not None:
            out[key] = float(value)
    return out


def _monitor(monitor: MonitorConfig) -> dict[str, Any]:
    out: dict[str, Any] = {
        "channels": list(monitor.channels),
        "period": float(monitor.period),
        "merge_gap": float(monitor.merge_gap),
        "min_duration": float(monitor.min_duration),
        "metrics": monitor.metrics.model_dump(),
    }
    if monitor.signals:
        out["signals"] = dict(monitor.signals)
    if monitor.coverage:
        out["coverage"] = {c: v.model_dump(exclude_none=True) for c, v in monitor.coverage.items()}
    if monitor.topics is not None:
        out["topics"] = monitor.topics
    return out


def challenged(node: Node) -> list[str]:
    """Everything `node` challenges, as gsn2x writes each: a node id or `A -> B`."""
    return [*node.challenges, *(relation_text(r) for r in node.challenged_relations)]


def _node(node: Node, status: str | None) -> dict[str, Any]:
    out: dict[str, Any] = {"text": node.text} if node.text else {}  # gsn2x: text is optional
    if node.supported_by:
        out["supportedBy"] = list(node.supported_by)
    if node.in_context_of:
        out["inContextOf"] = list(node.in_context_of)
    if targets := challenged(node):
        out["challenges"] = targets[0]  # gsn2x takes one; several are kept for casewatch
    if node.undeveloped:
        out["undeveloped"] = True
    if node.url is not None:
        out["url"] = node.url
    for key, value in node.gsn.items():
        out[key] = value
    classes = node.gsn.get("classes") or []
    classes = [classes] if isinstance(classes, str) else list(classes)  # gsn2x: a list
    if status is not None:
        classes = [c for c in classes if not c.startswith("casewatch_")] + [status_class(status)]
    if classes:
        out["classes"] = classes
    return out


def gsn_document(case: Case, statuses: Mapping[str, str] | None = None) -> dict[str, Any]:
    """The case as a gsn2x document (a plain dict, in the case's node order)."""
    info = dict(case.module.gsn.get("additionalInformation") or {})
    kept: dict[str, Any] = {}
    if case.monitor.channels:
        kept["monitor"] = _monitor(case.monitor)
    bindings: dict[str, dict[str, Any]] = {}
    for node in case.nodes.values():
        if node.spi is not None:
            bindings[node.id] = {"spi": _spi(node.spi)}
        elif node.hazard is not None:
            bindings[node.id] = {"hazard": _hazard(node.hazard)}
        elif node.contract is not None:
            bindings[node.id] = {"contract": _contract(node.contract)}
        elif node.odd is not None:  # the domain itself, whether it came from a file or not
            bindings[node.id] = {"odd": odd_to_data(node.odd)["odd"]}
        if len(targets := challenged(node)) > 1:
            bindings.setdefault(node.id, {})["challenges"] = targets
    if bindings:
        kept["bindings"] = bindings
    if kept:
        info["casewatch"] = kept
    module: dict[str, Any] = {"name": case.module.name, "brief": case.module.brief}
    # `extends` is applied already (the developed elements name their support), and the one
    # file written holds every module: gsn2x would look for the extended module in vain
    dropped = ("additionalInformation", "extends")
    module.update({k: v for k, v in case.module.gsn.items() if k not in dropped})
    if info:
        module["additionalInformation"] = info
    doc: dict[str, Any] = {"module": module}
    for node in case.nodes.values():
        doc[node.id] = _node(node, None if statuses is None else statuses.get(node.id))
    return doc


def status_css() -> str:
    """CSS for gsn2x's SVG: the worst status of each node as its outline and fill."""
    rules = [
        f".{status_class(s)} rect, .{status_class(s)} path, .{status_class(s)} ellipse, "
        f".{status_class(s)} polygon {{ stroke: {stroke}; fill: {fill}; stroke-width: 2; }}"
        for s, (stroke, fill) in STATUS_STYLE.items()
    ]
    return (
        "/* casewatch: each node's worst status over a run (casewatch export-gsn) */\n"
        + "\n".join(rules)
        + "\n"
    )


def write_gsn(case: Case, out_dir: Path, statuses: Mapping[str, str] | None = None) -> list[Path]:
    """Write `OUT/<module name>.gsn.yaml` (and the CSS with statuses); returns the paths."""
    out_dir.mkdir(parents=True, exist_ok=True)
    stem = "".join(c if c.isalnum() or c in "-_." else "-" for c in case.module.name) or "case"
    path = out_dir / f"{stem}.gsn.yaml"
    header = "# gsn2x argument written by casewatch export-gsn (docs/gsn2x.md)\n"
    text = yaml.safe_dump(
        gsn_document(case, statuses), sort_keys=False, allow_unicode=True, width=100
    )
    path.write_text(header + text, encoding="utf-8")
    written = [path]
    if statuses is not None:
        css = out_dir / CSS_NAME
        css.write_text(status_css(), encoding="utf-8")
        written.append(css)
    return written
