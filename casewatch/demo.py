"""`make demo`: check the reference case, judge the bundled drives, say where the reports are.

Runs exactly what a user would type:

    casewatch check examples/reference-case.yaml
    casewatch run examples/reference-case.yaml examples/data --labels auto --jobs 2 -o out/demo
    casewatch run examples/study-case.yaml examples/data --labels auto --jobs 2 \
        --format none -o out/demo-study       # the study's own hazard rules, for comparison
    python -m casewatch.nominal out/demo      # each SPI's false alarms on nominal driving
    python -m examples.sim.stack_timing examples/data/highway-tailgating.jsonl.gz \
        --out out/demo-bags                   # as a ROS 2 bag with a real stack's timing
    casewatch run examples/odd/contracts-case.yaml examples/data/odd-grid --jobs 2 \
        --format none --quiet -o out/demo-odd-runs   # contracts over the ODD grid
    casewatch odd out/demo-odd-runs --by road.type,environment.weather,environment.light \
        -o out/demo-odd                       # the accepted domain, against the known degradation
    casewatch run examples/rules/rules-case.yaml examples/data/rules --labels auto --jobs 2 \
        --format none --quiet -o out/demo-rules    # traffic rules against SUMO's truth
    casewatch compare out/demo-rules --net examples/data/rules/rules.net.xml \
        -o out/demo-compare                   # drivers x scenarios, scores, violation map
    python -m examples.sim.heldout            # the same on fresh generator seeds (needs SUMO)

The last step runs only when the simulator extra is installed (`pip install -e .[sim]`, which
`.ci/run` installs); without it the demo says how to get those figures.
"""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path

from casewatch.cli import main as cli
from casewatch.nominal import main as nominal

REPO = Path(__file__).resolve().parent.parent
CASE = REPO / "examples" / "reference-case.yaml"
DATA = REPO / "examples" / "data"
STUDY = REPO / "examples" / "study-case.yaml"
OUT = Path("out") / "demo"
OUT_STUDY = Path("out") / "demo-study"
OUT_BAGS = Path("out") / "demo-bags"
ODD_CASE = REPO / "examples" / "odd" / "contracts-case.yaml"
ODD_GRID = DATA / "odd-grid"
OUT_ODD_RUNS = Path("out") / "demo-odd-runs"
OUT_ODD = Path("out") / "demo-odd"
ODD_BY = "road.type,environment.weather,environment.light"
RULES_CASE = REPO / "examples" / "rules" / "rules-case.yaml"
RULES_DATA = DATA / "rules"
OUT_RULES = Path("out") / "demo-rules"
OUT_COMPARE = Path("out") / "demo-compare"


def score_text(row: dict) -> str:
    """`TP/FP/FN, precision, recall` of one hazard row of a summary's ground truth."""
    p = "n/a" if row["precision"] is None else f"{row['precision']:.0%}"
    r = "n/a" if row["recall"] is None else f"{row['recall']:.0%}"
    return (f"{row['true_positives']}/{row['false_positives']}/{row['false_negatives']} "
            f"TP/FP/FN, P {p}, R {r}")


def main() -> int:
    print(f"$ casewatch check {CASE.relative_to(REPO)}")
    code = cli(["check", str(CASE)])
    if code != 0:
        print("demo: the reference case does not pass check", file=sys.stderr)
        return code
    print(f"\n$ casewatch run {CASE.relative_to(REPO)} {DATA.relative_to(REPO)} "
          f"--labels auto --jobs 2 -o {OUT}")
    code = cli(["run", str(CASE), str(DATA), "--labels", "auto", "--jobs", "2", "-o", str(OUT)])
    if code not in (0, 1):
        return code
    summary = json.loads((OUT / "summary.json").read_text())
    print("\nReports:")
    for log in summary["per_log"]:
        report = Path(log["out_dir"]) / "report.html"
        print(f"  {log['verdict']:>11}  {report.resolve()}")
    print(f"\n$ casewatch run {STUDY.relative_to(REPO)} {DATA.relative_to(REPO)} "
          f"--labels auto --jobs 2 --format none -o {OUT_STUDY}")
    code = cli(["run", str(STUDY), str(DATA), "--labels", "auto", "--jobs", "2",
                "--format", "none", "-o", str(OUT_STUDY)])  # fmt: skip
    if code not in (0, 1):
        return code
    study = json.loads((OUT_STUDY / "summary.json").read_text())
    print("\nHazard detection against the labels (all logs), reference rules (situation "
          "signals) vs the study's rules:")
    print(f"  {'hazard':>6}  {'reference-case.yaml':<36}  {'study-case.yaml':<36}")
    ours, theirs = summary.get("ground_truth"), study.get("ground_truth")
    if ours and theirs:
        for a, b in zip([*ours["per_hazard"], ours["overall"]],
                        [*theirs["per_hazard"], theirs["overall"]], strict=True):  # fmt: skip
            print(f"  {a['hazard']:>6}  {score_text(a):<36}  {score_text(b):<36}")
    print(f"Fleet summary: {(OUT / 'summary.json').resolve()}")
    print(f"\n$ python -m casewatch.nominal {OUT}")
    nominal([str(OUT)])
    drive = DATA / "highway-tailgating.jsonl.gz"
    print(f"\n$ python -m examples.sim.stack_timing {drive.relative_to(REPO)} --out {OUT_BAGS}")
    print("  (the drive as an MCAP bag of Autoware messages, stamped with a real stack's phase, "
          "skew, jitter and delays; docs/bags.md)")
    from examples.sim.stack_timing import main as stack_timing  # the repository's examples

    stack_timing([str(drive), "--out", str(OUT_BAGS)])
    code = odd_demo()
    if code not in (0, 1):
        return code
    code = rules_demo()
    if code not in (0, 1):
        return code
    return heldout()


def rules_demo() -> int:
    """The traffic rules on the bundled SUMO rule drives, and the drivers compared."""
    print(f"\n$ casewatch run {RULES_CASE.relative_to(REPO)} {RULES_DATA.relative_to(REPO)} "
          f"--labels auto --jobs 2 --format none --quiet -o {OUT_RULES}")
    code = cli(["run", str(RULES_CASE), str(RULES_DATA), "--labels", "auto", "--jobs", "2",
                "--format", "none", "--quiet", "-o", str(OUT_RULES)])  # fmt: skip
    if code not in (0, 1):
        return code
    truth = json.loads((OUT_RULES / "summary.json").read_text())["ground_truth"]
    print("\nTraffic rules against SUMO's ground truth (all rule drives):")
    for row in [*truth["per_hazard"], truth["overall"]]:
        print(f"  {row['hazard']:>24}  {score_text(row)}")
    net = RULES_DATA / "rules.net.xml"
    print(f"\n$ casewatch compare {OUT_RULES} --net {net.relative_to(REPO)} -o {OUT_COMPARE}")
    code = cli(["compare", str(OUT_RULES), "--net", str(net), "-o", str(OUT_COMPARE)])
    print(f"Comparison and violation map: {(OUT_COMPARE / 'compare.html').resolve()}")
    return code


def odd_demo() -> int:
    """Contracts over the bundled ODD grid, and the domain they support (docs/odd.md)."""
    print(f"\n$ casewatch run {ODD_CASE.relative_to(REPO)} {ODD_GRID.relative_to(REPO)} "
          f"--jobs 2 --format none --quiet -o {OUT_ODD_RUNS}")
    code = cli(["run", str(ODD_CASE), str(ODD_GRID), "--jobs", "2", "--format", "none",
                "--quiet", "-o", str(OUT_ODD_RUNS)])  # fmt: skip
    if code not in (0, 1):
        return code
    print(f"\n$ casewatch odd {OUT_ODD_RUNS} --by {ODD_BY} -o {OUT_ODD}")
    code = cli(["odd", str(OUT_ODD_RUNS), "--by", ODD_BY, "-o", str(OUT_ODD)])
    print(f"ODD heatmap: {(OUT_ODD / 'odd.html').resolve()}")
    return code


def heldout() -> int:
    """Hazard and nominal figures on fresh generator seeds (`examples.sim.heldout`), when the
    simulator is installed; otherwise the command that gives them."""
    print("\n$ python -m examples.sim.heldout")
    if importlib.util.find_spec("libsumo") is None or importlib.util.find_spec("sumolib") is None:
        print("  held-out seeds need the simulator: pip install -e '.[sim]' (or make data), "
              "then python -m examples.sim.heldout")
        return 0
    from examples.sim.heldout import main as run_heldout  # the optional extra, loaded late

    return run_heldout([])


if __name__ == "__main__":
    sys.exit(main())
