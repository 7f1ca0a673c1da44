"""YAML composition that keeps source positions for every key and value.

pyyaml's `safe_load` throws the marks away and silently keeps the last of two equal keys. Here a
`yaml.SafeLoader` subclass only *composes* the node tree (no Python objects are ever constructed
from tags); we then convert it to a small positioned tree (`YNode`) ourselves. Only the YAML core
scalar types are interpreted (str, int, float, bool, null); anything else is reported.

Problems are collected as findings (codes CW003, CW005, CW006, CW007), never raised.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Literal

import yaml

from casewatch.safety_case.codes import finding
from casewatch.safety_case.findings import Finding
from casewatch.safety_case.model import Mark

#: Deeper nesting than this is not a safety case; refuse before any recursion gets near its limit.
MAX_DEPTH = 64

_TAG = "tag:yaml.org,2002:"
_CORE_SCALARS = {_TAG + t for t in ("str", "null", "bool", "int", "float", "timestamp")}

Kind = Literal["scalar", "seq", "map"]


@dataclass
class YEntry:
    """One mapping entry: the key text, where the key is, and the value."""

    key: str
    key_mark: Mark
    value: YNode


@dataclass
class YNode:
    """A composed YAML node with its position.

    `value` is a plain scalar (str, int, float, bool, None) for scalars, a list of YNode for
    sequences and a dict key -> YEntry for mappings (first occurrence wins on duplicates; the
    duplicate is reported). `content_mark` is where the scalar's text starts: for a plain scalar
    its own start, for a quoted scalar the first character inside the quotes, for a block scalar
    (`|`, `>`) the first character of its first non-blank content line.
    """

    kind: Kind
    value: object
    mark: Mark
    content_mark: Mark
    style: str | None = None
    children: list[YNode] = field(default_factory=list)

    def entries(self) -> dict[str, YEntry]:
        assert self.kind == "map"
        return self.value  # type: ignore[return-value]

    def items(self) -> list[YNode]:
        assert self.kind == "seq"
        return self.value  # type: ignore[return-value]


def to_plain(node: YNode) -> object:
    """The plain Python value (what `yaml.safe_load` would give for the supported subset)."""
    if node.kind == "scalar":
        return node.value
    if node.kind == "seq":
        return [to_plain(n) for n in node.items()]
    return {k: to_plain(e.value) for k, e in node.entries().items()}


#: The file marks name while a used module is composed (empty: the case file; see `compose`).
_mark_path = ""


def mark_of(ymark: yaml.Mark | None) -> Mark:
    """pyyaml marks are 0-based; ours are 1-based."""
    if ymark is None:
        return Mark(path=_mark_path)
    return Mark(line=ymark.line + 1, col=ymark.column + 1, path=_mark_path)


def yaml11_number_form(text: str) -> str | None:
    """The YAML 1.1-only notation a plain number uses (`1_000`, `1:30`, `0b101`, `017`), or
    None for a number every YAML and JSON reader agrees on."""
    digits = text.lstrip("+-")
    if "_" in digits:
        return "digits with '_' separators"
    if ":" in digits:
        return "base 60 (sexagesimal)"
    if re.fullmatch(r"0b[01]+", digits):
        return "a binary 0b number"
    if re.fullmatch(r"0[0-7]+", digits):
        return "an octal number with a leading zero"
    return None


class _Composer(yaml.SafeLoader):
    """Composes nodes only; an alias becomes an empty scalar and is reported (no sharing, no
    cycles, no exponential expansion)."""

    def __init__(self, stream: str) -> None:
        super().__init__(stream)
        self.aliases: list[Mark] = []

    def compose_node(self, parent: yaml.Node | None, index: object) -> yaml.Node:  # type: ignore[override]
        if self.check_event(yaml.AliasEvent):
            event = self.get_event()
            self.aliases.append(mark_of(event.start_mark))
            return yaml.ScalarNode(_TAG + "null", "", event.start_mark, event.end_mark)
        return super().compose_node(parent, index)


class _Converter:
    def __init__(self, text: str, path: str, loader: _Composer) -> None:
        self.lines = text.splitlines()
        self.path = path
        self.loader = loader
        self.findings: list[Finding] = []

    def unsupported(self, message: str, mark: Mark, hint: str = "") -> None:
        self.findings.append(finding("CW006", message, self.path, mark, hint))

    def content_mark(self, node: yaml.ScalarNode) -> Mark:
        start = mark_of(node.start_mark)
        if node.style in ('"', "'"):
            return Mark(line=start.line, col=start.col + 1, path=_mark_path)
        if node.style in ("|", ">"):
            for number in range(start.line + 1, len(self.lines) + 1):
                line = self.lines[number - 1]
                if line.strip():
                    return Mark(
                        line=number, col=len(line) - len(line.lstrip()) + 1, path=_mark_path
                    )
        return start

    def scalar(self, node: yaml.ScalarNode) -> object:
        tag = node.tag
        if tag not in _CORE_SCALARS:
            self.unsupported(
                f"unsupported YAML tag {tag!r}",
                mark_of(node.start_mark),
                "write plain YAML scalars; casewatch never constructs objects from tags",
            )
            return node.value
        if tag == _TAG + "str" or tag == _TAG + "timestamp":
            return node.value  # a date-like text stays the text the user wrote
        try:
            if tag == _TAG + "null":
                return None
            if tag == _TAG + "bool":
                return self.loader.construct_yaml_bool(node)
            if tag == _TAG + "int":
                value: object = self.loader.construct_yaml_int(node)
            else:
                value = self.loader.construct_yaml_float(node)
        except (ValueError, OverflowError, yaml.YAMLError):
            return node.value
        form = yaml11_number_form(node.value)
        if form is not None:
            self.findings.append(
                finding(
                    "CW007",
                    f"the number {node.value} is written as {form}, which only YAML 1.1 reads as "
                    f"{value!r}; YAML 1.2, JSON and most other tools read it differently",
                    self.path,
                    mark_of(node.start_mark),
                    f"write {value!r}",
                )
            )
        return value

    def convert(self, node: yaml.Node, depth: int = 0) -> YNode:
        mark = mark_of(node.start_mark)
        if depth > MAX_DEPTH:
            self.unsupported(f"nesting deeper than {MAX_DEPTH} levels", mark)
            return YNode("scalar", None, mark, mark)
        if isinstance(node, yaml.ScalarNode):
            return YNode("scalar", self.scalar(node), mark, self.content_mark(node), node.style)
        if isinstance(node, yaml.SequenceNode):
            if node.tag != _TAG + "seq":
                self.unsupported(f"unsupported YAML tag {node.tag!r} on a sequence", mark)
            items = [self.convert(child, depth + 1) for child in node.value]
            return YNode("seq", items, mark, mark)
        assert isinstance(node, yaml.MappingNode)
        if node.tag != _TAG + "map":
            self.unsupported(f"unsupported YAML tag {node.tag!r} on a mapping", mark)
        entries: dict[str, YEntry] = {}
        for key_node, value_node in node.value:
            key_mark = mark_of(key_node.start_mark)
            if not isinstance(key_node, yaml.ScalarNode):
                self.unsupported(
                    "a mapping key must be a plain scalar, not a list or a mapping", key_mark
                )
                continue
            if key_node.tag not in _CORE_SCALARS:
                self.unsupported(f"unsupported YAML tag {key_node.tag!r} on a key", key_mark)
            key = str(key_node.value)
            if key in entries:
                first = entries[key].key_mark
                self.findings.append(
                    finding(
                        "CW005",
                        f"duplicate key {key!r} (first at line {first.line}); YAML would "
                        "silently keep only the last one",
                        self.path,
                        key_mark,
                        "merge the two entries or rename one",
                    )
                )
                continue
            entries[key] = YEntry(key, key_mark, self.convert(value_node, depth + 1))
        return YNode("map", entries, mark, mark)


def compose(
    text: str, path: str = "<input>", marks_name_file: bool = False
) -> tuple[YNode | None, list[Finding]]:
    """Compose `text` into a positioned tree; syntax problems become findings (CW003/CW006).
    `marks_name_file`: every mark carries `path` (a module the case uses, whose nodes are
    checked with the case's and must be reported in their own file)."""
    global _mark_path
    previous, _mark_path = _mark_path, (path if marks_name_file else "")
    try:
        return _compose(text, path)
    finally:
        _mark_path = previous


def _compose(text: str, path: str) -> tuple[YNode | None, list[Finding]]:
    loader: _Composer | None = None
    try:
        loader = _Composer(text)
        root = loader.get_single_node()
    except yaml.MarkedYAMLError as exc:
        mark = mark_of(exc.problem_mark or exc.context_mark)
        problem = exc.problem or "invalid YAML"
        message = f"{exc.context}, {problem}" if exc.context else problem
        return None, [finding("CW003", f"YAML syntax error: {message}", path, mark)]
    except yaml.YAMLError as exc:  # ReaderError: a character YAML does not allow
        position = getattr(exc, "position", None)
        mark = _position_mark(text, position) if isinstance(position, int) else Mark()
        reason = getattr(exc, "reason", "") or "invalid character"
        return None, [finding("CW003", f"YAML syntax error: {reason}", path, mark)]
    except RecursionError:
        return None, [
            finding("CW006", f"nesting deeper than {MAX_DEPTH} levels", path, Mark(line=1, col=1))
        ]
    finally:
        if loader is not None:
            loader.dispose()
    findings = [
        finding(
            "CW006",
            "YAML aliases (*name) are not supported in a safety case",
            path,
            mark,
            "write the value out; a safety case must read the same in a diff as it is judged",
        )
        for mark in loader.aliases
    ]
    if root is None:
        return None, findings
    converter = _Converter(text, path, loader)
    tree = converter.convert(root)
    return tree, findings + converter.findings


def _position_mark(text: str, position: int) -> Mark:
    before = text[:position]
    line = before.count("\n") + 1
    col = position - (before.rfind("\n") + 1) + 1
    return Mark(line=line, col=col)
