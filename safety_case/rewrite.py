"""Rewrite a safety case's thresholds and durations, keeping everything else as written.

`casewatch tune` and `casewatch calibrate` hand back the user's own YAML with new numbers, not a
regenerated file: comments, key order, flow or block style and quoting stay (a ruamel.yaml round
trip), so the diff shows only what the data changed. A formula (`when:`, `stl:`) keeps its text
except for the one number swept: the token after `signal OP` (or before `OP signal`).
"""

from __future__ import annotations

import io
import re
from dataclasses import dataclass

from ruamel.yaml import YAML
from ruamel.yaml.comments import CommentedMap

from spec.emit import number_text

_NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"


class RewriteError(ValueError):
    """The case cannot be rewritten as asked (names the node and key)."""


@dataclass(frozen=True)
class Change:
    """New values for one node: its swept threshold and/or its duration."""

    node_id: str
    kind: str  # "spi" or "hazard"
    signal: str
    op: str
    signal_left: bool
    old: float
    new: float
    duration_kind: str | None  # "for", "min_duration" or None
    old_duration: float
    new_duration: float
    raw_stl: bool = False


def seconds_text(value: float) -> str:
    """`1.5s`, `2s` (the case language's duration form)."""
    return f"{value:.10g}s"


def replace_number(text: str, signal: str, op: str, signal_left: bool, value: float) -> str:
    """`text` with the number compared with `signal` by `op` replaced by `value` (the first
    such comparison)."""
    name = re.escape(signal)
    o = re.escape(op)
    if signal_left:
        pattern = rf"(\b{name}\s*{o}\s*)({_NUMBER})"
    else:
        pattern = rf"({_NUMBER})(\s*{o}\s*{name}\b)"
    match = re.search(pattern, text)
    if match is None:
        raise RewriteError(f"cannot find `{signal} {op} NUMBER` in the formula {text!r}")
    new = number_text(value)
    if signal_left:
        return text[: match.start(2)] + new + text[match.end(2):]
    return text[: match.start(1)] + new + text[match.start(2):]


def _like(old: object, text: str) -> object:
    """`text` as a scalar of the same quoting style as `old`."""
    return type(old)(text) if isinstance(old, str) and type(old) is not str else text


def _drop(mapping: CommentedMap, key: str) -> None:
    """Remove `key`; what followed its value (a comment, the blank line before the next
    node) moves to the key before it, so the layout around the mapping stays."""
    if key not in mapping:
        return
    last = list(mapping)[-1] == key
    tokens = mapping.ca.items.pop(key, None)
    del mapping[key]
    if last and tokens is not None and len(mapping):
        mapping.ca.items.setdefault(list(mapping)[-1], tokens)


def rewrite(yaml_text: str, changes: list[Change]) -> str:
    """The case text with every change applied (comments and layout kept)."""
    yaml = YAML(typ="rt")
    yaml.preserve_quotes = True
    yaml.width = 4096  # never re-wrap long lines
    data = yaml.load(yaml_text)
    if not isinstance(data, CommentedMap):
        raise RewriteError("the case is not a mapping of nodes")
    for ch in changes:
        node = data.get(ch.node_id)
        if not isinstance(node, CommentedMap):
            raise RewriteError(f"node {ch.node_id} is not in the case")
        binding = node.get(ch.kind)
        if not isinstance(binding, CommentedMap):
            raise RewriteError(f"node {ch.node_id} has no `{ch.kind}:` mapping")
        if ch.kind == "hazard" or ch.raw_stl:
            key = "when" if ch.kind == "hazard" else "stl"
            old = binding[key]
            binding[key] = _like(old, replace_number(str(old), ch.signal, ch.op,
                                                     ch.signal_left, ch.new))  # fmt: skip
        else:
            old = binding["threshold"]
            binding["threshold"] = _like(old, f"{ch.op} {number_text(ch.new)}")
        if ch.duration_kind and ch.new_duration != ch.old_duration:
            key = "for" if ch.duration_kind == "for" else "min_duration"
            if ch.new_duration == 0 and key == "for":
                _drop(binding, key)
            else:
                binding[key] = seconds_text(ch.new_duration)
    out = io.StringIO()
    yaml.dump(data, out)
    return out.getvalue()
