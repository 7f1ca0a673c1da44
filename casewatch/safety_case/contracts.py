"""The libraries of named formulas a case instantiates with `use:`: assume-guarantee contracts
(`contract: {use: ...}`, libraries/contracts.yaml) and traffic rules (`hazard: {use: ...}`,
libraries/traffic-rules.yaml).

A library is data shipped in the package: each entry has a text, parameters with defaults and
bounds, the stream signals it needs declared, and formula templates (`assume`/`guarantee`, or
`when`). Expanding one substitutes the parameters into the templates, so what the compiler sees
is an ordinary formula: one language, one checker, one evaluator for library and hand-written
formulas alike.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from functools import cache
from importlib import resources
from typing import Any

import yaml

from casewatch.errors import CasewatchError
from casewatch.safety_case.numbers import number_text
from casewatch.safety_case.signals import available_signals

LIBRARY = "contracts"
RULES = "traffic-rules"
_PLACE = re.compile(r"\{([A-Za-z_][A-Za-z0-9_]*)(?::([a-z]+))?\}")
_IDENT = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


class ContractError(CasewatchError, ValueError):
    """A `use:` that cannot be expanded; `key` is the YAML key to point at (`use`, `params`,
    or `params.<name>`)."""

    def __init__(self, message: str, key: str = "use", hint: str = "", at_key: bool = False):
        super().__init__(message)
        self.key = key
        self.hint = hint
        self.at_key = at_key  # point at the key itself (an unknown parameter), not its value


@dataclass(frozen=True)
class Param:
    name: str
    kind: str  # number, channel (a monitor channel) or signal (a signal name)
    default: float | str | None
    lo: float | None
    hi: float | None
    integer: bool
    unit: str
    description: str


#: The formula templates an entry of each library has (the others are its data).
FORMULA_KEYS = ("assume", "guarantee", "when")


@dataclass(frozen=True)
class Template:
    name: str
    text: str
    needs: dict[str, str]  # declared stream signals it reads -> what they are
    params: dict[str, Param]
    formulas: dict[str, str]  # assume / guarantee (contracts) or when (rules) -> template
    data: dict[str, Any]  # the rest of the entry (a rule's durations and penalties)

    @property
    def assume(self) -> str | None:
        return self.formulas.get("assume")

    @property
    def guarantee(self) -> str:
        return self.formulas["guarantee"]

    @property
    def source(self) -> str:
        """The equation of the source document the entry implements (`eq. 3.25`), or
        `casewatch` for casewatch's own variants."""
        return str(self.data.get("source", ""))

    @property
    def deviation(self) -> str:
        """How and why a casewatch variant departs from its source ('' when it follows it)."""
        return str(self.data.get("deviation", ""))


@cache
def library(name: str = LIBRARY) -> dict[str, Template]:
    """Every entry of the shipped library `name` (contracts, traffic-rules), by name."""
    library = resources.files("casewatch.safety_case").joinpath("libraries", f"{name}.yaml")
    raw = yaml.safe_load(library.read_text("utf-8"))
    out: dict[str, Template] = {}
    for key, entry in raw["entries"].items():
        params = {
            p: Param(
                p,
                spec.get("kind", "number"),
                spec.get("default"),
                spec.get("min"),
                spec.get("max"),
                bool(spec.get("integer", False)),
                spec.get("unit", ""),
                spec.get("description", ""),
            )
            for p, spec in (entry.get("params") or {}).items()
        }
        formulas = {k: entry[k] for k in FORMULA_KEYS if entry.get(k)}
        data = {
            k: v for k, v in entry.items() if k not in (*FORMULA_KEYS, "text", "needs", "params")
        }
        out[key] = Template(
            key, entry["text"], dict(entry.get("needs") or {}), params, formulas, data
        )
    return out


def _finite(number: float) -> bool:
    """math.isfinite, but False for an integer beyond float range (a 401-digit `frames`) instead
    of an OverflowError."""
    try:
        return math.isfinite(number)
    except OverflowError:
        return False


def _value(param: Param, given: Any, channels: list[str]) -> float | int | str:
    where = f"params.{param.name}"
    if param.kind == "channel":
        if given not in channels:
            raise ContractError(
                f"`{where}` must be one of the case's channels "
                f"({', '.join(channels)}), got {given!r}",
                where,
            )
        return str(given)
    if param.kind == "signal":
        if not isinstance(given, str) or not _IDENT.match(given):
            raise ContractError(f"`{where}` must be a signal name, got {given!r}", where)
        return given
    if isinstance(given, bool) or not isinstance(given, int | float) or not _finite(given):
        shown = repr(given) if len(repr(given)) <= 40 else f"{repr(given)[:37]}..."
        raise ContractError(f"`{where}` must be a finite number, got {shown}", where)
    value = float(given)
    if param.integer and value != int(value):
        raise ContractError(f"`{where}` must be a whole number, got {given!r}", where)
    if param.integer:
        value = int(value)
    if (param.lo is not None and value < param.lo) or (param.hi is not None and value > param.hi):
        raise ContractError(
            f"`{where}` must lie in [{param.lo:g}, {param.hi:g}]"
            f"{' ' + param.unit if param.unit else ''}, got {given!r}",
            where,
        )
    return value


def resolve_params(
    template: Template, given: dict[str, Any], channels: list[str]
) -> dict[str, float | str]:
    """Every parameter of `template`: the given value (checked) or its default."""
    unknown = sorted(set(given) - set(template.params))
    if unknown:
        known = ", ".join(template.params) or "none"
        raise ContractError(
            f"contract {template.name} has no parameter {unknown[0]!r} (its parameters: {known})",
            f"params.{unknown[0]}",
            at_key=True,
        )
    out: dict[str, float | str] = {}
    for name, param in template.params.items():
        if name in given:
            out[name] = _value(param, given[name], channels)
        elif param.default is None:
            choices = f" (one of {', '.join(channels)})" if param.kind == "channel" else ""
            raise ContractError(
                f"contract {template.name} needs `params.{name}`: {param.description}{choices}",
                "params",
            )
        else:
            default = param.default
            out[name] = default if isinstance(default, str) or param.integer else float(default)
    return out


def substitute(text: str, values: dict[str, float | str], period: float) -> str:
    """The template with its `{name}` places filled (`{frames:window}`: seconds)."""

    def fill(match: re.Match[str]) -> str:
        name, form = match.group(1), match.group(2)
        value = values[name]
        if form == "window":
            return number_text(round((float(value) - 1) * period, 9))
        if isinstance(value, str):
            return value
        return number_text(value)

    return _PLACE.sub(fill, text)


def instantiate(
    use: str,
    given: dict[str, Any],
    channels: list[str],
    declared: dict[str, str],
    period: float,
    name: str = LIBRARY,
) -> tuple[Template, dict[str, float | str], dict[str, str]]:
    """(template, resolved parameters, formula texts by key) for `use: ENTRY` of library
    `name`; raises `ContractError` for an unknown entry, parameter or undeclared signal."""
    entries = library(name)
    key = use.removeprefix(f"{name}/")
    template = entries.get(key)
    what = "contract" if name == LIBRARY else "rule"
    if template is None:
        import difflib

        close = difflib.get_close_matches(key, list(entries), n=1)
        mean = f"; did you mean {close[0]!r}?" if close else ""
        raise ContractError(
            f"no {what} {use!r} in the {name} library{mean}",
            "use",
            f"the library's {what}s: {', '.join(entries)}",
        )
    missing = [s for s in template.needs if s not in declared]
    if missing:
        lines = ", ".join(f"{s}: {template.needs[s]}" for s in missing)
        raise ContractError(
            f"{what} {key} reads the stream signal(s) {', '.join(missing)}, "
            "which monitor.signals does not declare",
            "use",
            f"declare them: monitor: {{signals: {{{lines}}}}}",
        )
    values = resolve_params(template, given, channels)
    known = available_signals(channels, declared)
    for pname, param in template.params.items():
        if param.kind == "signal" and values[pname] not in known:
            where = f"params.{pname}" if pname in given else "use"
            raise ContractError(
                f"{what} {key} reads `{pname}` = {values[pname]!r}, which is no signal of this "
                f"case ({param.description})",
                where,
                f"declare it under monitor.signals, or set params.{pname} to a signal the case "
                "has, e.g. lead_gap__<channel>",
            )
    texts = {k: substitute(v, values, period) for k, v in template.formulas.items()}
    return template, values, texts
