"""Regenerate the bundled reference data under `examples/data/` (`make data`).

    python -m examples.sim.build_data [--out examples/data] [--only NAME ...] [--figure PATH]

Runs every scenario of `examples.sim.scenarios.BUNDLED` in SUMO, writes the streams and the two
label files per scenario, an index (`index.json`: files, frames, label counts), and the figure of
`docs/reference-data.md`. Deterministic for a given SUMO version: seeds live in the scenarios.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

from examples.sim.frames import generate
from examples.sim.scenarios import BUNDLED, SCENARIOS

ROOT = Path(__file__).resolve().parents[2]
DEFAULT_OUT = ROOT / "examples" / "data"
DEFAULT_FIGURE = ROOT / "docs" / "img" / "reference-scenario.png"
FIGURE_SCENARIO = "urban-grid"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m examples.sim.build_data", description=__doc__)
    ap.add_argument("--out", type=Path, default=DEFAULT_OUT)
    ap.add_argument("--only", nargs="*", default=None, help="scenario names (default: bundled)")
    ap.add_argument("--figure", type=Path, default=DEFAULT_FIGURE)
    ap.add_argument("--no-figure", action="store_true")
    args = ap.parse_args(argv)
    try:
        import libsumo  # noqa: F401
    except ImportError:
        print("error: libsumo is not installed; run: pip install -e .[sim]", file=sys.stderr)
        return 2
    names = args.only or [s.name for s in BUNDLED]
    unknown = [n for n in names if n not in SCENARIOS]
    if unknown:
        print(f"error: unknown scenario(s) {unknown}; known: {sorted(SCENARIOS)}", file=sys.stderr)
        return 2
    index = []
    with tempfile.TemporaryDirectory(prefix="cwsim-") as tmp:
        for name in names:
            sc = SCENARIOS[name]
            g = generate(sc, args.out, Path(tmp) / name)
            entry = {
                "scenario": name, "seed": sc.seed, "duration": sc.duration, "frames": g.frames,
                "stream": g.stream.name, "labels": g.labels.name, "ssm_labels": g.ssm_labels.name,
                "bytes": g.stream.stat().st_size, "label_counts": g.label_counts,
                "ssm_label_counts": g.ssm_label_counts,
            }
            index.append(entry)
            print(json.dumps(entry))
            if name == FIGURE_SCENARIO and not args.no_figure:
                from examples.sim.figure import plot_scenario

                plot_scenario(sc, g, args.figure)
                print(f"figure: {args.figure}")
    if args.only is None:
        (args.out / "index.json").write_text(json.dumps(index, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
