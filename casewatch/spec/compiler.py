"""Compiling a safety case's SPI and hazard bindings into monitored STL formulas.

- SPI `signal: s, threshold: ">= 0.6"` -> `s >= 0.6`;
- with `for: d` -> `once[0:d](s >= 0.6)`: negative (violated) only once the threshold failed at
  every sample of the last `d` seconds;
- SPI `stl: f` -> `f`, parsed, resolved and re-emitted canonically;
- hazard `when: c` -> `not (c)`: negative robustness means "hazard present".

Every check on the way (parse, signal names, bounds vs. sampling period, online causality) is a
`Finding` with a CW04x code pointing into the YAML, never an exception.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from typing import Any, Literal

from casewatch.safety_case.findings import Finding, has_errors
from casewatch.safety_case.model import Case, ContractBinding, HazardBinding, Mark, Node, SpiBinding
from casewatch.spec.ast import (
    Arith,
    Compare,
    Formula,
    Interval,
    Not,
    Num,
    Signal,
    Sum,
    Window,
    children,
    future_operators,
    walk,
)
from casewatch.spec.ast import Node as AstNode
from casewatch.spec.codes import formula_finding
from casewatch.spec.emit import interval_text, number_text, period_fraction, to_rtamt, to_text
from casewatch.spec.model import CompiledFormula, CompiledSpec, FormulaKind
from casewatch.spec.parser import FormulaError, parse_formula, parse_rtamt, yaml_position
from casewatch.spec.signals import resolve_signals
from casewatch.spec.timing import (
    bound_ticks,
    future_depth,
    intervals_of,
    past_form,
    past_horizon,
    sum_warmup,
)
from casewatch.spec.trace import traces_for
from casewatch.spec.vacancy import vacant_ticks

Mode = Literal["online", "offline"]

#: The longest time window, in samples (27.8 h at 0.1 s): rtamt keeps a window's samples in a
#: buffer, so `once[0:1e300s]` would overflow it and `historically[0:1000000h]` exhaust memory.
MAX_BOUND_TICKS = 1_000_000

#: The most samples one `sum` adds, counting those of the sums inside it: rtamt receives a sum
#: expanded, one `prev` and one `+` per sample (CW049).
MAX_SUM_SAMPLES = 100


@dataclass(frozen=True)
class _Source:
    """A formula to compile, with what is needed to point back into the YAML."""

    node: Node
    kind: FormulaKind
    text: str  # what the user wrote (or the text built from signal + threshold)
    formula: Formula | None  # set when built directly (signal + threshold), else parsed
    mark: Mark  # where column 1 of `text` sits in the YAML
    binding_mark: Mark  # the `spi:` / `hazard:` key
    merge_gap: float | None
    min_duration: float | None
    warn: float | None = None
    #: the text comes from the contract library: findings point at `mark` (the `use:`), not
    #: at a column of a text the YAML does not contain
    fixed: bool = False
    role: str = ""  # for a contract: "guarantee" or "assumption" (named in findings)


def _period_ok(case: Case) -> tuple[Fraction | None, list[Finding]]:
    period = case.monitor.period
    exact = period_fraction(period) if period > 0 else Fraction(0)
    if exact <= 0 or (exact * 10**9).denominator != 1:
        mark = case.monitor.mark
        return None, [
            formula_finding(
                "CW046",
                f"sampling period {period!r}s is not a positive whole number of nanoseconds",
                case.path,
                mark.line,
                mark.col,
                hint="write e.g. 'period: 0.1s' or 'period: 50ms'",
            )
        ]
    return exact, []


def _sources(case: Case) -> tuple[list[_Source], list[Finding]]:
    out: list[_Source] = []
    findings: list[Finding] = []
    for node in case.nodes.values():
        if node.spi is not None:
            src = _spi_source(case, node, node.spi)
            if isinstance(src, Finding):
                findings.append(src)
            else:
                out.append(src)
        if node.hazard is not None:
            out.append(_hazard_source(node, node.hazard))
        if node.contract is not None:
            out.extend(_contract_sources(node, node.contract))
    return out, findings


def _contract_sources(node: Node, contract: ContractBinding) -> list[_Source]:
    """A contract's guarantee (the monitored formula, kind `spi`: it is evidence) and, when it
    has one, its assumption (compiled alone, then attached to the guarantee)."""
    common: dict[str, Any] = {
        "node": node,
        "kind": "spi",
        "formula": None,
        "binding_mark": contract.mark,
        "merge_gap": contract.merge_gap,
        "min_duration": contract.min_duration,
    }
    out = [
        _Source(
            text=contract.guarantee,
            mark=contract.guarantee_mark,
            warn=contract.warn,
            fixed=contract.guarantee_from_library,
            role="guarantee",
            **common,
        )
    ]
    if contract.assume is not None:
        out.append(
            _Source(
                text=contract.assume,
                mark=contract.assume_mark,
                fixed=contract.assume_from_library,
                role="assumption",
                **common,
            )
        )
    return out


def _spi_source(case: Case, node: Node, spi: SpiBinding) -> _Source | Finding:
    common: dict[str, Any] = {
        "node": node,
        "kind": "spi",
        "mark": spi.formula_mark,
        "binding_mark": spi.mark,
        "merge_gap": spi.merge_gap,
        "min_duration": spi.min_duration,
        "warn": spi.warn,
    }
    if spi.stl is not None and spi.signal is None:
        return _Source(text=spi.stl, formula=None, **common)  # type: ignore[arg-type]
    if spi.signal is not None and spi.threshold is not None and spi.stl is None:
        threshold = spi.threshold
        text = f"{spi.signal} {threshold.op} {number_text(threshold.value)}"
        formula: Formula = Compare(threshold.op, Signal(spi.signal, col=1), Num(threshold.value))
        if spi.for_seconds is not None and spi.for_seconds > 0:
            interval = Interval(Fraction(0), Fraction(repr(float(spi.for_seconds))))
            formula = Window("once", interval, formula)
            text = f"once{interval_text(interval)} ({text})"
        return _Source(text=text, formula=formula, **common)  # type: ignore[arg-type]
    # The loader reports the shape (CW018); this keeps a hand-built case from compiling silently.
    return formula_finding(
        "CW044",
        f"node {node.id}: `spi` needs `signal` + `threshold` or `stl` (exactly one)",
        case.path,
        spi.mark.line,
        spi.mark.col,
        hint="e.g. spi: {signal: els, threshold: '>= 0.6'}",
    )


def _hazard_source(node: Node, hazard: HazardBinding) -> _Source:
    return _Source(
        node=node,
        kind="hazard",
        text=hazard.when,
        formula=None,
        mark=hazard.formula_mark,
        binding_mark=hazard.mark,
        merge_gap=hazard.merge_gap,
        min_duration=hazard.min_duration,
        warn=hazard.warn,
        fixed=hazard.from_library,
    )


def _bound_at(case: Case, src: _Source, col: int) -> tuple[int, int]:
    """Where a time bound's finding points: the bound in the formula text, or the binding for
    a `for:` duration (which has no text of its own)."""
    if src.formula is not None:
        return src.binding_mark.line, src.binding_mark.col
    return _at(case, src, col)


def _at(case: Case, src: _Source, col: int, line: int = 1) -> tuple[int, int]:
    if src.fixed:
        return src.mark.line, src.mark.col
    if src.formula is not None and col <= 0:
        return src.mark.line, src.mark.col
    return yaml_position(src.mark, line, max(col, 1))


def _check(
    case: Case, src: _Source, formula: Formula, period: Fraction, mode: Mode
) -> list[Finding]:
    findings: list[Finding] = []
    path = case.path
    known, unknown = resolve_signals(formula, case.monitor.channels, case.monitor.signals)
    if not known and not unknown:
        verdict = "holds" if src.kind == "hazard" else "is judged"
        findings.append(
            formula_finding(
                "CW047",
                f"the formula of node {src.node.id} reads no signal, so its verdict is the same "
                f"at every tick (a constant {src.kind} {verdict} or not regardless of the drive)",
                path,
                src.mark.line,
                src.mark.col,
                hint="compare a signal, e.g. 'els >= 0.6'; for a fixed verdict, use evidence "
                "outside the monitor (an Sn without spi:)",
            )
        )
    for miss in unknown:
        line, col = _at(case, src, miss.col)
        findings.append(
            formula_finding(
                "CW041",
                miss.message(src.node.id),
                path,
                line,
                col,
                hint=miss.hint(case.monitor.channels),
            )
        )
    for interval in intervals_of(formula):
        ticks = bound_ticks(interval.hi, period)
        if ticks is not None and ticks > MAX_BOUND_TICKS:
            line, col = _bound_at(case, src, interval.col)
            findings.append(
                formula_finding(
                    "CW048",
                    f"time bound {float(interval.hi):g}s in node {src.node.id} spans {ticks} "
                    f"samples; a window holds at most {MAX_BOUND_TICKS} "
                    f"({float(MAX_BOUND_TICKS * period) / 3600:g} h at {float(period):g}s)",
                    path,
                    line,
                    col,
                    hint="rtamt keeps every sample of a window in memory; judge over a shorter "
                    "window",
                )
            )
        for bound in (interval.lo, interval.hi):
            if bound_ticks(bound, period) is None:
                line, col = _bound_at(case, src, interval.col)
                findings.append(
                    formula_finding(
                        "CW043",
                        f"time bound {float(bound):g}s is not a whole number of sampling periods "
                        f"({float(period):g}s) in node {src.node.id}",
                        path,
                        line,
                        col,
                        hint="rtamt counts samples; use a multiple of monitor.period",
                    )
                )
    for node, samples in _long_sums(formula, period):
        line, col = _at(case, src, node.col)
        own = (node.interval.hi - node.interval.lo) / period + 1
        detail = f"{float(node.interval.lo):g}s to {float(node.interval.hi):g}s ago at " + (
            f"{float(period):g}s"
            if own == samples
            else f"{float(period):g}s is {own}, times {samples // int(own)} of the sum inside it"
        )
        findings.append(
            formula_finding(
                "CW049",
                f"`sum` in node {src.node.id} adds {samples} samples ({detail}); at most "
                f"{MAX_SUM_SAMPLES}",
                path,
                line,
                col,
                hint="rtamt receives a sum expanded, one `prev` per sample; sum over a shorter "
                f"window, e.g. 'sum[0:{float(period * (MAX_SUM_SAMPLES - 1)):g}s](...)'",
            )
        )
    for sub in walk(formula):
        if isinstance(sub, Arith) and sub.op == "/" and sub.right == Num(0.0):
            findings.append(
                formula_finding(
                    "CW045",
                    f"division by the constant 0 in node {src.node.id}",
                    path,
                    src.mark.line,
                    src.mark.col,
                )
            )
    if mode == "online" and not any(f.code == "CW043" for f in findings):
        findings.extend(_causality(case, src, formula, period))
    if not any(f.code in ("CW043", "CW048") for f in findings):
        findings.extend(_vacancy(case, src, formula, period))
    return findings


def _vacancy(case: Case, src: _Source, formula: Formula, period: Fraction) -> list[Finding]:
    """A window that reads no sample yet at the start of a stream (and after every data gap)
    fixes the verdict there: `once[1s:2s] p` is violated for the first second whatever the
    data (spec.vacancy). Samples a `sum` warm-up already reports as no data do not count."""
    monitored = Not(formula) if src.kind == "hazard" else formula
    warmup = sum_warmup(monitored, period)
    ticks = [k for k in vacant_ticks(monitored, period) if k >= warmup]
    if not ticks:
        return []
    shown = f"{float(ticks[-1] * period + period):g}s"
    what = "reads as present" if src.kind == "hazard" else "is violated"
    return [
        formula_finding(
            "CW050",
            f"the {src.kind} of node {src.node.id} {what} at the first {len(ticks)} sample(s) "
            f"({shown}) of every stream and after every data gap, whatever the data: a window "
            "there reads no sample yet (robustness -inf)",
            case.path,
            src.mark.line,
            src.mark.col,
            hint="a window [a:b] with a > 0 holds no sample during the first a seconds "
            "(`once` and `since` are violated, `historically` holds, `prev` holds at the first "
            "sample); start the window at 0, e.g. 'once[0s:2s] (...)', or accept these ticks "
            "as reported",
        )
    ]


def _sum_samples(node: AstNode, period: Fraction) -> int | None:
    """How many samples the outermost sums under `node` add at most, counting the samples of
    nested sums (None when a bound is not whole periods: CW043 reports that)."""
    if isinstance(node, Sum):
        lo, hi = bound_ticks(node.interval.lo, period), bound_ticks(node.interval.hi, period)
        inner = _sum_samples(node.operand, period)
        if lo is None or hi is None or inner is None:
            return None
        return (hi - lo + 1) * max(inner, 1)
    counts = [_sum_samples(child, period) for child in children(node)]
    if None in counts:
        return None
    return max((c for c in counts if c is not None), default=0)


def _long_sums(node: AstNode, period: Fraction) -> list[tuple[Sum, int]]:
    """The outermost sums adding more than MAX_SUM_SAMPLES samples, with their count."""
    if isinstance(node, Sum):
        samples = _sum_samples(node, period)
        if samples is not None and samples > MAX_SUM_SAMPLES:
            return [(node, samples)]
    return [found for child in children(node) for found in _long_sums(child, period)]


def _causality(case: Case, src: _Source, formula: Formula, period: Fraction) -> list[Finding]:
    """Online monitoring is causal: a verdict at `t` may only read samples up to `t`."""
    future = future_operators(formula)
    if not future:
        return []
    found = past_form(formula, period)
    if found is not None:
        past, ticks = found
        hint = (
            f"the same judgement, delivered {float(ticks * period):g}s late, is the past-time "
            f"formula: {to_text(past)}"
        )
    else:
        hint = "rewrite 'a until[x:y] b' with 'since' over past samples"
    first = future[0]
    line, col = _at(case, src, getattr(first, "col", 0))
    names = sorted({type(n).__name__.lower() if not hasattr(n, "op") else n.op for n in future})
    return [
        formula_finding(
            "CW042",
            f"future operator ({', '.join(names)}) in node {src.node.id}: online monitoring "
            "judges each sample when it arrives and cannot look ahead",
            case.path,
            line,
            col,
            hint=hint,
        )
    ]


def _compile_one(
    case: Case, src: _Source, period: Fraction, mode: Mode
) -> tuple[CompiledFormula | None, list[Finding]]:
    formula = src.formula
    if formula is None:
        try:
            formula = parse_formula(src.text)
        except FormulaError as err:
            line, col = _at(case, src, err.col, err.line)
            what = "does not parse" if err.code == "CW040" else "is nested too deeply"
            return None, [
                formula_finding(
                    err.code,
                    f"{src.role or 'formula'} of node {src.node.id} {what}: {err.message}",
                    case.path,
                    line,
                    col,
                    hint=_caret_hint(src.text, err.col),
                )
            ]
    findings = _check(case, src, formula, period, mode)
    if has_errors(findings):
        return None, findings
    monitored = Not(formula) if src.kind == "hazard" else formula
    rtamt_text = to_rtamt(monitored, period)
    try:
        parse_rtamt(rtamt_text, float(period))  # nesting as rtamt receives it (CW051)
    except FormulaError as err:  # CW051: too deep for rtamt as it receives the formula
        return None, [
            formula_finding(
                err.code,
                f"{src.role or 'formula'} of node {src.node.id} is nested too deeply for rtamt: "
                f"{err.message}",
                case.path,
                src.mark.line,
                src.mark.col,
                hint="a `sum` reaches this near 75 samples (sum[0:7.4s] at 0.1 s); sum over a "
                "shorter window",
            )
        ]
    known, _ = resolve_signals(formula, case.monitor.channels, case.monitor.signals)
    spi = src.node.spi if src.kind == "spi" else None
    compiled = CompiledFormula(
        id=src.node.id,
        node_id=src.node.id,
        node_text=src.node.text,
        kind=src.kind,
        source=src.text,
        rtamt=rtamt_text,
        signals=known,
        signal=spi.signal if spi and spi.stl is None else None,
        threshold=(
            f"{spi.threshold.op} {number_text(spi.threshold.value)}"
            if spi and spi.threshold and spi.stl is None
            else None
        ),
        merge_gap=src.merge_gap if src.merge_gap is not None else case.monitor.merge_gap,
        min_duration=(
            src.min_duration if src.min_duration is not None else case.monitor.min_duration
        ),
        warn=src.warn or 0.0,
        horizon=float(past_horizon(monitored, period) * period),
        future_horizon=float(future_depth(monitored, period) * period),
        warmup_ticks=sum_warmup(monitored, period),
        persist_ticks=_persist_ticks(spi, period),
        rule=src.node.hazard.use if src.kind == "hazard" and src.node.hazard else None,
    )
    return compiled, findings


def _caret_hint(text: str, col: int, width: int = 160) -> str:
    """The formula with a caret under `col`; a long formula is cut to `width` characters
    around the caret, so one finding never prints kilobytes."""
    start = max(0, min(col - 1 - width // 2, len(text) - width))
    shown = text[start : start + width]
    left = "..." if start > 0 else ""
    right = "..." if start + width < len(text) else ""
    return f"{left}{shown}{right}\n{' ' * (len(left) + col - 1 - start)}^"


def _persist_ticks(spi: SpiBinding | None, period: Fraction) -> int:
    """An SPI's `for:` in sampling periods (0 without one); CW043 has checked it is whole."""
    if spi is None or spi.stl is not None or not spi.for_seconds or spi.for_seconds <= 0:
        return 0
    return round(Fraction(repr(float(spi.for_seconds))) / period)


def compile_case(case: Case, mode: Mode = "online") -> tuple[CompiledSpec | None, list[Finding]]:
    """Compile every SPI and hazard of `case`. Returns (None, findings) when any is an error."""
    period, findings = _period_ok(case)
    if period is None:
        return None, findings
    sources, shape_findings = _sources(case)
    findings.extend(shape_findings)
    formulas: list[CompiledFormula] = []
    for src in sources:
        compiled, found = _compile_one(case, src, period, mode)
        findings.extend(found)
        if compiled is None:
            continue
        if src.role == "assumption":  # follows its guarantee (_contract_sources)
            if formulas and formulas[-1].node_id == src.node.id:
                formulas[-1] = _with_assumption(formulas[-1], compiled, src.node)
            continue
        if src.role == "guarantee" and src.node.contract is not None:
            compiled = compiled.model_copy(update={"contract_use": src.node.contract.use})
        formulas.append(compiled)
    if has_errors(findings):
        return None, findings
    signals: dict[str, list[str]] = {name: [] for name in case.monitor.signals}
    for f in formulas:
        for name in sorted({n for g in f.monitored() for n in g.signals}):
            signals.setdefault(name, []).append(f.id)
    spec = CompiledSpec(
        case_path=case.path,
        case_digest=case.digest,
        module=case.module.name,
        root_id=_root_id(case),
        channels=list(case.monitor.channels),
        period=case.monitor.period,
        formulas=formulas,
        traces={f.node_id: traces_for(case, f.node_id) for f in formulas},
        signals={name: sorted(ids) for name, ids in sorted(signals.items())},
    )
    return spec, findings


def _with_assumption(
    guarantee: CompiledFormula, assumption: CompiledFormula, node: Node
) -> CompiledFormula:
    """The contract's monitored formula: its guarantee, carrying its assumption."""
    own = assumption.model_copy(update={"id": f"{guarantee.id}.assume", "warn": 0.0})
    use = node.contract.use if node.contract is not None else None
    return guarantee.model_copy(update={"assumption": own, "contract_use": use})


def _root_id(case: Case) -> str:
    """The root goal, or "" for a case without one (structural check CW035 reports that)."""
    try:
        return case.root_id()
    except IndexError:
        return ""


def check_formulas(case: Case, mode: Mode = "online") -> list[Finding]:
    """Only the findings of `compile_case` (what `casewatch check` adds for formulas)."""
    return compile_case(case, mode)[1]
