"""`make demo`: check the reference case, judge the bundled drives, say where the reports are.

Runs exactly what a user would type:

    casewatch check examples/reference-case.yaml
    casewatch run examples/reference-case.yaml examples/data --labels auto --jobs 2 -o out/demo
    python -m casewatch.nominal out/demo      # each SPI's false alarms on nominal driving
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from casewatch.cli import main as cli
from casewatch.nominal import main as nominal

REPO = Path(__file__).resolve().parent.parent
CASE = REPO / "examples" / "reference-case.yaml"
DATA = REPO / "examples" / "data"
OUT = Path("out") / "demo"


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
    truth = summary.get("ground_truth")
    if truth:
        print("\nHazard detection against the labels (all logs):")
        for row in [*truth["per_hazard"], truth["overall"]]:
            p = "n/a" if row["precision"] is None else f"{row['precision']:.1%}"
            r = "n/a" if row["recall"] is None else f"{row['recall']:.1%}"
            print(f"  {row['hazard']:>5}: {row['true_positives']} TP, {row['false_positives']} FP, "
                  f"{row['false_negatives']} FN; precision {p}, recall {r}")
    print(f"Fleet summary: {(OUT / 'summary.json').resolve()}")
    print(f"\n$ python -m casewatch.nominal {OUT}")
    nominal([str(OUT)])
    return 0


if __name__ == "__main__":
    sys.exit(main())
