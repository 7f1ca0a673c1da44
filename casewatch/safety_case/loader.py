"""Loading a safety case: bytes -> positioned YAML tree -> validated `Case`, with findings.

Nothing here raises on bad input. Every problem becomes a `Finding` with a stable code and the
line and column of the offending key or value; `require_case` is the one entry point that raises
(`CaseError`), for callers that must not proceed with a broken case.

Positions: `Node.mark` is the node id key; `SpiBinding.mark` / `HazardBinding.mark` the `spi:` /
`hazard:` key. `SpiBinding.formula_mark` / `HazardBinding.formula_mark` point at the first
character of the formula *text* (the `stl` value, or the `signal` value when bound by signal +
threshold, or the `when` value): for a plain scalar that is the value's own start; for a quoted
scalar the first character inside the quote (so column offsets into the formula add up); for a
block scalar (`|`, `>`) the first character of its first content line. The spec compiler adds
its parse-error offsets to this mark.
"""

from __future__ import annotations

import hashlib
import re
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ValidationError

from casewatch.safety_case.codes import finding
from casewatch.safety_case.contracts import LIBRARY, RULES, ContractError, Template, instantiate
from casewatch.safety_case.findings import CaseError, Finding, has_errors
from casewatch.safety_case.gsn2x import (
    COUNTER_TYPES,
    did_you_mean,
    split_relation,
    type_by_prefix,
)
from casewatch.safety_case.model import (
    Case,
    ContractBinding,
    HazardBinding,
    Mark,
    Module,
    MonitorConfig,
    Node,
    NodeType,
    OddSpec,
    ScoringParams,
    SpiBinding,
)
from casewatch.safety_case.odd import OddError, parse_odd, read_odd_file
from casewatch.safety_case.schema import (
    CONTRACT_KEYS,
    GSN_MODULE_ATTRIBUTES,
    GSN_NODE_ATTRIBUTES,
    GSN_NODE_TYPES,
    HAZARD_KEYS,
    METRIC_KEYS,
    MODULE_KEYS,
    MONITOR_KEYS,
    NODE_KEYS,
    SPI_KEYS,
    RawExtends,
    RawGsn2xNode,
    RawModule,
    RawMonitor,
    RawNode,
    bounds_text,
    describe_value,
)
from casewatch.safety_case.signals import available_signals
from casewatch.safety_case.structure import check_case
from casewatch.safety_case.yamltree import YEntry, YNode, compose, to_plain

#: A node id is a type prefix followed by a digit, e.g. G1, Sn3, CSn2, G1.2 (gsn2x style).
NODE_ID_RE = re.compile(r"^(CSn|CG|Sn|G|S|C|A|J)([0-9][A-Za-z0-9_.\-]*)$")
#: gsn2x's other spelling: the prefix, `-` or `_`, then any name (`G-TopLevelGoal`)
GSN2X_ID_RE = re.compile(r"^(CSn|CG|Sn|G|S|C|A|J)[-_]([A-Za-z0-9_.\-]+)$")
RESERVED_KEYS: tuple[str, ...] = ("module", "monitor")
#: Modules shipped with casewatch that `module.uses` finds by name when no file of that name
#: lies next to the using file.
PACKAGED_MODULES: dict[str, Path] = {
    "traffic-rules": Path(
        str(
            resources.files("casewatch.safety_case").joinpath("libraries", "traffic-rules.gsn.yaml")
        )
    ),
}
RELATIONS: tuple[str, ...] = ("supportedBy", "inContextOf", "challenges")
#: Keys of casewatch's bindings: on a node they are a misplaced binding, never a gsn2x layer.
BINDING_KEYS = frozenset((*SPI_KEYS, *HAZARD_KEYS, *CONTRACT_KEYS))
#: What `export-gsn` keeps per node in `module.additionalInformation.casewatch.bindings`
#: (`challenges`: a list of several, which gsn2x's single `challenges` cannot hold).
KEPT_NODE_KEYS = ("spi", "hazard", "contract", "odd", "challenges")
_TOP = Mark(line=1, col=1)  # where file-level findings (a missing block) point

_CODE_BY_ERROR = {
    "extra_forbidden": "CW013",
    "missing": "CW014",
    "malformed_threshold": "CW016",
    "malformed_duration": "CW017",
    "malformed_margin": "CW015",
    "spi_shape": "CW018",
    "channels": "CW019",
    "declared_signal": "CW025",
}

#: pydantic's range errors; for a metric parameter the message states its documented bounds.
_BOUND_ERRORS = frozenset(
    {"greater_than", "greater_than_equal", "less_than", "less_than_equal", "finite_number"}
)
#: Our own CW012 errors whose message already says everything.
_OWN_MESSAGES = frozenset(
    {"max_gap_below_period", "unknown_rule", "horizontal_index", "acp", "ids"}
)

_EXPECTED = {
    "string_type": "text",
    "string_too_short": "non-empty text",
    "bool_type": "true or false",
    "bool_parsing": "true or false",
    "list_type": "a list",
    "dict_type": "a mapping",
    "model_type": "a mapping",
    "model_attributes_type": "a mapping",
    "int_type": "a whole number",
    "int_parsing": "a whole number",
    "int_from_float": "a whole number",
    "float_type": "a number",
    "float_parsing": "a number",
    "finite_number": "a finite number",
}


@dataclass
class LoadResult:
    """Everything loading found.

    `case` is the validated case, or None when loading found errors. `partial` is a best-effort
    case built even when some nodes are invalid, so the structural checks can still report
    everything in one run; never hand `partial` to a later stage. `skipped` names top-level keys
    that could not become nodes (unknown type), so references to them are not also reported as
    dangling. `invalid` names nodes that failed validation (kept leniently in `partial`).
    """

    case: Case | None
    partial: Case | None
    findings: list[Finding]
    skipped: dict[str, Mark] = field(default_factory=dict)
    invalid: set[str] = field(default_factory=set)
    #: read by gsn2x's rules: a pure argument (no `monitor` block, none inherited)
    gsn2x_rules: bool = False
    #: module name -> the ids of the nodes written in it (this file's and its uses')
    modules: dict[str, set[str]] = field(default_factory=dict)
    #: gsn2x `extends` of this file and its uses, applied by the case file: (module name,
    #: what it extends, where `extends` is written)
    extensions: list[tuple[str, list[RawExtends], Mark]] = field(default_factory=list)


def node_type_of(node_id: str, gsn2x_rules: bool = False) -> NodeType | None:
    """The GSN type a node id's prefix names, or None when it names none. casewatch's rule
    wants a digit, `-` or `_` after the prefix (`G1`, `G-Top`); gsn2x's any rest (`Goal`)."""
    if gsn2x_rules:
        return type_by_prefix(node_id)
    match = NODE_ID_RE.match(node_id) or GSN2X_ID_RE.match(node_id)
    return NodeType(match.group(1)) if match else None


def load_case(path: str | Path) -> tuple[Case | None, list[Finding]]:
    """Load and validate the safety case at `path`; the case is None when there are errors."""
    result = load_file(path)
    return result.case, result.findings


def load_case_text(text: str, path: str = "<input>") -> tuple[Case | None, list[Finding]]:
    """Like `load_case`, from text already in memory (`path` is only used in findings)."""
    result = load_text(text, path)
    return result.case, result.findings


def require_case(path: str | Path) -> Case:
    """Load a case and run the structural checks; raise `CaseError` on any error finding."""
    result = load_file(path)
    findings = list(result.findings)
    if result.partial is not None:
        findings += check_case(
            result.partial,
            skipped=result.skipped,
            invalid=result.invalid,
            gsn2x_rules=result.gsn2x_rules,
        )
    if result.case is None or has_errors(findings):
        raise CaseError([f for f in findings if f.severity == "error"])
    return result.case


def load_file(path: str | Path) -> LoadResult:
    """Read bytes from disk; an unreadable file is a CW001 finding, not an exception."""
    shown = str(path)
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        reason = exc.strerror or type(exc).__name__
        return LoadResult(None, None, [finding("CW001", f"cannot read file: {reason}", shown)])
    return load_bytes(data, shown)


def load_bytes(data: bytes, path: str = "<input>") -> LoadResult:
    """Decode UTF-8 (a leading BOM is allowed) and load."""
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        before = data[: exc.start]
        line = before.count(b"\n") + 1
        col = len(before) - (before.rfind(b"\n") + 1) + 1
        return LoadResult(
            None,
            None,
            [
                finding(
                    "CW002",
                    f"file is not valid UTF-8: byte 0x{data[exc.start]:02x} at offset {exc.start}",
                    path,
                    Mark(line=line, col=col),
                    "save the file as UTF-8",
                )
            ],
        )
    return load_text(text, path, hashlib.sha256(data).hexdigest())


def load_text(
    text: str,
    path: str = "<input>",
    digest: str | None = None,
    used_by: tuple[str, ...] = (),
    loaded: set[str] | None = None,
    monitor: MonitorConfig | None = None,
) -> LoadResult:
    """Compose, validate and build the case from `text`. `used_by`: the chain of modules that
    `uses` this one (empty for the case file itself), for cycles and file names in findings;
    `monitor`: the using case's, which a module without its own monitors under."""
    if digest is None:
        digest = hashlib.sha256(text.encode("utf-8", "surrogatepass")).hexdigest()
    tree, findings = compose(text, path, marks_name_file=bool(used_by))
    if tree is None:
        if not findings:
            findings = [finding("CW004", "the file is empty; expected a safety case", path, _TOP)]
        return LoadResult(None, None, findings)
    if tree.kind != "map":
        kind = "a list" if tree.kind == "seq" else f"a single value ({describe_value(tree.value)})"
        findings.append(
            finding(
                "CW004",
                f"the top level must be a mapping of node ids, got {kind}",
                path,
                tree.mark,
                "start with `module:`, `monitor:` and nodes such as `G1: {text: ...}`",
            )
        )
        return LoadResult(None, None, findings)
    return _Builder(path, digest, findings, used_by, loaded, monitor).build(tree)


class _Builder:
    def __init__(
        self,
        path: str,
        digest: str,
        findings: list[Finding],
        used_by: tuple[str, ...] = (),
        loaded: set[str] | None = None,
        inherited: MonitorConfig | None = None,
    ) -> None:
        self.inherited = inherited
        self.path = path
        self.digest = digest
        self.findings = findings
        self.valid = True
        self.invalid: set[str] = set()  # ids of nodes that failed validation
        self.used_by = used_by  # the modules that use this one (empty: the case file)
        # every module file of the case loaded so far (a module used twice is loaded once)
        self.loaded = loaded if loaded is not None else {str(Path(path).resolve())}
        self.bindings: dict[str, dict] = {}  # node id -> spi/hazard entries kept for gsn2x
        self.monitor_config: MonitorConfig | None = None  # contracts and ODDs resolve against it
        self.monitor_given = False
        self.gsn2x_rules = False  # a pure argument: read by gsn2x's rules (docs/gsn2x.md)
        self.modules: dict[str, set[str]] = {}
        self.raw_extends: list[RawExtends] = []
        self.extensions: list[tuple[str, list[RawExtends], Mark]] = []

    def add(self, code: str, message: str, mark: Mark, hint: str = "") -> None:
        self.findings.append(finding(code, message, self.path, mark, hint))

    def build(self, tree: YNode) -> LoadResult:
        entries = tree.entries()
        kept = _casewatch_info(entries.get("module"))
        self.bindings = kept.get("bindings", {})
        monitor_entry = entries.get("monitor") or kept.get("monitor")
        self.gsn2x_rules = monitor_entry is None and self.inherited is None
        module = self.module(entries.get("module"))
        if self.used_by and monitor_entry is not None:
            self.add(
                "CW060",
                "this module is used by another, and a case has one monitor: its "
                "own `monitor` block is ignored (the using case's channels, period and "
                "metrics apply; its contracts and ODDs are still checked against it)",
                monitor_entry.key_mark,
                "move what it sets into the using case's `monitor`, or delete the block here",
            )
        monitor = None if self.used_by and monitor_entry is None else self.monitor(monitor_entry)
        self.monitor_config = monitor if monitor is not None else self.inherited
        self.monitor_given = monitor_entry is not None or self.inherited is not None
        nodes: dict[str, Node] = {}
        skipped: dict[str, Mark] = {}
        for key, entry in entries.items():
            if key in RESERVED_KEYS:
                continue
            node_type = _gsn_node_type(entry.value) or node_type_of(key, self.gsn2x_rules)
            if node_type is None:
                skipped[key] = entry.key_mark
                rest = "" if self.gsn2x_rules else " followed by a digit, `-` or `_`"
                self.add(
                    "CW020",
                    f"{key!r} is not a node id: ids start with a type prefix (G, S, Sn, C, A, J, "
                    f"CG, CSn){rest}, or give `nodeType: Goal` "
                    f"(or Strategy, Solution, ...){did_you_mean(key, RESERVED_KEYS)}",
                    entry.key_mark,
                    "e.g. G1 (goal), S1 (strategy), Sn1 (solution), C1 (context), CSn1",
                )
                continue
            nodes[key] = self.node(key, node_type, entry.key_mark, entry.value)
        for node_id, kept_entries in self.bindings.items():
            if node_id not in nodes and kept_entries:
                first = next(iter(kept_entries.values()))
                self.add(
                    "CW030",
                    f"module.additionalInformation.casewatch.bindings names "
                    f"{node_id!r}, which is not a node of this file",
                    first.key_mark,
                    "bind the spi/hazard to an existing node, or drop it",
                )
        digest = self.digest
        if module is not None:
            self.modules[module.name] = set(nodes)
            extends = self.raw_extends
            if extends:
                mark = entries["module"].value.entries()["extends"].key_mark
                self.extensions.append((module.name, extends, mark))
        if module is not None and module.uses:
            digest = self.use_modules(module, nodes, skipped, entries["module"])
        if not self.used_by:
            self.extend(nodes)
        partial = Case(
            path=self.path,
            digest=digest,
            module=module or Module(name=""),
            monitor=monitor or MonitorConfig(channels=[]),
            nodes=nodes,
        )
        errors = has_errors(self.findings)
        case = partial if (not errors and module is not None) else None
        return LoadResult(
            case,
            partial,
            self.findings,
            skipped,
            self.invalid,
            self.gsn2x_rules,
            self.modules,
            self.extensions,
        )

    def use_modules(
        self, module: Module, nodes: dict[str, Node], skipped: dict[str, Mark], entry: YEntry
    ) -> str:
        """Load the modules `module` uses (gsn2x `uses:`, files relative to this one) into
        `nodes`; their findings name their own files. Returns the digest of the whole case:
        this file's and every used file's bytes."""
        digest = hashlib.sha256(self.digest.encode())
        uses_entry = entry.value.entries().get("uses")
        items = uses_entry.value.items() if uses_entry and uses_entry.value.kind == "seq" else []
        chain = (*self.used_by, str(Path(self.path).resolve()))
        for k, name in enumerate(module.uses):
            mark = items[k].mark if k < len(items) else entry.key_mark
            target = Path(self.path).parent / name
            try:  # a NUL byte or a 300-character name is no file name (ValueError, OSError)
                if not target.exists() and name in PACKAGED_MODULES:
                    target = PACKAGED_MODULES[name]  # shipped with casewatch (traffic-rules)
                target.resolve()
            except (OSError, ValueError) as exc:
                shown = repr(name) if len(name) <= 60 else f"{name[:57]!r}... ({len(name)} chars)"
                self.add(
                    "CW028",
                    f"module `uses` {shown}: not a usable file name "
                    f"({getattr(exc, 'strerror', None) or exc})",
                    mark,
                    "name a YAML file relative to this one, e.g. uses: [rules.gsn.yaml]",
                )
                continue
            if str(target.resolve()) in chain:
                self.add(
                    "CW028",
                    f"module `uses` {name}, which uses this module again (a cycle: "
                    f"{' -> '.join(Path(c).name for c in chain)} -> {target.name})",
                    mark,
                )
                continue
            if str(target.resolve()) in self.loaded:
                continue  # used by another module too (a diamond): its nodes are in already
            self.loaded.add(str(target.resolve()))
            try:
                data = target.read_bytes()
            except OSError as exc:
                self.add(
                    "CW028",
                    f"module `uses` {name}: cannot read {target}: {exc.strerror or exc}",
                    mark,
                    "the path is relative to this file",
                )
                continue
            try:
                text = data.decode("utf-8-sig")
            except UnicodeDecodeError as exc:
                self.add(
                    "CW028",
                    f"module `uses` {name}: {target} is not UTF-8 text (byte offset {exc.start})",
                    mark,
                    "save it as UTF-8",
                )
                continue
            used = load_text(
                text,
                str(target),
                hashlib.sha256(data).hexdigest(),
                chain,
                self.loaded,
                self.monitor_config,
            )
            self.findings.extend(used.findings)
            if used.partial is None:
                digest.update(hashlib.sha256(data).digest())
                continue
            digest.update(used.partial.digest.encode())  # its bytes and those of its uses
            self.invalid |= used.invalid
            skipped.update(used.skipped)
            for name, ids in used.modules.items():
                self.modules.setdefault(name, set()).update(ids)
            self.extensions += used.extensions
            for node_id, node in used.partial.nodes.items():
                if node_id in nodes:
                    first = nodes[node_id].mark
                    where = f"{first.path or self.path}:{first.line}"
                    self.findings.append(
                        finding(
                            "CW029",
                            f"node {node_id} is defined in {target.name} and already in {where}",
                            str(target),
                            node.mark,
                            "node ids are shared by every module of a case: rename one",
                        )
                    )
                    continue
                nodes[node_id] = node
        return digest.hexdigest()

    def extend(self, nodes: dict[str, Node]) -> None:
        """Apply gsn2x's `extends` of every module of the case: each developed element, an
        undeveloped node of the named module, is supported by the developing module's nodes.
        What gsn2x refuses (its C09, C10, V07) is CW065."""
        for name, extends, mark in self.extensions:
            for ext in extends:
                if ext.module not in self.modules:
                    self.add(
                        "CW065",
                        f"module {name} `extends` module {ext.module!r}, which is not part of "
                        f"this case{did_you_mean(ext.module, list(self.modules))}",
                        mark,
                        "add its file to `uses` (gsn2x wants it on its command line too)",
                    )
                    continue
                for foreign, local in ext.develops.items():
                    problem = self.development_problem(name, ext.module, foreign, local, nodes)
                    if problem:
                        self.add("CW065", f"module {name} `extends` {ext.module}: {problem}", mark)
                        continue
                    nodes[foreign] = nodes[foreign].model_copy(
                        update={"supported_by": list(local), "undeveloped": False}
                    )

    def development_problem(
        self, name: str, other: str, foreign: str, local: list[str], nodes: dict[str, Node]
    ) -> str:
        """Why `foreign` of module `other` cannot be developed by `local` of module `name`."""
        if foreign not in self.modules[other]:
            return f"{foreign} is not a node of module {other}"
        if not nodes[foreign].undeveloped:
            return f"{foreign} is not undeveloped, so another module cannot develop it"
        strangers = [i for i in local if i not in self.modules.get(name, set())]
        if strangers:
            return f"{strangers[0]} (to develop {foreign}) is not a node of module {name}"
        return ""

    # -- reserved blocks -------------------------------------------------------------------

    def module(self, entry: YEntry | None) -> Module | None:
        if entry is None and (self.used_by or self.gsn2x_rules):
            # gsn2x: `module` is optional; the file names the module (`min.gsn.yaml` -> min)
            return Module(name=Path(self.path).stem.removesuffix(".gsn") or "case")
        if entry is None:
            self.add(
                "CW010",
                "missing `module` block",
                Mark(line=1, col=1),
                "add e.g. `module: {name: ego-a-to-b, brief: what this case argues}`",
            )
            return None
        plain = to_plain(entry.value)
        extra: dict = {}
        if self.gsn2x_rules and isinstance(plain, dict):
            # gsn2x keeps any further module key as information (shown in the legend)
            extra = {k: plain.pop(k) for k in list(plain) if k not in MODULE_KEYS}
        raw = self.validate(
            RawModule,
            entry.value,
            entry.key_mark,
            "`module`",
            {(): MODULE_KEYS},
            plain=plain,
        )
        if not isinstance(raw, RawModule):
            return None
        self.raw_extends = raw.extends or []
        gsn = {k: v for k in GSN_MODULE_ATTRIBUTES if (v := getattr(raw, k)) is not None}
        if raw.extends is not None:
            gsn["extends"] = [e.model_dump() for e in raw.extends]
        gsn.update(extra)
        info = gsn.get("additionalInformation")
        if isinstance(info, dict) and "casewatch" in info:  # read as monitor and bindings
            rest = {k: v for k, v in info.items() if k != "casewatch"}
            if rest:
                gsn["additionalInformation"] = rest
            else:
                del gsn["additionalInformation"]
        return Module(name=raw.name, brief=raw.brief, uses=raw.uses, gsn=gsn)

    def monitor(self, entry: YEntry | None) -> MonitorConfig | None:
        if entry is None:
            self.add(
                "CW011",
                "no `monitor` block: the case is checked as a pure argument, and there is "
                "nothing to judge at run time",
                Mark(line=1, col=1),
                "to monitor it, add e.g. `monitor: {channels: [lav, tfuse], period: 0.1s}`",
            )
            return None
        levels = {
            (): MONITOR_KEYS,
            ("metrics",): METRIC_KEYS,
            ("scoring",): tuple(ScoringParams.model_fields),
        }
        raw = self.validate(RawMonitor, entry.value, entry.key_mark, "`monitor`", levels)
        if not isinstance(raw, RawMonitor):
            return None
        return MonitorConfig(
            channels=raw.channels,
            period=raw.period,
            signals=raw.signals,
            metrics=raw.metrics,
            coverage=raw.coverage,
            merge_gap=raw.merge_gap,
            min_duration=raw.min_duration,
            topics=raw.topics,
            scoring=raw.scoring,
            mark=entry.key_mark,
        )

    # -- nodes -----------------------------------------------------------------------------

    def node(self, node_id: str, node_type: NodeType, mark: Mark, value: YNode) -> Node:
        where = f"node {node_id}"
        if self.gsn2x_rules and value.kind == "scalar" and value.value is None:
            value = YNode("map", {}, value.mark, value.content_mark)  # `C1:` as `C1: {}`
        kept = self.bindings.get(node_id)
        if kept and value.kind == "map":  # spi/hazard kept for gsn2x in the module block
            value = YNode("map", {**value.entries(), **kept}, value.mark, value.content_mark)
        plain = to_plain(value)
        entries = value.entries() if value.kind == "map" else {}
        if isinstance(plain, dict):
            misplaced = (
                (
                    "spi",
                    node_type is not NodeType.SOLUTION,
                    "CW021",
                    "`spi` binds evidence to an SPI and belongs on a solution (Sn) node",
                ),
                (
                    "hazard",
                    node_type is not NodeType.COUNTER_SOLUTION,
                    "CW022",
                    "`hazard` belongs on a counter-solution (CSn) node",
                ),
                (
                    "contract",
                    node_type is not NodeType.SOLUTION,
                    "CW021",
                    "`contract` binds evidence to an assume-guarantee contract and belongs on "
                    "a solution (Sn) node",
                ),
                (
                    "odd",
                    node_type is not NodeType.CONTEXT,
                    "CW009",
                    "`odd` states an Operational Design Domain and belongs on a context (C) "
                    "node that a goal names in `inContextOf`",
                ),
                (
                    "challenges",
                    node_type not in COUNTER_TYPES,
                    "CW023",
                    "only counter nodes (CG, CSn) challenge a claim",
                ),
            )
            for key, wrong, code, why in misplaced:
                if key in plain and wrong:
                    self.add(
                        code, f"{where} is a {_type_name(node_type)}: {why}", entries[key].key_mark
                    )
                    del plain[key]
        if isinstance(plain, dict) and "spi" in plain and "contract" in plain:
            self.add(
                "CW018",
                f"{where} has both `spi` and `contract`: a solution is bound to one of them",
                entries["contract"].key_mark,
                "keep the contract (an assume-guarantee pair) or the SPI",
            )
            del plain["contract"]
        layers = self.layers(where, plain, entries) if isinstance(plain, dict) else {}
        levels = {
            (): NODE_KEYS,
            ("spi",): SPI_KEYS,
            ("hazard",): HAZARD_KEYS,
            ("contract",): CONTRACT_KEYS,
        }
        model = RawGsn2xNode if self.gsn2x_rules else RawNode
        raw = self.validate(model, value, mark, where, levels, plain=plain)
        key_marks = {k: e.key_mark for k, e in entries.items()}
        ref_marks = {rel: _ref_marks(entries[rel].value) for rel in RELATIONS if rel in entries}
        for written, at in list(ref_marks.get("challenges", {}).items()):
            if (relation := split_relation(written)) is not None:  # found again as `A -> B`
                ref_marks["challenges"].setdefault(f"{relation[0]} -> {relation[1]}", at)
        if isinstance(raw, RawNode):
            challenged, relations = _split_challenges(raw.challenges)
            return Node(
                id=node_id,
                type=node_type,
                text=raw.text,
                supported_by=raw.supportedBy,
                in_context_of=raw.inContextOf,
                challenges=challenged,
                challenged_relations=relations,
                undeveloped=raw.undeveloped,
                url=raw.url,
                spi=self.spi(raw, entries),
                hazard=self.hazard(node_id, raw, entries),
                contract=self.contract(node_id, raw, entries),
                odd=self.odd(node_id, raw, entries),
                gsn={
                    **{k: v for k in GSN_NODE_ATTRIBUTES if (v := getattr(raw, k)) is not None},
                    **layers,
                },
                mark=mark,
                key_marks=key_marks,
                ref_marks=ref_marks,
            )
        # Best effort, so the graph checks can still run; the case is already marked invalid.
        self.invalid.add(node_id)
        lenient = plain if isinstance(plain, dict) else {}
        text = lenient.get("text")
        challenged, relations = _split_challenges(_lenient_ids(lenient.get("challenges")))
        return Node(
            id=node_id,
            type=node_type,
            text=text if isinstance(text, str) else "",
            supported_by=_lenient_ids(lenient.get("supportedBy")),
            in_context_of=_lenient_ids(lenient.get("inContextOf")),
            challenges=challenged,
            challenged_relations=relations,
            undeveloped=lenient.get("undeveloped") is True,
            mark=mark,
            key_marks=key_marks,
            ref_marks=ref_marks,
        )

    def layers(self, where: str, plain: dict, entries: dict) -> dict:
        """Take gsn2x's extra attributes (its layers, `gsn2x -l layer1`) out of `plain`.

        In a pure argument every key gsn2x does not read is a layer; one that looks like a
        misspelt attribute or a binding key is kept too, with a CW063 warning. In a monitored
        case a layer must be text and must not look like a typo or a binding key (those stay
        CW013 errors: a misspelt `spi` would leave evidence silently unmonitored)."""
        layers: dict = {}
        for key in [k for k in plain if k not in NODE_KEYS]:
            hint = did_you_mean(key, NODE_KEYS)
            suspicious = bool(hint) or key in BINDING_KEYS
            if self.gsn2x_rules:
                layers[key] = plain.pop(key)
                if suspicious:
                    why = hint[2:] or f"`{key}` belongs inside `spi`, `hazard` or `contract`"
                    self.add(
                        "CW063",
                        f"{where}: `{key}` is no gsn2x attribute, so gsn2x and casewatch keep it "
                        f"as a layer; {why}",
                        entries[key].key_mark,
                    )
            elif isinstance(plain[key], str) and not suspicious:
                layers[key] = plain.pop(key)
        return layers

    def spi(self, raw: RawNode, entries: dict) -> SpiBinding | None:
        if raw.spi is None:
            return None
        spi_entries = entries["spi"].value.entries()
        formula_key = "stl" if raw.spi.stl is not None else "signal"
        return SpiBinding(
            signal=raw.spi.signal,
            threshold=raw.spi.threshold,
            for_seconds=raw.spi.for_,
            stl=raw.spi.stl,
            merge_gap=raw.spi.merge_gap,
            min_duration=raw.spi.min_duration,
            warn=raw.spi.warn,
            mark=entries["spi"].key_mark,
            formula_mark=spi_entries[formula_key].value.content_mark,
        )

    def hazard(self, node_id: str, raw: RawNode, entries: dict) -> HazardBinding | None:
        if raw.hazard is None:
            return None
        h = raw.hazard
        hazard_entries = entries["hazard"].value.entries()
        if h.use is None:
            return HazardBinding(
                when=h.when or "",
                merge_gap=h.merge_gap,
                min_duration=h.min_duration,
                warn=h.warn,
                mark=entries["hazard"].key_mark,
                formula_mark=hazard_entries["when"].value.content_mark,
            )
        use_mark = hazard_entries["use"].value.content_mark
        found = self._instantiate(node_id, h.use, h.params, hazard_entries, use_mark, RULES)
        if found is None:
            return None
        template, values, texts = found
        data = template.data
        return HazardBinding(
            when=texts["when"],
            use=template.name,
            params=values,
            from_library=True,
            merge_gap=h.merge_gap if h.merge_gap is not None else data.get("merge_gap"),
            min_duration=(
                h.min_duration if h.min_duration is not None else data.get("min_duration")
            ),
            warn=h.warn,
            mark=entries["hazard"].key_mark,
            formula_mark=use_mark,
        )

    def _instantiate(
        self, node_id: str, use: str, params: dict, keyed: dict, use_mark: Mark, library: str
    ) -> tuple[Template, dict, dict[str, str]] | None:
        """A library entry (`use:`) expanded against this file's monitor (or the using
        case's); None after a CW008 (none when the monitor block is invalid: reported already)."""
        monitor = self.monitor_config
        what = "contract" if library == LIBRARY else "rule"
        if monitor is None:
            if not self.monitor_given:
                self.add(
                    "CW008",
                    f"node {node_id}: a library {what} needs the `monitor` block "
                    "of its file (its channels, period and signals)",
                    use_mark,
                )
            self.invalid.add(node_id)
            return None
        try:
            return instantiate(
                use, dict(params), list(monitor.channels), monitor.signals, monitor.period, library
            )
        except ContractError as exc:
            self.add(
                "CW008", f"node {node_id}: {exc}", self._param_mark(exc, keyed, use_mark), exc.hint
            )
            self.invalid.add(node_id)
            return None

    @staticmethod
    def _param_mark(exc: ContractError, keyed: dict, fallback: Mark) -> Mark:
        """Where a library error points: the offending parameter (its key for an unknown one,
        its value otherwise), else `fallback` (the `use:` value)."""
        if not exc.key.startswith("params") or "params" not in keyed:
            return fallback
        name = exc.key.partition(".")[2]
        params = keyed["params"].value.entries() if keyed["params"].value.kind == "map" else {}
        if name in params:
            return params[name].key_mark if exc.at_key else params[name].value.mark
        return keyed["params"].key_mark

    def contract(self, node_id: str, raw: RawNode, entries: dict) -> ContractBinding | None:
        """`contract:`, a library contract expanded with its parameters (CW008 when it cannot
        be), or a hand-written assume/guarantee pair."""
        if raw.contract is None:
            return None
        c = raw.contract
        keyed = entries["contract"].value.entries()
        mark = entries["contract"].key_mark

        def at(key: str) -> Mark:
            return keyed[key].value.content_mark if key in keyed else mark

        common = {
            "merge_gap": c.merge_gap,
            "min_duration": c.min_duration,
            "warn": c.warn,
            "mark": mark,
        }
        if c.use is None:
            return ContractBinding(
                guarantee=c.guarantee or "",
                assume=c.assume,
                guarantee_mark=at("guarantee"),
                assume_mark=at("assume"),
                **common,
            )
        use_mark = at("use")
        found = self._instantiate(node_id, c.use, c.params, keyed, use_mark, LIBRARY)
        if found is None:
            return None
        _, values, texts = found
        assume, guarantee = texts.get("assume"), texts["guarantee"]
        own_guarantee, own_assume = c.guarantee is not None, c.assume is not None
        return ContractBinding(
            guarantee=c.guarantee if own_guarantee else guarantee,
            assume=c.assume if own_assume else assume,
            use=c.use,
            params=values,
            guarantee_mark=at("guarantee") if own_guarantee else use_mark,
            assume_mark=at("assume") if own_assume else use_mark,
            guarantee_from_library=not own_guarantee,
            assume_from_library=not own_assume and assume is not None,
            **common,
        )

    def odd(self, node_id: str, raw: RawNode, entries: dict) -> OddSpec | None:
        """`odd:` on a context: a file (relative to this one) or an inline mapping; CW009 when
        it cannot be used."""
        if raw.odd is None:
            return None
        monitor = self.monitor_config
        signals = None
        if monitor is not None and monitor.channels:
            signals = set(available_signals(monitor.channels, monitor.signals))
        mark = entries["odd"].value.content_mark
        try:
            if isinstance(raw.odd, str):
                return read_odd_file(Path(self.path).parent / raw.odd, signals)
            return parse_odd(raw.odd, "", signals)
        except OddError as exc:
            self.add(
                "CW009",
                f"node {node_id}: `odd`: {exc}",
                mark,
                "docs/odd.md: odd: {attributes: {environment.weather: [clear, rain]}} or "
                "odd: accepted-odd.yaml",
            )
            self.invalid.add(node_id)
            return None

    # -- pydantic errors -> findings -------------------------------------------------------

    def validate(
        self,
        model: type[BaseModel],
        tree: YNode,
        key_mark: Mark,
        where: str,
        levels: dict[tuple[str, ...], tuple[str, ...]],
        plain: object = None,
    ) -> BaseModel | None:
        data = to_plain(tree) if plain is None else plain
        try:
            return model.model_validate(data)
        except ValidationError as exc:
            for error in exc.errors(include_url=False):
                self.findings.append(self.error_finding(error, tree, key_mark, where, levels))
            return None

    def error_finding(
        self,
        error: Any,  # pydantic's ErrorDetails
        tree: YNode,
        container_mark: Mark,
        where: str,
        levels: dict[tuple[str, ...], tuple[str, ...]],
    ) -> Finding:
        kind = error["type"]
        ctx = error.get("ctx") or {}
        loc = list(error["loc"])
        if "field" in ctx:
            loc.append(ctx["field"])
        # Our custom errors name the offending item by key (mappings) and/or index (lists).
        candidates = [[*loc, ctx[k]] for k in ("key", "index") if k in ctx] or [loc]
        for attempt in candidates:
            key_mark, value_mark, names, found = _locate(tree, container_mark, attempt)
            if found:
                break
        keypath = _join(names)
        code = _CODE_BY_ERROR.get(kind, "CW012")
        if kind == "extra_forbidden":
            key = names[-1]
            allowed = levels.get(tuple(n for n in names[:-1] if not n.startswith("[")), ())
            parent = _join(names[:-1])
            under = f" under `{parent}`" if parent else ""
            message = f"unknown key {key!r} in {where}{under}{did_you_mean(key, allowed)}"
            hint = f"allowed keys: {', '.join(allowed)}" if allowed else ""
            return finding(code, message, self.path, key_mark, hint)
        if kind == "missing":
            return finding(
                code,
                f"{where} is missing the required key `{keypath}`",
                self.path,
                key_mark if not found else value_mark,
            )
        mark = value_mark if found else key_mark
        subject = f"{where}, `{keypath}`" if keypath else where
        if code != "CW012":
            return finding(code, f"{subject}: {error['msg']}", self.path, mark)
        got = ctx.get("got") or describe_value(error.get("input"))
        if kind in _BOUND_ERRORS and len(names) == 2 and names[0] == "metrics":
            message = (
                f"{subject} must be a number in {bounds_text(names[1])}, got {got} (the bounds "
                "of every metric parameter: docs/safety-case-language.md, `metrics:`)"
            )
        elif kind in _OWN_MESSAGES:
            message = f"{subject}: {error['msg']}"
        elif names and names[0] in RELATIONS and kind in ("list_type", "string_type"):
            expected = "a node id" if len(names) > 1 else "a node id or a list of node ids"
            message = f"{subject} must be {expected}, got {got}"
        elif kind in _EXPECTED:
            message = f"{subject} must be {_EXPECTED[kind]}, got {got}"
        else:
            reason = str(error.get("msg", "invalid value"))
            reason = reason.replace("Input should be", "should be").replace("Value error, ", "")
            message = f"{subject} {reason}, got {got}"
        return finding(code, message, self.path, mark)


def _locate(
    tree: YNode, container_mark: Mark, loc: list[object]
) -> tuple[Mark, Mark, list[str], bool]:
    """Follow a pydantic error location through the positioned tree.

    Returns (mark of the last key reached, mark of the last value reached, readable key path,
    whether the whole location exists in the YAML)."""
    node = tree
    key_mark = container_mark
    value_mark = tree.mark
    names: list[str] = []
    for part in loc:
        if node.kind == "map" and isinstance(part, str) and part in node.entries():
            entry = node.entries()[part]
            key_mark, node = entry.key_mark, entry.value
            value_mark = node.mark
            names.append(part)
        elif node.kind == "seq" and isinstance(part, int) and 0 <= part < len(node.items()):
            node = node.items()[part]
            key_mark = value_mark = node.mark
            names.append(f"[{part}]")
        else:
            if isinstance(part, str) and not part.startswith("function-"):
                names.append(part)
            return key_mark, value_mark, names, False
    return key_mark, value_mark, names, True


def _join(names: list[str]) -> str:
    """`["spi", "threshold"]` -> `spi.threshold`; `["channels", "[1]"]` -> `channels[1]`."""
    out = ""
    for name in names:
        out += name if (name.startswith("[") or not out) else "." + name
    return out


def _ref_marks(value: YNode) -> dict[str, Mark]:
    if value.kind == "scalar" and isinstance(value.value, str):
        return {value.value: value.mark}
    out: dict[str, Mark] = {}
    if value.kind == "seq":
        for item in value.items():
            if item.kind == "scalar" and isinstance(item.value, str):
                out.setdefault(item.value, item.mark)
    return out


def _gsn_node_type(value: YNode) -> NodeType | None:
    """The type gsn2x's `nodeType` names, for an id without a type prefix."""
    if value.kind != "map" or "nodeType" not in value.entries():
        return None
    name = value.entries()["nodeType"].value.value
    prefix = GSN_NODE_TYPES.get(name) if isinstance(name, str) else None
    return NodeType(prefix) if prefix else None


def _casewatch_info(entry: YEntry | None) -> dict:
    """What `casewatch export-gsn` keeps for itself in `module.additionalInformation.casewatch`
    (gsn2x shows it in the legend and ignores it otherwise): the `monitor` entry and, per node,
    its `spi`/`hazard` entries, as positioned YAML so findings point into the file."""
    if entry is None or entry.value.kind != "map":
        return {}
    info = entry.value.entries().get("additionalInformation")
    if info is None or info.value.kind != "map" or "casewatch" not in info.value.entries():
        return {}
    kept = info.value.entries()["casewatch"].value
    if kept.kind != "map":
        return {}
    out: dict = {}
    if "monitor" in kept.entries():
        out["monitor"] = kept.entries()["monitor"]
    bindings = kept.entries().get("bindings")
    if bindings is not None and bindings.value.kind == "map":
        out["bindings"] = {
            node_id: {k: e for k, e in b.value.entries().items() if k in KEPT_NODE_KEYS}
            for node_id, b in bindings.value.entries().items()
            if b.value.kind == "map"
        }
    return out


def _split_challenges(targets: list[str]) -> tuple[list[str], list[tuple[str, str]]]:
    """gsn2x's `challenges` names a node (`G2`) or a relation (`G2 -> CG1`): split the two."""
    nodes: list[str] = []
    relations: list[tuple[str, str]] = []
    for target in targets:
        relation = split_relation(target)
        if relation is None:
            nodes.append(target)
        else:
            relations.append(relation)
    return nodes, relations


def _lenient_ids(raw: object) -> list[str]:
    if isinstance(raw, str):
        return [raw]
    if isinstance(raw, list):
        return [x for x in raw if isinstance(x, str)]
    return []


def _type_name(node_type: NodeType) -> str:
    return node_type.name.lower().replace("_", "-")
