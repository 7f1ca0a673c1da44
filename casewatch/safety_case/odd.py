"""Operational Design Domains: the layered condition model, and ODD specifications as data.

A stream reports its conditions in a layered model (after the PEGASUS six-layer model of
scenario description; docs/odd.md): `meta.odd` in the header, `{"road": {"type": "highway"},
"environment": {"weather": "rain", "light": "night"}, ...}`, and a frame's `odd` changes some of
them from that tick on. casewatch names each attribute by its layer and key,
`environment.weather`. An ODD specification (`OddSpec`) lists the accepted values of some
attributes, optionally the accepted combinations; `casewatch odd` writes one, a case includes
one on a context node (`odd:`), and the evaluator checks every tick against it.

This module only defines and validates; it never judges a drive (that is `evaluator.odd_check`).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import yaml
from pydantic import ValidationError

from casewatch.errors import CasewatchError
from casewatch.safety_case.model import OddRange, OddSpec, OddValue

#: The layers of the condition model and what each holds. An attribute is `<layer>.<key>`.
LAYERS: dict[str, str] = {
    "road": "road geometry and topology: type (highway, urban, rural), lanes, curvature",
    "infrastructure": "traffic infrastructure: signals, signs, lane markings",
    "temporary": "temporary changes: roadworks, closures",
    "traffic": "other road users: density, vulnerable road users",
    "environment": "weather and light: weather (clear, rain, fog, snow), light (day, night)",
    "connectivity": "V2X, GNSS and map availability",
}


class OddError(CasewatchError, ValueError):
    """A condition report or ODD specification that cannot be used; the message says where."""


def _scalar(value: object, where: str) -> OddValue:
    if isinstance(value, bool | str):
        return value
    if isinstance(value, int | float) and math.isfinite(value):
        return float(value)
    raise OddError(f"{where}: expected a text, number or boolean, got {value!r:.40}")


def flatten_conditions(layered: object, where: str = "odd") -> dict[str, OddValue]:
    """`{"environment": {"weather": "rain"}}` -> `{"environment.weather": "rain"}`, checked:
    known layers, one level of keys, scalar values. Raises `OddError` naming the key."""
    if not isinstance(layered, dict):
        raise OddError(
            f"{where}: expected a mapping of layers ({', '.join(LAYERS)}), "
            f"got {type(layered).__name__}"
        )
    out: dict[str, OddValue] = {}
    for layer, attributes in layered.items():
        if layer not in LAYERS:
            raise OddError(f"{where}.{layer}: unknown layer; the layers are {', '.join(LAYERS)}")
        if not isinstance(attributes, dict):
            raise OddError(
                f"{where}.{layer}: expected a mapping of attributes, e.g. "
                f'{{"weather": "rain"}}, got {attributes!r:.40}'
            )
        for key, value in attributes.items():
            out[f"{layer}.{key}"] = _scalar(value, f"{where}.{layer}.{key}")
    return out


def attribute_problem(name: str, signals: set[str] | None) -> str | None:
    """Why `name` cannot be an ODD attribute (None when it can): a layered name with a known
    layer, or (without a dot) a signal the case knows, judged per tick."""
    if "." in name:
        layer, _, key = name.partition(".")
        if layer not in LAYERS:
            return f"unknown layer {layer!r} in {name!r}; the layers are {', '.join(LAYERS)}"
        if not key:
            return f"{name!r} names a layer but no attribute (e.g. {layer}.type)"
        return None
    if signals is not None and name not in signals:
        return (
            f"{name!r} is neither a layered condition (`environment.weather`) nor a signal "
            "of this case"
        )
    return None


def parse_odd(data: object, source: str = "", signals: set[str] | None = None) -> OddSpec:
    """An `OddSpec` from plain data (the `odd:` mapping); raises `OddError` naming the key."""
    if isinstance(data, dict) and set(data) == {"odd"}:
        data = data["odd"]  # a file written by `casewatch odd`: one top-level `odd:` key
    if not isinstance(data, dict):
        raise OddError(
            f"expected a mapping with `attributes` (and optionally `name`, "
            f"`combinations`), got {type(data).__name__}"
        )
    try:
        spec = OddSpec.model_validate({**data, "source": source})
    except ValidationError as exc:
        first = exc.errors(include_url=False)[0]
        where = ".".join(str(p) for p in first["loc"]) or "odd"
        raise OddError(f"{where}: {first['msg']} (got {first.get('input')!r:.60})") from None
    if not spec.attributes:
        raise OddError("attributes: an ODD lists at least one attribute and its accepted values")
    for name, accepted in spec.attributes.items():
        problem = attribute_problem(name, signals)
        if problem:
            raise OddError(f"attributes.{name}: {problem}")
        if isinstance(accepted, list) and not accepted:
            raise OddError(
                f"attributes.{name}: no accepted value (an empty list excludes "
                "every tick); list the values, or drop the attribute"
            )
        if isinstance(accepted, OddRange):
            if accepted.min is None and accepted.max is None:
                raise OddError(f"attributes.{name}: a range needs `min`, `max` or both")
            if (
                accepted.min is not None
                and accepted.max is not None
                and accepted.min > accepted.max
            ):
                raise OddError(f"attributes.{name}: min {accepted.min:g} > max {accepted.max:g}")
    for k, combo in enumerate(spec.combinations):
        for name in combo:
            if name not in spec.attributes or "." not in name:
                raise OddError(
                    f"combinations[{k}].{name}: a combination names layered "
                    "conditions the ODD lists under `attributes` (signals are "
                    "judged by their range alone)"
                )
    return spec


def read_odd_file(path: str | Path, signals: set[str] | None = None) -> OddSpec:
    """An ODD specification file (YAML); `OddError` for anything unusable."""
    try:  # ValueError: a NUL byte in the name
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        shown = repr(str(path)) if len(str(path)) <= 80 else f"{str(path)[:77]!r}..."
        raise OddError(
            f"{shown}: cannot read the ODD specification: {getattr(exc, 'strerror', None) or exc}"
        ) from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise OddError(f"{path}: not YAML: {exc}") from None
    try:
        return parse_odd(data, str(path), signals)
    except OddError as exc:
        raise OddError(f"{path}: {exc}") from None


def _plain(value: OddValue) -> OddValue | int:
    if isinstance(value, float) and value.is_integer():
        return int(value)
    return value


def odd_to_data(spec: OddSpec) -> dict[str, Any]:
    """The plain `{"odd": ...}` form `parse_odd` reads back (what `casewatch odd` writes)."""
    attributes: dict[str, Any] = {}
    for name, accepted in spec.attributes.items():
        if isinstance(accepted, OddRange):
            attributes[name] = {
                k: v for k, v in (("min", accepted.min), ("max", accepted.max)) if v is not None
            }
        else:  # whole numbers as written (3 lanes, not 3.0); they read back as floats
            attributes[name] = [_plain(v) for v in accepted]
    body: dict[str, Any] = {"name": spec.name, "attributes": attributes}
    if spec.combinations:
        body["combinations"] = [{k: _plain(v) for k, v in c.items()} for c in spec.combinations]
    return {"odd": body}
