"""The topic mapping: which bag topics feed which casewatch channel, and how to align them.

Written as a small YAML file (`--topics topics.yaml`) or inline under `monitor.topics` in the
case (`docs/bags.md`). Every error names the file, the line and the key, and what was expected.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Literal

from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    ValidationError,
    model_validator,
)
from pydantic_core import PydanticCustomError

from casewatch.errors import CasewatchError
from casewatch.safety_case.schema import parse_duration
from casewatch.safety_case.yamltree import YNode, compose, to_plain


class MappingError(CasewatchError, ValueError):
    """A topic mapping that cannot be used; the message is `FILE:LINE: key: what is wrong`."""


Seconds = Annotated[float, BeforeValidator(parse_duration)]


def _age_limit(raw: object) -> float:
    seconds = parse_duration(raw)
    if seconds <= 0:  # no message is ever that fresh: every tick would be a dropout
        raise PydanticCustomError(
            "malformed_duration",
            "a message age limit must be longer than zero (a message is at most this old "
            "when a tick uses it; 0 would make every tick a dropout), got {got}",
            {"got": repr(raw)},
        )
    return seconds


AgeLimit = Annotated[float, BeforeValidator(_age_limit)]


class TopicRef(BaseModel):
    """One topic, with an optional age limit of its own."""

    model_config = ConfigDict(extra="forbid", frozen=True)
    topic: str = Field(min_length=1)
    max_age: AgeLimit | None = None


def _topic(value: object) -> object:
    """A bare topic name is short for `{topic: NAME}`."""
    return {"topic": value} if isinstance(value, str) else value


Topic = Annotated[TopicRef, BeforeValidator(_topic)]


class ChannelTopics(BaseModel):
    """The topics of one driving stack. `plan` may be left out (plan metrics then have no
    value); a channel without fresh odometry and objects at a tick is a dropout."""

    model_config = ConfigDict(extra="forbid", frozen=True)
    odometry: Topic
    objects: Topic
    plan: Topic | None = None


class EgoSize(BaseModel):
    """The ego footprint, which `nav_msgs/Odometry` does not carry."""

    model_config = ConfigDict(extra="forbid", frozen=True)
    length: float = Field(gt=0, le=100)
    width: float = Field(gt=0, le=100)


class ChannelSight(BaseModel):
    """What a channel's sensors can see (the stream header's `coverage`; the case's
    `monitor.coverage` wins for the channels it names)."""

    model_config = ConfigDict(extra="forbid", frozen=True)
    fov_deg: float = Field(360.0, gt=0, le=360)
    range_m: float | None = Field(None, gt=0)


class SignalTopic(TopicRef):
    """A scalar stream signal: the `data` field of a std_msgs number (or Bool) message."""

    field: str = "data"


class TopicMapping(BaseModel):
    """The whole mapping (see the module docstring)."""

    model_config = ConfigDict(extra="forbid", frozen=True)
    ego: EgoSize
    channels: dict[str, ChannelTopics] = Field(min_length=1)
    signals: dict[str, Annotated[SignalTopic, BeforeValidator(_topic)]] = {}
    time: Literal["header", "receive"] = "header"
    max_age: AgeLimit | None = None  # default: 1.5 periods
    max_delay: Seconds = 1.0
    plan_time: Literal["auto", "stamps", "velocity"] = "auto"
    poses_at_tick: bool = True  # ego and object poses moved from their stamps to the tick
    coverage: dict[str, ChannelSight] = {}
    meta: dict[str, str | int | float] = {}

    @model_validator(mode="after")
    def _coverage_of_mapped_channels(self) -> TopicMapping:
        extra = [c for c in self.coverage if c not in self.channels]
        if extra:
            raise ValueError(
                f"coverage names channel(s) {', '.join(extra)} that channels: does not map"
            )
        return self

    def age_limit(self, ref: TopicRef, period: float) -> float:
        """Seconds a message of `ref` stays usable: its own limit, the mapping's, or 1.5
        periods. A stack does not tick with the monitor: its stamps have their own phase
        against the ticks and jitter, and with a limit of exactly one period a phase near a
        tick plus a millisecond of jitter would leave every other tick without a message.
        Half a period of slack absorbs that; a single lost message is then bridged by its
        predecessor (at most 1.5 periods old), two in a row are a dropout (docs/bags.md)."""
        if ref.max_age is not None:
            return ref.max_age
        if self.max_age is not None:
            return self.max_age
        return 1.5 * period

    def topics(self) -> dict[str, str]:
        """topic name -> role (`odometry`, `objects`, `plan`, `signal`), for type checks."""
        roles: dict[str, str] = {}
        for ch in self.channels.values():
            roles[ch.odometry.topic] = "odometry"
            roles[ch.objects.topic] = "objects"
            if ch.plan is not None:
                roles[ch.plan.topic] = "plan"
        for sig in self.signals.values():
            roles[sig.topic] = "signal"
        return roles


@dataclass(frozen=True)
class LoadedMapping:
    mapping: TopicMapping
    source: str  # where it was written, for messages ("topics.yaml" or "case.yaml:12")


def load_mapping(path: str | Path, key: tuple[str, ...] = ()) -> LoadedMapping:
    """Read a mapping from a YAML file, or from the node at `key` inside it (the case's
    `("monitor", "topics")`). Raises `MappingError`."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise MappingError(f"{path}: cannot read the topic mapping: {exc}") from None
    root, findings = compose(text, str(path))
    errors = [f for f in findings if f.severity == "error"]
    if errors:  # a YAML syntax error, a duplicate key, an alias, a tag, ...
        f = errors[0]
        hint = f"\n    {f.hint}" if f.hint else ""
        raise MappingError(f"{path}:{f.line}:{f.col}: {f.code}: {f.message}{hint}")
    node = root
    for part in key:
        if node is None or node.kind != "map" or part not in node.entries():
            raise MappingError(f"{path}: no `{'.'.join(key)}` in this file")
        node = node.entries()[part].value
    if node is None or node.kind != "map":
        line = node.mark.line if node is not None else 1
        raise MappingError(
            f"{path}:{line}: a topic mapping must be a YAML mapping "
            "(ego:, channels:, ...; see docs/bags.md)"
        )
    try:
        mapping = TopicMapping.model_validate(to_plain(node))
    except ValidationError as exc:
        err = exc.errors()[0]
        loc = [str(p) for p in err["loc"]]
        line = _line(node, loc)
        where = ".".join([*key, *loc]) or "topic mapping"
        raise MappingError(f"{path}:{line}: {where}: {_explain(dict(err))}") from None
    prefix = ".".join(key)
    return LoadedMapping(mapping, f"{path}:{node.mark.line}" if prefix else str(path))


def _line(node: YNode, loc: list[str]) -> int:
    """The line of the deepest key of `loc` that exists in the YAML."""
    line = node.mark.line
    for part in loc:
        if node.kind != "map" or part not in node.entries():
            break
        entry = node.entries()[part]
        line = entry.key_mark.line
        node = entry.value
    return line


def _explain(err: dict) -> str:
    kind = err["type"]
    if kind == "missing":
        return "required here and missing"
    if kind == "extra_forbidden":
        return (
            "unknown key (allowed: ego, channels, signals, time, max_age, max_delay, "
            "plan_time, poses_at_tick, coverage, meta; per channel: odometry, objects, "
            "plan)"
        )
    return str(err["msg"])


def resolve_mapping(
    override: str | Path | None, case_path: str | Path | None, case_topics: str | dict | None
) -> LoadedMapping:
    """The mapping a run uses: `--topics FILE` when given, else the case's `monitor.topics`
    (a file relative to the case, or the mapping written inline). Raises `MappingError`."""
    if override is not None:
        return load_mapping(override)
    if case_topics is None or case_path is None:
        raise MappingError(
            "a ROS 2 bag needs a topic mapping (which topics are the odometry, objects and "
            "plan of each channel): give --topics topics.yaml or write monitor.topics in the "
            "case; docs/bags.md has an example, and `casewatch convert BAG --list-topics` "
            "lists what the bag holds"
        )
    if isinstance(case_topics, str):
        return load_mapping(Path(case_path).parent / case_topics)
    return load_mapping(case_path, ("monitor", "topics"))
