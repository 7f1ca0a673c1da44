"""Regenerate the bundled reference data under `examples/data/` (`make data`).

    python -m examples.sim.build_data [--out examples/data] [--only NAME ...] [--figure PATH]
    python -m examples.sim.build_data --only highway-realstack --seed 1234 --out /tmp/heldout

Runs every scenario of `examples.sim.scenarios.BUNDLED` in SUMO, writes the streams and the two
label files per scenario, an index (`index.json`: files, frames, label counts), and the figures
of `docs/reference-data.md`. Deterministic for a given SUMO version: seeds live in the scenarios.

`--seed N` runs the named scenarios with seed N instead of their own (SUMO's traffic, the
background and every channel's noise change; the script stays the same), for held-out
validation. It needs `--out` outside `examples/data`, never writes a figure, and the streams
record the seed in their header. `--only` also accepts scenarios that are not bundled (see
`SCENARIOS`, e.g. `highway-merge-realstack`).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from dataclasses import replace
from pathlib import Path

from examples.sim.frames import generate
from examples.sim.scenarios import BUNDLED, SCENARIOS

ROOT = Path(__file__).resolve().parents[2]
DEFAULT_OUT = ROOT / "examples" / "data"
DEFAULT_FIGURE = ROOT / "docs" / "img" / "reference-scenario.png"
FIGURE_SCENARIO = "urban-grid"
#: The second figure (real-stack profiles), written next to `--figure`.
REALSTACK_FIGURE_SCENARIO = "urban-realstack"
REALSTACK_FIGURE_NAME = "realstack-scenario.png"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m examples.sim.build_data",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ap.add_argument("--out", type=Path, default=DEFAULT_OUT)
    ap.add_argument("--only", nargs="*", default=None, help="scenario names (default: bundled)")
    ap.add_argument(
        "--seed",
        type=int,
        default=None,
        help="run with this seed instead of the scenarios' own (held-out data)",
    )
    ap.add_argument("--figure", type=Path, default=DEFAULT_FIGURE)
    ap.add_argument("--no-figure", action="store_true")
    args = ap.parse_args(argv)
    if args.seed is not None and args.out.resolve() == DEFAULT_OUT.resolve():
        print(
            f"error: --seed writes held-out data; give an --out other than {DEFAULT_OUT}",
            file=sys.stderr,
        )
        return 2
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
    figures = (
        {}
        if args.no_figure or args.seed is not None
        else {
            FIGURE_SCENARIO: args.figure,
            REALSTACK_FIGURE_SCENARIO: args.figure.parent / REALSTACK_FIGURE_NAME,
        }
    )
    index = []
    with tempfile.TemporaryDirectory(prefix="cwsim-") as tmp:
        for name in names:
            sc = SCENARIOS[name]
            if args.seed is not None:
                sc = replace(sc, seed=args.seed)
            g = generate(sc, args.out, Path(tmp) / name)
            entry = {
                "scenario": name,
                "seed": sc.seed,
                "duration": sc.duration,
                "frames": g.frames,
                "stream": g.stream.name,
                "labels": g.labels.name,
                "ssm_labels": g.ssm_labels.name,
                "bytes": g.stream.stat().st_size,
                "label_counts": g.label_counts,
                "ssm_label_counts": g.ssm_label_counts,
            }
            index.append(entry)
            print(json.dumps(entry))
            if name in figures:
                from examples.sim.figure import plot_scenario

                plot_scenario(sc, g, figures[name])
                print(f"figure: {figures[name]}")
    # the full set, or any run outside examples/data (a partial run there would truncate it)
    if args.only is None or args.out.resolve() != DEFAULT_OUT.resolve():
        (args.out / "index.json").write_text(json.dumps(index, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
