"""`make demo`: check the reference case, judge the bundled drives, and say what each part found.

Runs exactly what a user would type, in eight parts:

    casewatch check examples/reference-case.yaml
    casewatch run examples/reference-case.yaml examples/data --labels auto --jobs 2 -o out/demo
    casewatch run examples/study-case.yaml examples/data --labels auto --jobs 2 \
        --format none -o out/demo-study       # the study's own hazard rules, for comparison
    casewatch diff out/demo out/demo-study -o out/demo-diff   # judged against the labels
    python -m casewatch.nominal out/demo      # each SPI's false alarms on nominal driving
    python -m examples.sim.stack_timing examples/data/highway-tailgating.jsonl.gz \
        --out out/demo-bags                   # as a ROS 2 bag with a real stack's timing
    casewatch run examples/odd/contracts-case.yaml examples/data/odd-grid --jobs 2 \
        --format none --quiet -o out/demo-odd-runs   # contracts over the ODD grid
    casewatch odd out/demo-odd-runs \
        --by environment.weather,environment.intensity,environment.light \
        --bins intensity=0,30,70,100:light,medium,heavy -o out/demo-odd  # the study's 27 cells
    casewatch run examples/rules/rules-case.yaml examples/data/rules --labels auto --jobs 2 \
        --format none --quiet -o out/demo-rules    # traffic rules against SUMO's truth
    casewatch compare out/demo-rules --net examples/data/rules/rules.net.xml \
        -o out/demo-compare                   # drivers x scenarios, scores, violation map
    python -m examples.sim.heldout            # the same on fresh generator seeds (needs SUMO)

Each command's own output goes to `out/demo-logs/NN-name.txt`; the terminal gets the command,
the few figures that matter, and one verdict line per part (`  => ...`), every line within 100
columns. The last part runs only when the simulator extra is installed (`pip install -e
.[sim]`, which `.ci/run` installs); without it the demo says how to get those figures.
"""

from __future__ import annotations

import contextlib
import importlib.util
import io
import json
import os
import re
import sys
import textwrap
from collections.abc import Callable
from pathlib import Path

from casewatch.cli import main as cli

REPO = Path(__file__).resolve().parent.parent
CASE = REPO / "examples" / "reference-case.yaml"
DATA = REPO / "examples" / "data"
STUDY = REPO / "examples" / "study-case.yaml"
OUT = Path("out") / "demo"
OUT_STUDY = Path("out") / "demo-study"
OUT_DIFF = Path("out") / "demo-diff"
OUT_BAGS = Path("out") / "demo-bags"
OUT_LOGS = Path("out") / "demo-logs"
ODD_CASE = REPO / "examples" / "odd" / "contracts-case.yaml"
ODD_GRID = DATA / "odd-grid"
OUT_ODD_RUNS = Path("out") / "demo-odd-runs"
OUT_ODD = Path("out") / "demo-odd"
ODD_BY = "environment.weather,environment.intensity,environment.light"
ODD_BINS = "intensity=0,30,70,100:light,medium,heavy"  # the study's light, medium, heavy
RULES_CASE = REPO / "examples" / "rules" / "rules-case.yaml"
RULES_DATA = DATA / "rules"
OUT_RULES = Path("out") / "demo-rules"
OUT_COMPARE = Path("out") / "demo-compare"
#: Every line the demo prints fits this many columns (a terminal, a CI log, a pull request).
WIDTH = 100
PARTS = 8
#: A nominal share above this is a false alarm worth a look (`casewatch.nominal --limit`).
NOMINAL_LIMIT = 0.01


def show(text: str, indent: str = "  ") -> None:
    """Print `text` line by line, each wrapped to `WIDTH` columns (continuations indented)."""
    for line in text.splitlines() or [""]:
        line = line.rstrip()
        lead = line[: len(line) - len(line.lstrip())] or indent
        print(
            "\n".join(
                textwrap.wrap(line, WIDTH, subsequent_indent=lead + "    ", break_on_hyphens=False)
            )
            or ""
        )


def command(*words: object) -> None:
    """`$ casewatch ...` as typed, broken with ` \\` to stay within `WIDTH` (never between an
    option and its value)."""
    words = [str(w) for w in words]
    units: list[str] = []
    for word in words:
        if (
            units
            and units[-1].startswith("-")
            and " " not in units[-1]
            and not word.startswith("-")
        ):
            units[-1] += " " + word
        else:
            units.append(word)
    lines, line = [], "$"
    for unit in units:
        if len(line) + 1 + len(unit) > WIDTH - 2:
            lines.append(line + " \\")
            line = "   "
        line += " " + unit
    print("\n".join([*lines, line]))


def part(number: int, title: str) -> None:
    print(f"\n[{number}/{PARTS}] {title}")


def verdict(text: str) -> None:
    """The part's conclusion: the last line it prints."""
    show(f"  => {text}")


def rel(path: Path | str) -> str:
    """`path` relative to the working directory when under it (shorter, and copy-pasteable)."""
    path = Path(path)
    try:
        return (
            os.path.relpath(path)
            if path.is_absolute() and path.resolve().is_relative_to(Path.cwd())
            else str(path)
        )
    except ValueError:
        return str(path)


def quiet(name: str, run: Callable[[], int]) -> tuple[int, str]:
    """Run a step with its output captured into `out/demo-logs/NAME.txt`; (exit code, text)."""
    buffer = io.StringIO()
    with contextlib.redirect_stdout(buffer), contextlib.redirect_stderr(buffer):
        code = run()
    OUT_LOGS.mkdir(parents=True, exist_ok=True)
    (OUT_LOGS / f"{name}.txt").write_text(buffer.getvalue(), encoding="utf-8")
    return code, buffer.getvalue()


def score_text(row: dict) -> str:
    """`TP/FP/FN, precision, recall` of one hazard row of a summary's ground truth."""
    p = "n/a" if row["precision"] is None else f"{row['precision']:.0%}"
    r = "n/a" if row["recall"] is None else f"{row['recall']:.0%}"
    return (
        f"{row['true_positives']}/{row['false_positives']}/{row['false_negatives']} "
        f"TP/FP/FN, P {p}, R {r}"
    )


def failed(what: str, code: int, log: str) -> int:
    show(f"  => {what} failed (exit {code}); its output: {OUT_LOGS / log}.txt")
    return code


def check_part() -> int:
    part(1, "Check the reference safety case")
    command("casewatch check", rel(CASE))
    code, text = quiet("1-check", lambda: cli(["check", rel(CASE)]))
    show("  " + (text.strip().splitlines()[-1] if text.strip() else ""))
    if code != 0:
        return failed("check", code, "1-check")
    verdict("the reference case passes check: no errors, no warnings")
    return 0


def reference_part() -> tuple[int, dict | None]:
    part(2, "Judge the bundled drives with the reference case")
    args = ["run", rel(CASE), rel(DATA), "--labels", "auto", "--jobs", "2", "-o", str(OUT)]
    command("casewatch", *args)
    code, _ = quiet("2-run", lambda: cli(args))
    if code not in (0, 1):
        return failed("the reference run", code, "2-run"), None
    summary = json.loads((OUT / "summary.json").read_text())
    print("  verdict      report")
    for log in summary["per_log"]:
        print(f"  {log['verdict']:<11}  {rel(Path(log['out_dir']) / 'report.html')}")
    formulas = summary["formulas"]
    spi = sum(f["episodes"] for f in formulas if f["kind"] == "spi")
    hazards = sum(f["episodes"] for f in formulas if f["kind"] == "hazard")
    verdicts = ", ".join(f"{n} {v}" for v, n in sorted(summary["verdicts"].items()))
    verdict(
        f"{summary['logs']} drives ({summary['hours']:.2f} h) judged, "
        f"{summary['logs_failed']} failed: {spi} SPI episodes, {hazards} hazard events; "
        f"root goal {verdicts}"
    )
    return 0, summary


def study_part(summary: dict) -> int:
    part(3, "The study's own hazard rules against the same labels")
    args = [
        "run",
        rel(STUDY),
        rel(DATA),
        "--labels",
        "auto",
        "--jobs",
        "2",
        "--format",
        "none",
        "-o",
        str(OUT_STUDY),
    ]
    command("casewatch", *args)
    code, _ = quiet("3-run-study", lambda: cli(args))
    if code not in (0, 1):
        return failed("the study run", code, "3-run-study")
    study = json.loads((OUT_STUDY / "summary.json").read_text())
    ours, theirs = summary.get("ground_truth"), study.get("ground_truth")
    if ours and theirs:
        print(f"  {'hazard':>6}  {'reference-case.yaml':<36}{'study-case.yaml'}")
        for a, b in zip(
            [*ours["per_hazard"], ours["overall"]],
            [*theirs["per_hazard"], theirs["overall"]],
            strict=True,
        ):
            print(f"  {a['hazard']:>6}  {score_text(a):<36}{score_text(b)}")
    diff = ["diff", str(OUT), str(OUT_STUDY), "-o", str(OUT_DIFF), "--fail-on", "hazard"]
    command("casewatch", *diff)
    code, _ = quiet("3-diff", lambda: cli(diff))
    if code not in (0, 1):
        return failed("the diff", code, "3-diff")
    report = json.loads((OUT_DIFF / "diff.json").read_text())
    kinds = ("lost", "new", "fixed", "new_detection")
    n = {
        k: sum(len(r[k]) for d in report["logs"] for r in d["nodes"] if r["kind"] == "hazard")
        for k in kinds
    }
    print(
        f"  hazard events: {n['lost']} lost detections, {n['new']} new false alarms, "
        f"{n['fixed']} fixed, {n['new_detection']} new detections"
    )
    print(f"  diff page: {rel(OUT_DIFF / 'diff.html')}")
    o, t = ours["overall"] if ours else None, theirs["overall"] if theirs else None
    if o and t:
        verdict(
            f"reference rules find {o['true_positives']} of "
            f"{o['true_positives'] + o['false_negatives']} labelled hazards, the study's "
            f"{t['true_positives']}; as a new version the study rules would be "
            f"{report['regressions']} regressions"
        )
    else:
        verdict(f"as a new version the study rules would be {report['regressions']} regressions")
    return 0


def nominal_rows(out_dir: Path) -> list[tuple[str, int, object, list]]:
    """Per drive of `out_dir`: (name, nominal ticks, the worst SPI's share, the shares above
    `NOMINAL_LIMIT`), as `python -m casewatch.nominal` computes them."""
    from casewatch.evaluator.ground_truth import read_labels
    from casewatch.evaluator.nominal import DEFAULT_MARGIN, nominal_shares
    from casewatch.nominal import run_folders, ssm_labels_path
    from casewatch.reports.render import load_result

    rows = []
    for folder in run_folders(out_dir):
        result = load_result(folder / "result.json")
        labels_path = Path(result.ground_truth.labels_path)
        labels = read_labels(labels_path)[0]
        ssm = ssm_labels_path(labels_path)
        if ssm is not None:
            labels += read_labels(ssm)[0]
        shares = [s for s in nominal_shares(result, labels, DEFAULT_MARGIN) if s.share is not None]
        worst = max(shares, key=lambda s: s.share)
        ticks = max((s.evaluated for s in shares), default=0)
        rows.append((folder.name, ticks, worst, [s for s in shares if s.share > NOMINAL_LIMIT]))
    return rows


def nominal_verdict(rows: list[tuple[str, int, object, list]]) -> str:
    over = [(name, s) for name, _, _, above in rows for s in above]
    if over:
        return f"{len(over)} SPI x drive shares above {NOMINAL_LIMIT:.0%}: " + ", ".join(
            f"{s.node_id} on {d} {s.share:.1%}" for d, s in over[:4]
        )
    return (
        f"every SPI stays within {NOMINAL_LIMIT:.0%} violated on the nominal driving of every drive"
    )


def nominal_part() -> int:
    """Each SPI's violated share of nominal driving per drive, one line per drive."""
    part(4, "False alarms on nominal driving (no label or SSM conflict within 3 s)")
    command("python -m casewatch.nominal", OUT)
    rows = nominal_rows(OUT)
    print(f"  {'drive':<26}{'ticks':>7}  worst SPI on nominal ticks")
    for name, ticks, worst, _ in rows:
        print(f"  {name:<26}{ticks:>7}  {worst.node_id} {worst.signal} {worst.share:.2%}")
    verdict(nominal_verdict(rows))
    return 0


def bag_part() -> int:
    drive = DATA / "highway-tailgating.jsonl.gz"
    part(5, "The drive as a ROS 2 bag with a real stack's timing (docs/bags.md)")
    command("python -m examples.sim.stack_timing", rel(drive), "--out", OUT_BAGS)
    from examples.sim.stack_timing import main as stack_timing  # the repository's examples

    code, text = quiet("5-bags", lambda: stack_timing([str(drive), "--out", str(OUT_BAGS)]))
    show(text.rstrip())
    if code != 0:
        return failed("the bag round trip", code, "5-bags")
    found = re.search(r"(\d+)/(\d+), (\d+)/(\d+)\s*$", text)
    if found and found[1] == found[2] and found[3] == found[4]:
        verdict(
            f"judged as an MCAP bag of Autoware messages, the drive gives the same {found[2]} "
            "episodes as the stream, both ways"
        )
    else:
        verdict("the bag and the stream disagree on some episodes (the last columns above)")
    return 0


def odd_part() -> int:
    """Contracts over the bundled ODD grid, and the domain they support (docs/odd.md)."""
    part(6, "Contracts over the ODD grid, and the domain they support (docs/odd.md)")
    run = [
        "run",
        rel(ODD_CASE),
        rel(ODD_GRID),
        "--jobs",
        "2",
        "--format",
        "none",
        "--quiet",
        "-o",
        str(OUT_ODD_RUNS),
    ]
    command("casewatch", *run)
    code, _ = quiet("6-run-odd", lambda: cli(run))
    if code not in (0, 1):
        return failed("the ODD grid run", code, "6-run-odd")
    odd = ["odd", str(OUT_ODD_RUNS), "--by", ODD_BY, "--bins", ODD_BINS, "-o", str(OUT_ODD)]
    command("casewatch", *odd)
    code, text = quiet("6-odd", lambda: cli(odd))
    if code not in (0, 1):
        return failed("casewatch odd", code, "6-odd")
    cells = json.loads((OUT_ODD / "odd.json").read_text())["cells"]
    accepted = [c for c in cells if c["accepted"]]
    # the study's table: a row per weather and intensity, a column per time of day
    lights = {c["conditions"]["environment.light"] for c in cells}
    columns = [li for li in ("day", "sunset", "night") if li in lights] + sorted(
        str(li) for li in lights - {"day", "sunset", "night"}
    )
    rows: dict[str, dict[str, str]] = {}
    for c in cells:
        weather, level, light = (c["conditions"][a] for a in ODD_BY.split(","))
        rows.setdefault(f"{weather} {level}", {})[light] = (
            "accepted" if c["accepted"] else "rejected"
        )
    print(("  " + " " * 14 + "".join(f"{col:<10}" for col in columns)).rstrip())
    for row, verdicts in rows.items():
        print(
            (f"  {row:<14}" + "".join(f"{verdicts.get(col, '-'):<10}" for col in columns)).rstrip()
        )
    agree = next(
        (
            line.strip()
            for line in text.splitlines()
            if line.startswith("Against the streams' known degradation")
        ),
        "",
    )
    print(f"  heatmap: {rel(OUT_ODD / 'odd.html')}")
    verdict(
        f"{len(accepted)} of {len(cells)} cells accepted"
        + (
            f"; {agree.split(': ', 1)[1]} with the degradation built into the drives"
            if ": " in agree
            else ""
        )
    )
    return code


def rules_part() -> int:
    """The traffic rules on the bundled SUMO rule drives, and the drivers compared."""
    part(7, "Traffic rules against SUMO's truth, and the drivers compared")
    run = [
        "run",
        rel(RULES_CASE),
        rel(RULES_DATA),
        "--labels",
        "auto",
        "--jobs",
        "2",
        "--format",
        "none",
        "--quiet",
        "-o",
        str(OUT_RULES),
    ]
    command("casewatch", *run)
    code, _ = quiet("7-run-rules", lambda: cli(run))
    if code not in (0, 1):
        return failed("the rules run", code, "7-run-rules")
    truth = json.loads((OUT_RULES / "summary.json").read_text())["ground_truth"]
    for row in [*truth["per_hazard"], truth["overall"]]:
        print(f"  {row['hazard']:>24}  {score_text(row)}")
    net = RULES_DATA / "rules.net.xml"
    compare = ["compare", str(OUT_RULES), "--net", rel(net), "-o", str(OUT_COMPARE)]
    command("casewatch", *compare)
    code, _ = quiet("7-compare", lambda: cli(compare))
    if code != 0:
        return failed("casewatch compare", code, "7-compare")
    checks = json.loads((OUT_COMPARE / "compare.json").read_text())["checks"]
    print(f"  comparison and violation map: {rel(OUT_COMPARE / 'compare.html')}")
    o = truth["overall"]
    road = checks.get("network") or {}
    verdict(
        f"rule events against SUMO's truth: {score_text(o)}; {checks['markers']} of "
        f"{checks['hazard_events']} events on the map, {road.get('off_road', 'n/a')} off "
        "the road"
    )
    return 0


def heldout_part() -> int:
    """Hazard and nominal figures on fresh generator seeds (`examples.sim.heldout`), when the
    simulator is installed; otherwise the command that gives them."""
    part(8, "The same on fresh generator seeds (held out from every threshold)")
    command("python -m examples.sim.heldout")
    if importlib.util.find_spec("libsumo") is None or importlib.util.find_spec("sumolib") is None:
        verdict(
            "skipped: held-out seeds need the simulator (pip install -e '.[sim]' or make "
            "data, then python -m examples.sim.heldout)"
        )
        return 0
    from examples.sim.heldout import SEEDS  # the optional extra, loaded late
    from examples.sim.heldout import main as run_heldout

    code, text = quiet("8-heldout", lambda: run_heldout([]))
    if code != 0:
        return failed("the held-out seeds", code, "8-heldout")
    seeds = []
    for line in text.splitlines():  # its hazard tables; the nominal tables are summed up below
        if line.startswith("Seed "):
            print(f"  seed {line.split()[1]}: hazard detection, reference case")
        elif re.match(r"\s+(CSn\d+|all)\s+\d+/\d+/\d+ TP/FP/FN", line):
            show(line)
            if line.split()[0] == "all":
                seeds.append(line.split(None, 1)[1].strip())
    rows = [row for seed in SEEDS for row in nominal_rows(Path("out") / "heldout" / f"run{seed}")]
    verdict(
        "held-out "
        + "; ".join(f"seed {seed}: {figures}" for seed, figures in zip(SEEDS, seeds, strict=False))
        + f"; {nominal_verdict(rows)}"
    )
    return 0


def main() -> int:
    code = check_part()
    if code:
        return code
    code, summary = reference_part()
    if summary is None:
        return code
    for step in (
        lambda: study_part(summary),
        nominal_part,
        bag_part,
        odd_part,
        rules_part,
        heldout_part,
    ):
        code = step()
        if code not in (0, 1):
            return code
    print(f"\ndemo: all {PARTS} parts ran; each command's full output is in {OUT_LOGS}/")
    return 0


if __name__ == "__main__":
    sys.exit(main())
