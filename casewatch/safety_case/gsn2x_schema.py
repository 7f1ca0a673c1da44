"""gsn2x's input format as pydantic models, written from gsn2x's documentation (YAML syntax,
layout, layers, modules, confidence and dialectic extensions), to check that what casewatch
writes for gsn2x is something gsn2x reads.

This is gsn2x's format, not casewatch's: `challenges` is one node or one relation (`G2 -> CG1`),
never a list; `classes` is a list; `horizontalIndex` is `{relative: n}` or `{absolute: n|last}`;
rank increments and wrap widths are whole numbers >= 0; any attribute gsn2x does not know is a
layer and may hold anything. `gsn2x_problems` adds the few document-wide rules gsn2x refuses a
file for (every id typed, only counter nodes challenge, references resolve).
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, StrictBool, StrictInt, StrictStr, ValidationError

from casewatch.safety_case.gsn2x import (
    COUNTER_TYPES,
    NODE_TYPE_NAMES,
    split_relation,
    type_by_prefix,
)

Count = Annotated[StrictInt, Field(ge=0)]
#: `supportedBy`, `inContextOf`, `defeatedRelation`: one id or a list of ids
Ids = StrictStr | list[StrictStr]


class Relative(BaseModel):
    """`horizontalIndex: {relative: -1}`: move this many places within its rank."""

    model_config = ConfigDict(extra="forbid")
    relative: StrictInt


class Absolute(BaseModel):
    """`horizontalIndex: {absolute: 0}` or `{absolute: last}`: a fixed place in its rank."""

    model_config = ConfigDict(extra="forbid")
    absolute: Count | Literal["last"]


class Gsn2xElement(BaseModel):
    """One element (node). Keys gsn2x does not know are layers (`extra="allow"`)."""

    model_config = ConfigDict(extra="allow")
    text: StrictStr = ""
    supportedBy: Ids = []
    inContextOf: Ids = []
    challenges: StrictStr | None = None  # one node id, or a relation `X -> Y`
    undeveloped: StrictBool = False
    defeated: StrictBool = False
    defeatedRelation: Ids = []
    classes: list[StrictStr] = []
    url: StrictStr | None = None
    rankIncrement: Count | None = None
    horizontalIndex: Relative | Absolute | None = None
    nodeType: Literal[tuple(NODE_TYPE_NAMES)] | None = None  # type: ignore[valid-type]
    charWrap: Count | None = None
    acp: dict[StrictStr, Ids] = {}


class Extends(BaseModel):
    """`extends: [{module: template, develops: {G1: [G2]}}]`."""

    model_config = ConfigDict(extra="forbid")
    module: StrictStr
    develops: dict[StrictStr, list[StrictStr]]


class Gsn2xModule(BaseModel):
    """The optional `module` block; further keys are shown in the legend."""

    model_config = ConfigDict(extra="allow")
    name: StrictStr
    brief: StrictStr | None = None
    extends: list[Extends] = []
    uses: list[StrictStr] = []
    stylesheets: list[StrictStr] = []
    horizontalIndex: Relative | Absolute | None = None
    rankIncrement: Count | None = None
    charWrap: Count | None = None


def _ids(value: str | list[str]) -> list[str]:
    return [value] if isinstance(value, str) else list(value)


def gsn2x_problems(document: object) -> list[str]:
    """Why gsn2x would refuse `document` (a loaded YAML value), one line each; [] when it
    reads it. Only one file: references to elements of other files count as unresolved."""
    if not isinstance(document, dict):
        return ["the document is not a mapping of element ids"]
    problems: list[str] = []
    elements: dict[str, Gsn2xElement] = {}
    for key, value in document.items():
        try:
            if key == "module":
                module = Gsn2xModule.model_validate(value)
                problems += [
                    f"module: extends {e.module!r}, a module this file does not hold"
                    for e in module.extends
                    if e.module != module.name
                ]
            else:
                elements[str(key)] = Gsn2xElement.model_validate(value or {})
        except ValidationError as exc:
            for error in exc.errors(include_url=False):
                where = ".".join(str(p) for p in error["loc"])
                problems.append(f"{key}: {where}: {error['msg']}")
    for node_id, element in elements.items():
        explicit = NODE_TYPE_NAMES.get(element.nodeType) if element.nodeType else None
        node_type = explicit or type_by_prefix(node_id)
        if node_type is None:
            problems.append(f"{node_id}: no type (no known prefix and no nodeType)")
        if element.challenges is not None and node_type not in COUNTER_TYPES:
            problems.append(f"{node_id}: only counter nodes challenge")
        if element.undeveloped and _ids(element.supportedBy):
            problems.append(f"{node_id}: undeveloped but supported")
        named = [*_ids(element.supportedBy), *_ids(element.inContextOf)]
        if element.challenges is not None:
            relation = split_relation(element.challenges)
            named += list(relation) if relation else [element.challenges]
        problems += [f"{node_id}: names {t!r}, no element" for t in named if t not in elements]
    return problems
