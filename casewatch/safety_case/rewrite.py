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
from ruamel.yaml.error import CommentMark
from ruamel.yaml.tokens import CommentToken

from casewatch.errors import CasewatchError
from casewatch.safety_case.numbers import number_text

_NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"


class RewriteError(CasewatchError, ValueError):
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
        return text[: match.start(2)] + new + text[match.end(2) :]
    return text[: match.start(1)] + new + text[match.start(2) :]


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


#: The prefix of the notes `rewrite` writes beside a threshold (and finds again to replace).
NOTE_PREFIX = "casewatch calibrate:"


def _note(node: CommentedMap, binding: CommentedMap, text: str | None) -> None:
    """Put `text` as the end-of-line comment of the threshold's line (the `threshold:` key of a
    block mapping, the `spi:` key of a flow one), after any comment the author wrote there;
    a note an earlier run left (`NOTE_PREFIX`) goes, so a note never outlives its reason.

    ruamel keeps an end-of-line comment and the blank and comment lines that follow it in one
    token: only its first line is the comment of this line, the rest stays as it is."""
    flow = binding.fa.flow_style()
    owner, key = (node, "spi") if flow else (binding, "threshold")
    tokens = owner.ca.items.get(key)
    token = tokens[2] if tokens is not None and len(tokens) > 2 else None
    value = token.value if token is not None else ""
    cut = value.find("\n")
    head, tail = (value, "\n") if cut < 0 else (value[:cut], value[cut:])
    kept = head.strip().removeprefix("#").strip().split(NOTE_PREFIX)[0].rstrip(" ;")
    comment = "; ".join(x for x in (kept, f"{NOTE_PREFIX} {text}" if text else "") if x)
    if comment == head.strip().removeprefix("#").strip():
        return  # nothing to add or remove: the line stays exactly as written
    if token is None:
        owner.yaml_add_eol_comment(comment, key)
        return
    # column 0: ruamel then writes one space before the value, which starts with one more
    tokens[2] = CommentToken((f" # {comment}" if comment else "") + tail, CommentMark(0), None)


def rewrite(yaml_text: str, changes: list[Change], notes: dict[str, str] | None = None) -> str:
    """The case text with every change applied (comments and layout kept). `notes`: node id
    -> a note to write as a comment beside that SPI's threshold (why calibrate left it as it
    is); SPIs that change or get a note lose any note an earlier run left."""
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
            binding[key] = _like(
                old, replace_number(str(old), ch.signal, ch.op, ch.signal_left, ch.new)
            )
        else:
            old = binding["threshold"]
            binding["threshold"] = _like(old, f"{ch.op} {number_text(ch.new)}")
        if ch.duration_kind and ch.new_duration != ch.old_duration:
            key = "for" if ch.duration_kind == "for" else "min_duration"
            if ch.new_duration == 0 and key == "for":
                _drop(binding, key)
            else:
                binding[key] = seconds_text(ch.new_duration)
    touched = {ch.node_id for ch in changes if ch.kind == "spi" and not ch.raw_stl}
    for node_id in touched | set(notes or {}):
        node = data.get(node_id)
        binding = node.get("spi") if isinstance(node, CommentedMap) else None
        if not isinstance(binding, CommentedMap) or "threshold" not in binding:
            raise RewriteError(f"node {node_id} has no `spi:` mapping with a threshold")
        _note(node, binding, (notes or {}).get(node_id))
    out = io.StringIO()
    yaml.dump(data, out)
    return out.getvalue()
