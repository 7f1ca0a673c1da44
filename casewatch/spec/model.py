"""The compiled specification: the value `spec.compile_case` returns and the evaluator runs.

Contract between `spec/` and `evaluator/`. Every formula is already canonical rtamt text that
rtamt 0.4.10 evaluates correctly (see `docs/formulas.md` for the fences), and keeps the id of the
GSN node it came from so every verdict can be traced.
"""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict

FormulaKind = Literal["spi", "hazard"]


class TraceStep(BaseModel):
    model_config = ConfigDict(frozen=True)
    id: str
    text: str


class CompiledFormula(BaseModel):
    """One monitored formula."""

    model_config = ConfigDict(frozen=True)
    id: str  # formula id, e.g. "Sn1" (one formula per node today)
    node_id: str
    node_text: str
    kind: FormulaKind  # spi: robustness < 0 is a violation; hazard: robustness < 0 = hazard present
    source: str  # what the user wrote (`s >= 0.6`, the raw stl, or the hazard's `when`)
    rtamt: str  # canonical, fully parenthesised rtamt text of the monitored formula
    signals: list[str]  # input signal names, sorted
    signal: str | None = None  # the SPI's signal, when bound by signal + threshold
    threshold: str | None = None  # e.g. ">= 0.6", when bound by signal + threshold
    merge_gap: float  # seconds, resolved against the case default
    min_duration: float  # seconds, resolved against the case default
    # near-miss margin (robustness units): 0 <= robustness < warn forms near_miss episodes;
    # 0 = none
    warn: float = 0.0
    horizon: float = 0.0  # seconds of past the formula looks at (for warm-up accounting)
    # seconds the formula looks ahead (0 online; offline, a verdict at t needs data to t + this)
    future_horizon: float = 0.0
    warmup_ticks: int = 0  # samples after a reset whose verdict is undefined (`sum` incomplete)
    #: an SPI's `for:` in samples: after a (re)start a violation counts only once it has
    #: lasted `for:` of data, so a violated verdict at the first `persist_ticks` samples
    #: is no data (the window is shorter than written), never a violation (docs/formulas.md)
    persist_ticks: int = 0
    #: a contract's assumption (`contract:` on a solution), judged by its own monitor: the
    #: contract is violated only where it holds and this formula (the guarantee) fails, and is
    #: "outside assumption" where it fails (docs/contracts.md). Its id is `<id>.assume`.
    assumption: CompiledFormula | None = None
    contract_use: str | None = None  # the library contract instantiated (`use:`), if any
    rule: str | None = None  # the traffic rule a hazard instantiates (`hazard: {use: ...}`)

    def monitored(self) -> list[CompiledFormula]:
        """This formula and its assumption: every formula a monitor judges for it."""
        return [self] if self.assumption is None else [self, self.assumption]


CompiledFormula.model_rebuild()


class CompiledSpec(BaseModel):
    """Everything the evaluator needs, plus traces for the report."""

    model_config = ConfigDict(frozen=True)
    case_path: str
    case_digest: str
    module: str
    root_id: str
    channels: list[str]
    period: float
    formulas: list[CompiledFormula]
    # node id -> every path from that node up to the root, each a list of steps (node first).
    traces: dict[str, list[list[TraceStep]]]
    # signal name -> ids of formulas that use it
    signals: dict[str, list[str]]
