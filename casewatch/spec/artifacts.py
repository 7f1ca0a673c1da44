"""Writing a compiled specification to disk: `specs.stl`, `trace.json`, `signals.json`.

The files are for people and other tools (an assessor reading what is monitored, a script
feeding rtamt directly); the evaluator itself takes the `CompiledSpec` value.
"""

from __future__ import annotations

import json
from pathlib import Path

from casewatch.safety_case.signals import available_signals
from casewatch.spec.emit import OUTPUT_VAR
from casewatch.spec.model import CompiledSpec


def specs_text(spec: CompiledSpec) -> str:
    """Every formula as rtamt text, one per line, each after a comment naming its node."""
    lines = [
        f"# casewatch compiled specification of {spec.case_path} (module {spec.module})",
        f"# sha256 {spec.case_digest}; sampling period {spec.period:g}s; "
        f"channels {', '.join(spec.channels)}",
        f"# each formula is the right-hand side of `{OUTPUT_VAR} = ...` in an rtamt "
        "discrete-time specification; inputs are float signals",
    ]
    for f in spec.formulas:
        text = " ".join(f.node_text.split())
        lines.append("")
        lines.append(f"# {f.node_id} ({f.kind}): {text}")
        lines.append(f"# source: {' '.join(f.source.split())}")
        lines.append(f.rtamt)
        if f.assumption is not None:  # a contract: judged only where this one holds
            lines.append(
                f"# {f.assumption.id} (the assumption of {f.node_id}): "
                f"{' '.join(f.assumption.source.split())}"
            )
            lines.append(f.assumption.rtamt)
    return "\n".join(lines) + "\n"


def trace_map(spec: CompiledSpec) -> dict[str, dict[str, list[list[dict[str, str]]]]]:
    """formula id -> node id -> every trace from that node to the root."""
    return {
        f.id: {f.node_id: [[step.model_dump() for step in path] for path in spec.traces[f.node_id]]}
        for f in spec.formulas
    }


def signal_map(spec: CompiledSpec, declared: dict[str, str]) -> dict[str, object]:
    """Declared stream signals (used or not) and every signal a formula uses, with users."""
    catalogue = available_signals(spec.channels, declared)
    names = sorted(set(declared) | set(spec.signals))
    signals = {}
    for name in names:
        info = catalogue.get(name)
        signals[name] = {
            "source": "declared" if name in declared else "builtin",
            "description": info.description if info else "",
            "formulas": spec.signals.get(name, []),
        }
    return {"channels": spec.channels, "period": spec.period, "signals": signals}


def write_artifacts(
    spec: CompiledSpec, out_dir: str | Path, declared: dict[str, str]
) -> list[Path]:
    """Write the three files into `out_dir` (created if missing); returns their paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    files = {
        "specs.stl": specs_text(spec),
        "trace.json": json.dumps(trace_map(spec), indent=2) + "\n",
        "signals.json": json.dumps(signal_map(spec, declared), indent=2) + "\n",
    }
    written = []
    for name, text in files.items():
        path = out / name
        path.write_text(text, encoding="utf-8")
        written.append(path)
    return written
