"""Judge the drives of the SPI sweep and tabulate, per SPI, nominal false alarms and detection.

Separate from `examples.sim.spi_sweep` (which writes the drives) so the figures can be
recomputed from a judged sweep without SUMO, and so a test can run the analysis on small
drives of its own.
"""

from __future__ import annotations

import contextlib
import io
import json
import sys
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from casewatch.cli import main as cli
from casewatch.evaluator.faults import (
    FAMILY_SIGNALS,
    FaultLabel,
    detected,
    fault_labels_path,
    read_fault_labels,
)
from casewatch.evaluator.nominal import nominal_shares
from casewatch.evaluator.result import RunResult
from casewatch.nominal import nominal_labels
from casewatch.reports.render import load_result


@dataclass
class SpiFigures:
    """One SPI over a set of drives: nominal ticks evaluated and violated, faults of its
    families injected and detected (per family)."""

    node_id: str
    signal: str
    evaluated: int = 0
    violated: int = 0
    faults: dict[str, list[int]] = field(default_factory=dict)  # family -> [injected, found]

    @property
    def nominal(self) -> float | None:
        return self.violated / self.evaluated if self.evaluated else None

    def detection(self) -> float | None:
        total = sum(v[0] for v in self.faults.values())
        return sum(v[1] for v in self.faults.values()) / total if total else None

    def as_dict(self) -> dict[str, Any]:
        return {
            "node_id": self.node_id,
            "signal": self.signal,
            "evaluated": self.evaluated,
            "violated": self.violated,
            "nominal": self.nominal,
            "faults": self.faults,
            "detection": self.detection(),
        }


def spi_episodes(result: RunResult) -> dict[str, list[tuple[float, float]]]:
    """SPI node id -> its episodes (start, end) in a run."""
    out: dict[str, list[tuple[float, float]]] = defaultdict(list)
    for e in result.episodes:
        if e.kind == "spi":
            out[e.node_id].append((e.start, e.end))
    return out


def spi_signals(result: RunResult) -> dict[str, str]:
    """SPI node id -> the signal it reads (or its formula when it has no single signal)."""
    return {f.node_id: f.signal or f.source for f in result.formulas if f.kind == "spi"}


def figures_of(
    clean: RunResult,
    faulted: RunResult | None,
    faults: list[FaultLabel],
    *into: dict[str, SpiFigures],
) -> None:
    """Add one drive pair's figures to each of `into` (by SPI node id): the clean run's
    nominal shares (its labels and SSM conflicts not nominal) and, with the faulted run, each
    fault's detection."""
    if clean.ground_truth is None:
        raise ValueError("the clean run was judged without labels")
    shares = nominal_shares(clean, nominal_labels(Path(clean.ground_truth.labels_path)))
    found: list[tuple[str, str, str, bool]] = []  # node, signal, family, detected
    if faulted is not None:
        with_fault, without = spi_episodes(faulted), spi_episodes(clean)
        found = [
            (node, signal, f.fault, detected(with_fault.get(node, []), without.get(node, []), f))
            for node, signal in spi_signals(clean).items()
            for f in faults
            if signal in FAMILY_SIGNALS[f.fault]
        ]
    for target in into:
        for share in shares:
            fig = target.setdefault(share.node_id, SpiFigures(share.node_id, share.signal))
            fig.evaluated += share.evaluated
            fig.violated += share.violated
        for node, signal, family, hit in found:
            row = target.setdefault(node, SpiFigures(node, signal)).faults.setdefault(
                family, [0, 0]
            )
            row[0] += 1
            row[1] += hit


def _judge(case: Path, folder: Path, out: Path) -> int:
    with contextlib.redirect_stdout(io.StringIO()):
        return cli(
            [
                "run",
                str(case),
                str(folder),
                "--labels",
                "auto",
                "--jobs",
                "2",
                "--format",
                "none",
                "--quiet",
                "--save-signals",
                "-o",
                str(out),
            ]
        )


def judge_and_report(drives: list[Any], case: Path, out: Path, json_path: Path | None) -> int:
    """Judge every folder of `drives` with `case`, print the tables, write the figures."""
    folders = sorted({d.clean.parent for d in drives})
    results: dict[str, Path] = {}
    for folder in folders:
        run_dir = out / "runs" / folder.relative_to(out)
        code = _judge(case, folder, run_dir)
        if code not in (0, 1):
            print(f"spi-sweep: judging {folder} failed (exit {code})", file=sys.stderr)
            return 2
        summary = json.loads((run_dir / "summary.json").read_text(encoding="utf-8"))
        for entry in summary["per_log"]:
            if not entry.get("ok", True):
                print(f"spi-sweep: {entry['stream']}: {entry.get('error')}", file=sys.stderr)
                return 2
            results[str(Path(entry["stream"]).resolve())] = Path(entry["out_dir"])
    groups: dict[tuple[int, str], dict[str, SpiFigures]] = defaultdict(dict)
    total: dict[str, SpiFigures] = {}
    for d in drives:
        clean = load_result(results[str(d.clean.resolve())] / "result.json")
        faulted = load_result(results[str(d.faulted.resolve())] / "result.json")
        faults = read_fault_labels(fault_labels_path(d.faulted))
        figures_of(clean, faulted, faults, groups[(d.seed, d.profile)], total)
    print_tables(groups, total)
    if json_path is not None:
        json_path.parent.mkdir(parents=True, exist_ok=True)
        json_path.write_text(
            json.dumps(
                {
                    "groups": [
                        {"seed": s, "profile": p, "spis": [f.as_dict() for f in g.values()]}
                        for (s, p), g in sorted(groups.items())
                    ],
                    "total": [f.as_dict() for f in total.values()],
                },
                indent=1,
            ),
            encoding="utf-8",
        )
    return 0


def _pct(v: float | None) -> str:
    return "-" if v is None else f"{100 * v:.1f}"


def print_tables(
    groups: dict[tuple[int, str], dict[str, SpiFigures]], total: dict[str, SpiFigures]
) -> None:
    """Nominal % and detection % per SPI: one column per (seed, profile), then all."""
    keys = sorted(groups)
    head = "".join(f"{f's{s}/{p}':>12}" for s, p in keys)
    print(f"\nNominal ticks violated (%), per seed/profile, then all\n{'SPI':<16}{head}{'all':>8}")
    for node, fig in total.items():
        cells = "".join(
            f"{_pct(groups[k].get(node, SpiFigures(node, '')).nominal):>12}" for k in keys
        )
        print(f"{node + ' ' + fig.signal:<16}{cells}{_pct(fig.nominal):>8}")
    print(
        f"\nInjected faults detected (found/injected), per seed/profile, then all\n"
        f"{'SPI':<16}{head}{'all':>8}"
    )
    for node, fig in total.items():
        if not fig.faults:
            continue
        cells = ""
        for k in keys:
            g = groups[k].get(node)
            n = sum(v[0] for v in g.faults.values()) if g else 0
            found = sum(v[1] for v in g.faults.values()) if g else 0
            cells += f"{f'{found}/{n}':>12}"
        print(f"{node + ' ' + fig.signal:<16}{cells}{_pct(fig.detection()):>8}")
        for family, (n, found) in sorted(fig.faults.items()):
            print(
                f"{'  ' + family:<16}{'':>{12 * len(keys)}}{_pct(found / n if n else None):>8}"
                f"  ({found}/{n})"
            )
