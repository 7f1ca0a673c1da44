"""pydantic models of the raw YAML shapes, and the parsers for thresholds and durations.

These validate what the user wrote, key by key, before `loader.py` turns it into the contract
models of `model.py`. Domain errors are raised as `PydanticCustomError` with our own error types
(`malformed_threshold`, `malformed_duration`, ...) so the loader can map each one to its stable
check code and to the line of the offending key, instead of showing a pydantic dump.
"""

from __future__ import annotations

import math
import re
from typing import Annotated, Literal

import annotated_types
from pydantic import (
    AfterValidator,
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    StrictBool,
    StrictInt,
    StrictStr,
    ValidationInfo,
    field_validator,
    model_validator,
)
from pydantic_core import PydanticCustomError

from casewatch.safety_case.model import ChannelCoverage, MetricParams, ScoringParams, Threshold
from casewatch.safety_case.signals import SEP, builtin_signals

# [0-9], not \d: \d also matches digits of other scripts, which float() reads (U+0661 -> 1.0)
_NUMBER = r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?"
_THRESHOLD_RE = re.compile(rf"^\s*(>=|<=|>|<)\s*({_NUMBER})\s*$")
_DURATION_RE = re.compile(rf"^\s*({_NUMBER})\s*(ms|s|min|h)?\s*$")
_UNIT_SECONDS = {"ms": 0.001, "s": 1.0, "min": 60.0, "h": 3600.0, None: 1.0}
#: A channel name: an ASCII letter, then letters, digits and `_`; `channel_name_problem` also
#: refuses `__` and a trailing `_`, so `metric__a__b` always splits back into its parts.
CHANNEL_RE = re.compile(r"[A-Za-z][A-Za-z0-9_]*")
DECLARED_SIGNAL_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


def parse_threshold(raw: object) -> Threshold:
    """`">= 0.6"` -> Threshold(op=">=", value=0.6); anything else raises `malformed_threshold`."""
    if isinstance(raw, str):
        match = _THRESHOLD_RE.match(raw)
        if match:
            value = float(match.group(2))
            if math.isfinite(value):
                return Threshold(op=match.group(1), value=value)  # type: ignore[arg-type]
        hint = ""
        if re.match(r"^\s*(=>|=<|==|=|!=)", raw):
            hint = "; comparisons are >=, <=, > or <"
        elif "_" in raw:
            hint = (
                "; write the number without '_' digit separators (YAML 1.1 and Python read "
                "'1_0' as 10, JSON and YAML 1.2 do not)"
            )
        raise PydanticCustomError(
            "malformed_threshold",
            "expected an operator and a number such as '>= 0.6' or '< 0.05', got {got}{hint}",
            {"got": repr(raw), "hint": hint},
        )
    raise PydanticCustomError(
        "malformed_threshold",
        'expected a quoted operator and number such as ">= 0.6", got {got}',
        {"got": _describe(raw)},
    )


#: Longest duration a case may write (period, `for`, merge_gap, min_duration), seconds.
MAX_DURATION = 86400.0


def parse_duration(raw: object) -> float:
    """`0.5s`, `300ms`, `1min`, `2h` or a plain number of seconds -> seconds (>= 0)."""
    seconds: float | None = None
    if isinstance(raw, bool):
        seconds = None
    elif isinstance(raw, int | float):
        # float() of a 401-digit int raises OverflowError; any such number is "too long"
        seconds = float(raw) if abs(raw) < 1e300 else 2.0 * MAX_DURATION
    elif isinstance(raw, str):
        match = _DURATION_RE.match(raw)
        if match:
            seconds = float(match.group(1)) * _UNIT_SECONDS[match.group(2)]
    if seconds is None or not math.isfinite(seconds):
        raise PydanticCustomError(
            "malformed_duration",
            "expected a duration such as 0.5s, 300ms, 1min or a number of seconds, got {got}",
            {"got": _describe(raw)},
        )
    if seconds < 0:
        raise PydanticCustomError(
            "malformed_duration", "a duration cannot be negative, got {got}", {"got": _short(raw)}
        )
    if seconds > MAX_DURATION:
        # a `min_duration: 1e300s` would drop every episode and let any run pass
        raise PydanticCustomError(
            "malformed_duration",
            "a duration longer than a day ({max:g} s) is no monitoring window, got {got}",
            {"got": _short(raw), "max": MAX_DURATION},
        )
    return seconds


def _optional_duration(raw: object) -> float | None:
    return None if raw is None else parse_duration(raw)


def _positive_duration(raw: object) -> float:
    seconds = parse_duration(raw)
    if seconds <= 0:
        raise PydanticCustomError(
            "malformed_duration",
            "the period must be longer than zero, got {got}",
            {"got": repr(raw)},
        )
    return seconds


def _optional_threshold(raw: object) -> Threshold | None:
    return None if raw is None else parse_threshold(raw)


def _as_list(raw: object) -> object:
    """`supportedBy: G2` and `supportedBy: [G2]` mean the same; null means none."""
    if raw is None:
        return []
    if isinstance(raw, str):
        return [raw]
    return raw


def _short(value: object, limit: int = 40) -> str:
    """`repr(value)`, cut to `limit` characters (a 401-digit number is not echoed whole)."""
    try:
        text = repr(value)
    except ValueError:  # an int beyond Python's digit limit for conversion to text
        return "a number of more than 4300 digits"
    return text if len(text) <= limit else f"{text[: limit - 3]}... ({len(text)} characters)"


def _describe(value: object) -> str:
    if value is None:
        return "nothing (null)"
    if isinstance(value, bool):
        return f"the boolean {str(value).lower()}"
    if isinstance(value, int | float):
        return f"the number {_short(value)}"
    if isinstance(value, str):
        return f"the text {_short(value)}"
    if isinstance(value, list):
        return "a list"
    if isinstance(value, dict):
        return "a mapping"
    return type(value).__name__


describe_value = _describe

#: Largest warning margin a case may write (robustness units: the formula's own).
MAX_MARGIN = 1e6


def _optional_margin(raw: object) -> float | None:
    """`warn:` (a near-miss margin in the formula's robustness units): a finite number > 0."""
    if raw is None:
        return None
    value = float(raw) if isinstance(raw, int | float) and not isinstance(raw, bool) else None
    if value is None or not math.isfinite(value) or not 0 < value <= MAX_MARGIN:
        raise PydanticCustomError(
            "malformed_margin",
            "expected a warning margin: a number above 0 and at most 1e6, in the units of the "
            "formula's robustness (e.g. 0.1 for `els >= 0.6`), got {got}",
            {"got": _describe(raw)},
        )
    return value


Duration = Annotated[float, BeforeValidator(parse_duration)]
OptionalDuration = Annotated[float | None, BeforeValidator(_optional_duration)]
PositiveDuration = Annotated[float, BeforeValidator(_positive_duration)]
OptionalThreshold = Annotated[Threshold | None, BeforeValidator(_optional_threshold)]
OptionalMargin = Annotated[float | None, BeforeValidator(_optional_margin)]
IdList = Annotated[list[StrictStr], BeforeValidator(_as_list)]
Text = Annotated[StrictStr, Field(min_length=1)]


class RawSpi(BaseModel):
    """`spi:` as written: `signal` + `threshold` (+ `for`) XOR `stl`."""

    model_config = ConfigDict(extra="forbid")
    signal: Text | None = None
    threshold: OptionalThreshold = None
    for_: OptionalDuration = Field(None, alias="for")
    stl: Text | None = None
    merge_gap: OptionalDuration = None
    min_duration: OptionalDuration = None
    warn: OptionalMargin = None

    @model_validator(mode="after")
    def _one_binding(self) -> RawSpi:
        bound = self.signal is not None or self.threshold is not None
        if self.stl is not None and bound:
            raise PydanticCustomError(
                "spi_shape", "use either `signal` + `threshold` or `stl`, not both"
            )
        if self.stl is not None and self.for_ is not None:
            raise PydanticCustomError(
                "spi_shape",
                "`for` applies to `signal` + `threshold`; write the persistence into "
                "the `stl` formula instead",
            )
        if self.stl is None and (self.signal is None or self.threshold is None):
            missing = "threshold" if self.signal is not None else "signal"
            if not bound:
                raise PydanticCustomError(
                    "spi_shape", "an SPI needs `signal` + `threshold` or a raw `stl` formula"
                )
            raise PydanticCustomError(
                "spi_shape",
                "`signal` and `threshold` go together; `{missing}` is missing",
                {"missing": missing},
            )
        return self


class RawHazard(BaseModel):
    """`hazard:` as written: a `when` condition, or a traffic rule from the library (`use`,
    with `params`)."""

    model_config = ConfigDict(extra="forbid")
    when: Text | None = None
    use: Text | None = None
    params: dict[StrictStr, StrictStr | StrictInt | float] = {}
    merge_gap: OptionalDuration = None
    min_duration: OptionalDuration = None
    warn: OptionalMargin = None

    @model_validator(mode="after")
    def _shape(self) -> RawHazard:
        if self.use is None and self.params:
            raise PydanticCustomError(
                "spi_shape", "`params` set the parameters of a library rule: add `use`"
            )
        if (self.when is None) == (self.use is None):
            raise PydanticCustomError(
                "spi_shape",
                "a hazard needs `when` (a condition) or `use` (a traffic rule of "
                "the library, docs/traffic-rules.md), not both",
            )
        return self


class RawContract(BaseModel):
    """`contract:` as written: a library contract (`use` + `params`) or an `assume` /
    `guarantee` pair (with `use`, either one replaces the library's)."""

    model_config = ConfigDict(extra="forbid")
    use: Text | None = None
    params: dict[StrictStr, StrictStr | StrictInt | float] = {}
    assume: Text | None = None
    guarantee: Text | None = None
    merge_gap: OptionalDuration = None
    min_duration: OptionalDuration = None
    warn: OptionalMargin = None

    @model_validator(mode="after")
    def _shape(self) -> RawContract:
        if self.use is None and self.params:
            raise PydanticCustomError(
                "spi_shape", "`params` set the parameters of a library contract: add `use`"
            )
        if self.use is None and self.guarantee is None:
            raise PydanticCustomError(
                "spi_shape",
                "a contract needs `guarantee` (and optionally `assume`), or `use` "
                "naming a library contract (docs/contracts.md)",
            )
        return self


def _horizontal_index(raw: object) -> object:
    """gsn2x's `horizontalIndex`: `{relative: N}` (any whole number) or `{absolute: N}` (N >= 0,
    or `last`), kept as written. gsn2x 2's plain number (negative: relative) is read too and kept
    in today's form, which `export-gsn` writes."""
    if raw is None:
        return None
    if isinstance(raw, int) and not isinstance(raw, bool):
        return {"relative": raw} if raw < 0 else {"absolute": raw}
    if isinstance(raw, dict) and len(raw) == 1:
        ((key, value),) = raw.items()
        whole = isinstance(value, int) and not isinstance(value, bool)
        if key == "relative" and whole:
            return raw
        if key == "absolute" and (value == "last" or (whole and int(value) >= 0)):
            return raw
    raise PydanticCustomError(
        "horizontal_index",
        "expected gsn2x's `relative: N` or `absolute: N` (N >= 0, or last), got {got}",
        {"got": _describe(raw)},
    )


def _acp(raw: object) -> object:
    """gsn2x's assurance claim points: a name -> one element id or a list of ids."""
    if raw is None:
        return None
    if isinstance(raw, dict) and all(
        isinstance(v, str) or (isinstance(v, list) and all(isinstance(i, str) for i in v))
        for v in raw.values()
    ):
        return raw
    raise PydanticCustomError(
        "acp",
        "expected gsn2x's assurance claim points, each a name and an element id or a list of "
        "ids (`acp: {ACP1: Sn1}`), got {got}",
        {"got": _describe(raw)},
    )


def _ids_as_written(raw: object) -> object:
    """One node id or a list of them (gsn2x's `defeatedRelation`), kept as written."""
    if raw is None or isinstance(raw, str):
        return raw
    if isinstance(raw, list) and all(isinstance(i, str) for i in raw):
        return raw
    raise PydanticCustomError(
        "ids", "expected a node id or a list of node ids, got {got}", {"got": _describe(raw)}
    )


HorizontalIndex = Annotated[object, AfterValidator(_horizontal_index)]
IdsAsWritten = Annotated[object, AfterValidator(_ids_as_written)]
Acp = Annotated[object, AfterValidator(_acp)]
#: gsn2x's `nodeType` values
NodeTypeName = Literal[
    "Goal",
    "Strategy",
    "Solution",
    "Context",
    "Assumption",
    "Justification",
    "CounterGoal",
    "CounterSolution",
]


class RawNode(BaseModel):
    """One node as written (keys in gsn2x spelling)."""

    model_config = ConfigDict(extra="forbid")
    text: Text
    supportedBy: IdList = []  # gsn2x spelling
    inContextOf: IdList = []  # gsn2x spelling
    challenges: IdList = []
    undeveloped: StrictBool = False
    url: StrictStr | None = None
    spi: RawSpi | None = None
    hazard: RawHazard | None = None
    contract: RawContract | None = None
    odd: object = None  # a context's ODD: a file path or a mapping (safety_case.odd)
    # gsn2x presentation attributes: kept as written for export-gsn, otherwise not read
    classes: StrictStr | list[StrictStr] | None = None
    level: StrictStr | None = None
    horizontalIndex: HorizontalIndex = None
    rankIncrement: Annotated[StrictInt, Field(ge=0)] | None = None
    nodeType: NodeTypeName | None = None
    charWrap: Annotated[StrictInt, Field(ge=0)] | None = None
    acp: Acp = None
    additionalInformation: object = None
    defeated: StrictBool | None = None  # gsn2x dialectic extension
    defeatedRelation: IdsAsWritten = None

    @field_validator("spi", "hazard", "contract", mode="before")
    @classmethod
    def _binding_written(cls, value: object, info: ValidationInfo) -> object:
        """`spi:` (or `hazard:`, `contract:`) written with nothing after it would leave the
        node silently unmonitored: a binding must say what to judge (CW018)."""
        if value is None:
            example = {
                "spi": "spi: {signal: els, threshold: '>= 0.6'}",
                "hazard": "hazard: {when: 'lead_thw < 1.0'}",
                "contract": "contract: {use: lane_keeping}",
            }[info.field_name or "spi"]
            raise PydanticCustomError(
                "spi_shape",
                "`{binding}:` is empty (null), so nothing would be monitored; write the binding "
                "(e.g. {example}) or remove the key (a node without one is evidence outside "
                "the monitor)",
                {"binding": info.field_name, "example": example},
            )
        return value


class RawGsn2xNode(RawNode):
    """A node of a pure argument (a file without `monitor`), read by gsn2x's rules: `text` is
    optional there, as in gsn2x."""

    text: StrictStr = ""


#: gsn2x's `nodeType` names -> our types (an id without a type prefix needs one).
GSN_NODE_TYPES: dict[str, str] = {
    "Goal": "G",
    "Strategy": "S",
    "Solution": "Sn",
    "Context": "C",
    "Assumption": "A",
    "Justification": "J",
    "CounterGoal": "CG",
    "CounterSolution": "CSn",
}

#: The gsn2x attributes of a node kept as written (`Node.gsn`).
GSN_NODE_ATTRIBUTES: tuple[str, ...] = (
    "classes",
    "level",
    "horizontalIndex",
    "rankIncrement",
    "nodeType",
    "charWrap",
    "acp",
    "additionalInformation",
    "defeated",
    "defeatedRelation",
)


class RawExtends(BaseModel):
    """gsn2x's `extends: [{module: template, develops: {G1: [G2]}}]`: this module develops
    undeveloped elements of another (G1 of template is supported by G2 of this one)."""

    model_config = ConfigDict(extra="forbid")
    module: Text
    develops: dict[StrictStr, IdList]


class RawModule(BaseModel):
    model_config = ConfigDict(extra="forbid")
    name: Text
    brief: StrictStr = ""
    uses: list[StrictStr] = []  # gsn2x: module files this one uses, relative to it
    extends: list[RawExtends] | None = None  # gsn2x: develop another module's elements
    additionalInformation: object = None
    horizontalIndex: HorizontalIndex = None
    rankIncrement: Annotated[StrictInt, Field(ge=0)] | None = None
    charWrap: Annotated[StrictInt, Field(ge=0)] | None = None
    stylesheets: list[StrictStr] | None = None


#: The gsn2x attributes of a module kept as written (`Module.gsn`).
GSN_MODULE_ATTRIBUTES: tuple[str, ...] = (
    "extends",
    "additionalInformation",
    "horizontalIndex",
    "rankIncrement",
    "charWrap",
    "stylesheets",
)


def channel_name_problem(name: str) -> str | None:
    """Why `name` cannot be a channel name, or None when it can.

    Signal names join metric and channels with `__` (`ss__chA__Apollo7`), so a channel must not
    contain `__` nor end in `_` (`a_` + `b` would read `x__a___b`, which splits two ways)."""
    if not CHANNEL_RE.fullmatch(name):
        return "must start with a letter and contain only letters, digits and '_'"
    if SEP in name:
        return "must not contain '__' (it separates the parts of a signal name)"
    if name.endswith("_"):
        return "must not end in '_' (signal names such as 'els__a__b' would become ambiguous)"
    return None


def _check_channels(channels: list[str]) -> list[str]:
    seen: set[str] = set()
    for index, name in enumerate(channels):
        problem = channel_name_problem(name)
        if problem is not None:
            raise PydanticCustomError(
                "channels",
                "channel name '{name}' {problem}; e.g. lav, chA, Apollo7, front_cam",
                {"name": name, "index": index, "problem": problem},
            )
        if name in seen:
            raise PydanticCustomError(
                "channels", "channel '{name}' is listed twice", {"name": name, "index": index}
            )
        seen.add(name)
    if len(channels) < 2:
        raise PydanticCustomError(
            "channels",
            "a cross-channel monitor needs at least two channels, got {count}",
            {"count": len(channels)},
        )
    return channels


def _signals_to_dict(raw: object) -> object:
    """`signals: [speed, lane_offset]` is shorthand for a mapping with empty descriptions."""
    if raw is None:
        return {}
    if isinstance(raw, list):
        out: dict[str, object] = {}
        for index, item in enumerate(raw):
            if not isinstance(item, str):
                raise PydanticCustomError(
                    "declared_signal",
                    "a declared signal name must be text, got {got}",
                    {"got": _describe(item), "index": index},
                )
            out[item] = ""
        return out
    if isinstance(raw, dict):
        return {k: ("" if v is None else v) for k, v in raw.items()}
    return raw


def _metric_numbers(raw: object) -> object:
    """Metric parameters are numbers: pydantic alone would read `true` as 1 and the text
    "inf" as infinity. Text that is a plain number stays allowed, because YAML 1.1 reads
    `1e-3` (no dot) as text."""
    if isinstance(raw, dict):
        for key, value in raw.items():
            plain_text = isinstance(value, str) and re.fullmatch(_NUMBER, value.strip())
            if isinstance(value, bool) or not (isinstance(value, int | float) or plain_text):
                raise PydanticCustomError(
                    "float_type",
                    "expected a number",
                    {"key": key, "got": _describe(value)},
                )
    return raw


def bounds_text(name: str) -> str:
    """The declared range of metric parameter `name` as documented: `(0, 60]`, `[2, 10000]`.

    Empty ends (`(0, ?`) mean the parameter lacks a bound, which a test refuses."""
    field = MetricParams.model_fields[name]
    low, high = "?", "?"
    for rule in field.metadata:
        if isinstance(rule, annotated_types.Gt):
            low = f"({rule.gt:g}"
        elif isinstance(rule, annotated_types.Ge):
            low = f"[{rule.ge:g}"
        elif isinstance(rule, annotated_types.Lt):
            high = f"{rule.lt:g})"
        elif isinstance(rule, annotated_types.Le):
            high = f"{rule.le:g}]"
    return f"{low}, {high}"


def _check_scoring(scoring: ScoringParams) -> ScoringParams:
    """Overrides name rules of the traffic-rules library, with sane values."""
    from casewatch.safety_case.contracts import RULES, library

    rules = library(RULES)
    names = {
        f"{r}.{party}" if by else r
        for r, t in rules.items()
        for by in [t.data.get("penalty_by_party")]
        for party in (by or [None])
    }
    for table, what in ((scoring.penalties, "penalties"), (scoring.carla, "carla")):
        for name, value in table.items():
            if name not in names:
                raise PydanticCustomError(
                    "unknown_rule",
                    "scoring.{what}: no rule {name} (the rules: {known})",
                    {"what": what, "name": repr(name), "known": ", ".join(sorted(names))},
                )
            values = value if isinstance(value, tuple) else (value,)
            if any(not math.isfinite(v) or v < 0 for v in values) or (
                what == "carla" and not (isinstance(value, float | int) and 0 < value <= 1)
            ):
                raise PydanticCustomError(
                    "unknown_rule",
                    "scoring.{what}.{name}: {got} is no {expected}",
                    {
                        "what": what,
                        "name": name,
                        "got": repr(value),
                        "expected": "coefficient in (0, 1]"
                        if what == "carla"
                        else "pair of penalties >= 0",
                    },
                )
    return scoring


class RawMonitor(BaseModel):
    """`monitor:` as written."""

    model_config = ConfigDict(extra="forbid")
    channels: Annotated[list[StrictStr], AfterValidator(_check_channels)]
    period: PositiveDuration = 0.1
    signals: Annotated[dict[str, StrictStr], BeforeValidator(_signals_to_dict)] = {}
    metrics: Annotated[MetricParams, BeforeValidator(_metric_numbers)] = MetricParams()
    coverage: dict[StrictStr, ChannelCoverage] = {}
    merge_gap: Duration = 1.0
    min_duration: Duration = 0.0
    # how ROS 2 bags feed the channels: a topics file (relative to the case) or the mapping
    # itself; its content is checked when a bag is read (monitor.bags.mapping, docs/bags.md)
    topics: StrictStr | dict | None = None
    scoring: Annotated[ScoringParams, AfterValidator(_check_scoring)] = ScoringParams()

    @model_validator(mode="after")
    def _gap_covers_a_period(self) -> RawMonitor:
        if self.metrics.max_gap < self.period:
            raise PydanticCustomError(
                "max_gap_below_period",
                "{gap} s is shorter than the period ({period} s), so every frame would start a "
                "data gap; use at least the period",
                {
                    "gap": f"{self.metrics.max_gap:g}",
                    "period": f"{self.period:g}",
                    "field": "metrics",
                    "key": "max_gap",
                },
            )
        return self

    @model_validator(mode="after")
    def _declared_names(self) -> RawMonitor:
        for name in self.coverage:
            if name not in self.channels:
                raise PydanticCustomError(
                    "coverage_channel",
                    "coverage is declared for '{name}', which is not one of the channels {known}",
                    {"name": name, "known": self.channels, "field": "coverage", "key": name},
                )
        builtin = builtin_signals(self.channels)
        for index, name in enumerate(self.signals):
            if not DECLARED_SIGNAL_RE.match(name):
                raise PydanticCustomError(
                    "declared_signal",
                    "declared signal name '{name}' must be an identifier ([A-Za-z_][A-Za-z0-9_]*)",
                    {"name": name, "field": "signals", "key": name, "index": index},
                )
            if name in builtin:
                raise PydanticCustomError(
                    "declared_signal",
                    "declared signal '{name}' has the name of a built-in metric signal",
                    {"name": name, "field": "signals", "key": name, "index": index},
                )
        return self


#: Allowed keys per nesting level, for "did you mean" hints.
NODE_KEYS: tuple[str, ...] = tuple(f.alias or name for name, f in RawNode.model_fields.items())
SPI_KEYS: tuple[str, ...] = tuple(f.alias or name for name, f in RawSpi.model_fields.items())
HAZARD_KEYS: tuple[str, ...] = tuple(RawHazard.model_fields)
CONTRACT_KEYS: tuple[str, ...] = tuple(RawContract.model_fields)
MODULE_KEYS: tuple[str, ...] = tuple(RawModule.model_fields)
MONITOR_KEYS: tuple[str, ...] = tuple(RawMonitor.model_fields)
METRIC_KEYS: tuple[str, ...] = tuple(MetricParams.model_fields)
