"""Structure-aware hypothesis strategies for the fuzz corpus (issue 23): mutations of the
reference safety case and of bundled frames, the way a hostile user would write them.

A case mutation works on the reference case as a plain YAML tree (delete a node or a key, rewire
a relation, swap in a hostile formula, threshold, duration, channel set or metric parameter); a
stream mutation works on the first frames of a bundled drive as JSON values and lines (drop,
duplicate, reorder, poison a field, break a line, nest it deeply, change the header, compress
and cut the file short).
"""

from __future__ import annotations

import copy
import gzip
import json
from functools import cache
from pathlib import Path

import yaml
from hypothesis import strategies as st

REPO = Path(__file__).resolve().parents[2]
REFERENCE = REPO / "examples" / "reference-case.yaml"
BUNDLED = REPO / "examples" / "data" / "highway-tailgating.jsonl.gz"
CHANNELS = ["lav", "tfuse"]

# -- safety cases --------------------------------------------------------------------------------

FORMULAS = [
    "1 > 0",
    "els >= 1_0",
    "els >= \u0661",
    "els >= 1e400",
    "once[0:1e300s] els > 0",
    "once[0:0.15] els > 0",
    "historically[0:1000000h] (els >= 0.6)",
    "eventually[0:1s] els > 0",
    "els__lav__tfuse >= 0.5",
    "ss__tfuse__lav < 0.2",
    "(" * 300 + "els" + ")" * 300 + " > 0",
    "not " * 300 + "els > 0",
    "els / 0 > 1",
    "els / (els - els) > 1",
    "abs(els) > 1",
    " and ".join(["els > 0"] * 200),
    "prev prev els > 0",
    "els since[0:1] ocs > 0",
    "\u00fcn\u00efc\u00f6d\u00e9 > 1",
    "els\x00 > 1",
    "",
    " ",
    "els >",
    "els == 0.5",
    "a__b > 0",
    "speed > 20",
    "ppcs__lav >= 0.8 implies ss >= 0.9",
]
THRESHOLDS = [
    ">= 0.6",
    ">= 1_0",
    ">= \u0661",
    "=> 1",
    ">= 1e400",
    "> 1e308",
    "<= .5",
    0.6,
    None,
    True,
    ">= nan",
    "<0",
]
DURATIONS = [
    "1s",
    "0",
    "-1s",
    "1e300s",
    "1e-300s",
    "0.15s",
    "inf",
    1e300,
    True,
    "300ms",
    ".5min",
    None,
    [1],
]
PERIODS = ["0.1s", "0.05s", "0", "-0.1", "1e-12s", 1e300, "100ms", "0.3s", 0.1, "1h", "x"]
CHANNEL_SETS = [
    ["lav", "tfuse"],
    ["chA", "Apollo7"],
    ["lav"],
    ["lav", "lav"],
    ["lav", "tf__use"],
    ["a_", "b"],
    ["lav", "tfuse", "third"],
    [],
    "lav",
    [1, 2],
    ["lav", "TFUSE"],
]
METRIC_VALUES = [
    0,
    -1,
    1e300,
    float("inf"),
    float("nan"),
    True,
    "x",
    10**12,
    0.5,
    2,
    10001,
    "1e-1",
    None,
    [0.5],
]
NODE_KEYS = [
    "text",
    "supportedBy",
    "inContextOf",
    "challenges",
    "undeveloped",
    "spi",
    "hazard",
    "url",
]
SCALARS = [None, True, 0, -1, 1e308, "", "x", "\u202e", [], {}, "G1", ["G1", "G1"]]


@cache
def reference_tree() -> dict:
    return yaml.safe_load(REFERENCE.read_text())


def _node_ids(tree: dict) -> list[str]:
    return [k for k in tree if k not in ("module", "monitor")]


@st.composite
def case_mutation(draw, tree: dict) -> None:
    """Apply one mutation to `tree` in place."""
    ids = _node_ids(tree) or ["G1"]
    some_id = st.sampled_from([*ids, "G99", "X1", "CSn1", "C1"])
    kind = draw(
        st.sampled_from(
            [
                "delete-node",
                "delete-key",
                "rewire",
                "add-support",
                "formula",
                "threshold",
                "duration",
                "period",
                "channels",
                "metric",
                "node-scalar",
                "rename",
                "monitor-key",
            ]
        )
    )
    node_id = draw(st.sampled_from(ids))
    node = tree.get(node_id)
    if kind == "delete-node":
        tree.pop(node_id, None)
    elif kind == "delete-key" and isinstance(node, dict) and node:
        node.pop(draw(st.sampled_from(sorted(node))), None)
    elif kind == "rewire" and isinstance(node, dict):
        relation = draw(st.sampled_from(["supportedBy", "inContextOf", "challenges"]))
        node[relation] = draw(st.lists(some_id, max_size=3))
    elif kind == "add-support" and isinstance(node, dict):
        node["supportedBy"] = [*(node.get("supportedBy") or []), draw(some_id)]
    elif kind == "formula":
        target = draw(st.sampled_from([i for i in ids if i.startswith(("Sn", "CSn"))] or ids))
        formula = draw(st.sampled_from(FORMULAS))
        key = "hazard" if target.startswith("CSn") else "spi"
        value = {"when": formula} if key == "hazard" else {"stl": formula}
        if isinstance(tree.get(target), dict):
            tree[target][key] = value
    elif kind == "threshold" and isinstance(node, dict):
        node["spi"] = {
            "signal": draw(st.sampled_from(["els", "ppcs", "x"])),
            "threshold": draw(st.sampled_from(THRESHOLDS)),
        }
    elif kind == "duration" and isinstance(node, dict):
        binding = node.get("spi") if isinstance(node.get("spi"), dict) else None
        key = draw(st.sampled_from(["for", "merge_gap", "min_duration"]))
        if binding is not None:
            binding[key] = draw(st.sampled_from(DURATIONS))
    elif kind == "period":
        _monitor(tree)["period"] = draw(st.sampled_from(PERIODS))
    elif kind == "channels":
        _monitor(tree)["channels"] = draw(st.sampled_from(CHANNEL_SETS))
    elif kind == "metric":
        metrics = _monitor(tree).setdefault("metrics", {})
        if isinstance(metrics, dict):
            name = draw(st.sampled_from([*sorted(metrics), "max_gap", "els_window", "junk"]))
            metrics[name] = draw(st.sampled_from(METRIC_VALUES))
    elif kind == "node-scalar":
        tree[node_id] = draw(st.sampled_from(SCALARS))
    elif kind == "rename" and node_id in tree:
        tree[draw(st.sampled_from(["G1.x", "X1", "CSn9", "Sn1", "g1", "G1"]))] = tree.pop(node_id)
    elif kind == "monitor-key":
        key = draw(st.sampled_from(["merge_gap", "min_duration", "signals", "coverage", "junk"]))
        _monitor(tree)[key] = draw(st.sampled_from([*DURATIONS, {"speed": None}, ["els"]]))


def _monitor(tree: dict) -> dict:
    if not isinstance(tree.get("monitor"), dict):
        tree["monitor"] = {}
    return tree["monitor"]


@st.composite
def mutated_cases(draw) -> str:
    """The reference case with one to four mutations, as YAML text."""
    tree = copy.deepcopy(reference_tree())
    for _ in range(draw(st.integers(1, 4))):
        draw(case_mutation(tree))
    return yaml.safe_dump(tree, sort_keys=False, allow_unicode=True)


# -- streams -------------------------------------------------------------------------------------

FIELD_PATHS = [
    ("t",),
    ("channels",),
    ("channels", "lav"),
    ("channels", "lav", "ego"),
    ("channels", "lav", "ego", "x"),
    ("channels", "tfuse", "ego", "yaw"),
    ("channels", "tfuse", "ego", "length"),
    ("channels", "lav", "plan"),
    ("channels", "lav", "plan", 0),
    ("channels", "lav", "objects"),
    ("channels", "lav", "objects", 0),
    ("channels", "lav", "objects", 0, "prediction"),
    ("channels", "lav", "objects", 0, "x"),
    ("channels", "lav", "objects", 0, "id"),
    ("channels", "tfuse", "objects", 0, "polygon"),
    ("signals",),
    ("signals", "speed_limit"),
]
HOSTILE = [
    None,
    True,
    "ten",
    1e308,
    -1e308,
    0,
    -5,
    1e-7,
    2**64,
    [],
    {},
    [[0, 1]],
    [[0, 1, 2], [0, 1, 2]],
    [[-1, 0, 0]],
    [[0, 0], [0, 0], [0, 0]],
    "\u202e",
    [[[[[[[[[[[[1]]]]]]]]]]]],
    {"x": 1},
]
RAW_LINES = [
    "",
    "{",
    "[" * 5000,
    "null",
    "42",
    '"x"',
    '{"t": NaN, "channels": {}}',
    '{"t": Infinity}',
    " " * 70_000 + "{}",
    '{"header": {"period": 0.1}}',
    '{"t": 1e999, "channels": {}}',
    "\u2028{}",
]


@cache
def bundled_rows(count: int = 80) -> tuple[str, ...]:
    """The header and the first `count` frames of a bundled drive, as JSON lines."""
    text = gzip.decompress(BUNDLED.read_bytes()).decode()
    return tuple(text.splitlines()[: count + 1])


def _set_path(value: object, path: tuple, new: object) -> None:
    for step in path[:-1]:
        if not _has(value, step):
            return
        value = value[step]  # type: ignore[index]
    if isinstance(value, dict) or _has(value, path[-1]):
        value[path[-1]] = new  # type: ignore[index]


def _has(value: object, step: object) -> bool:
    if isinstance(value, dict):
        return step in value
    return isinstance(value, list) and isinstance(step, int) and step < len(value)


@st.composite
def stream_mutation(draw, rows: list[object]) -> None:
    """Apply one mutation to `rows` (decoded JSON values, or raw text lines) in place."""
    if not rows:
        return
    i = draw(st.integers(0, len(rows) - 1))
    kind = draw(
        st.sampled_from(
            [
                "drop",
                "duplicate",
                "swap",
                "field",
                "time",
                "dropout",
                "ghost-channel",
                "raw",
                "truncate-line",
                "header",
                "deep",
            ]
        )
    )
    row = rows[i]
    if kind == "drop":
        del rows[i]
    elif kind == "duplicate":
        rows.insert(i, copy.deepcopy(row))
    elif kind == "swap":
        j = draw(st.integers(0, len(rows) - 1))
        rows[i], rows[j] = rows[j], rows[i]
    elif kind == "field" and isinstance(row, dict):
        _set_path(row, draw(st.sampled_from(FIELD_PATHS)), draw(st.sampled_from(HOSTILE)))
    elif kind == "time" and isinstance(row, dict) and isinstance(row.get("t"), float | int):
        step = draw(st.sampled_from([1e-7, 0.0, -0.1, 0.04, 0.26, 0.6, 1000.0, 1e13]))
        for later in rows[i:]:
            if isinstance(later, dict) and isinstance(later.get("t"), float | int):
                later["t"] = later["t"] + step
    elif kind == "dropout" and isinstance(row, dict) and isinstance(row.get("channels"), dict):
        count = draw(st.integers(1, 30))  # a channel gone for a while
        name = draw(st.sampled_from(CHANNELS))
        for later in rows[i : i + count]:
            if isinstance(later, dict) and isinstance(later.get("channels"), dict):
                later["channels"].pop(name, None)
    elif kind == "ghost-channel" and isinstance(row, dict) and _has(row.get("channels"), "lav"):
        row["channels"]["ghost"] = copy.deepcopy(row["channels"]["lav"])
    elif kind == "raw":
        rows[i] = draw(st.sampled_from(RAW_LINES))
    elif kind == "truncate-line":
        text = row if isinstance(row, str) else json.dumps(row)
        rows[i] = text[: draw(st.integers(0, max(0, len(text) - 1)))]
    elif kind == "header":
        header = {"format": "casewatch-frames", "version": 1, "channels": CHANNELS, "period": 0.1}
        key = draw(st.sampled_from(["period", "channels", "format", "version", "meta"]))
        header[key] = draw(st.sampled_from([0.05, ["lav"], "other", 2, None, {"a": [1]}, 0.1]))
        rows.insert(draw(st.sampled_from([0, i])), {"header": header})
    elif kind == "deep":
        rows[i] = "[" * draw(st.sampled_from([900, 1025, 100_000])) + "]" * 10


@st.composite
def mutated_streams(draw) -> bytes:
    """The first bundled frames with one to five mutations, as the bytes of a stream file,
    sometimes gzip-compressed and cut short."""
    rows: list[object] = [json.loads(line) for line in bundled_rows()]
    for _ in range(draw(st.integers(1, 5))):
        draw(stream_mutation(rows))
    text = "\n".join(r if isinstance(r, str) else json.dumps(r) for r in rows) + "\n"
    data = text.encode("utf-8", "surrogatepass")
    form = draw(st.sampled_from(["plain", "plain", "gzip", "gzip-cut", "bad-utf8"]))
    if form == "gzip":
        return gzip.compress(data, mtime=0)
    if form == "gzip-cut":
        whole = gzip.compress(data, mtime=0)
        return whole[: draw(st.integers(0, len(whole) - 1))]
    if form == "bad-utf8":
        cut = draw(st.integers(0, len(data)))
        return data[:cut] + b"\xff\xfe" + data[cut:]
    return data


# -- issue 31: bags, topic mappings, library uses, ODD files, run and fleet folders ------------

#: Values a hostile mapping, ODD file or result.json puts where a number, text or list belongs.
HOSTILE_VALUES = [
    None,
    True,
    0,
    -1,
    -0.1,
    1e308,
    "nan",
    "inf",
    "1e400",
    10**401,
    "",
    "a\x00b",
    "x" * 300,
    [],
    {},
    [[[[[[1]]]]]],
    "\u202e",
    0.0,
]


@cache
def small_bag() -> tuple[bytes, str]:
    """The MCAP bytes and the topic mapping of the small end-to-end stream as a bag."""
    import contextlib
    import io
    import tempfile

    from casewatch.cli import main
    from tests.evaluator.streams import write_stream

    with tempfile.TemporaryDirectory() as tmp:
        stream = write_stream(Path(tmp) / "s.jsonl", frames=40)
        with contextlib.redirect_stderr(io.StringIO()):
            assert main(["convert", str(stream), "-o", str(Path(tmp) / "bag")]) == 0
        return (
            (Path(tmp) / "bag" / "bag.mcap").read_bytes(),
            (Path(tmp) / "bag.topics.yaml").read_text(),
        )


@st.composite
def mutated_bags(draw) -> bytes:
    """The small bag cut short, bit-flipped, with a length field or a type name overwritten."""
    data = bytearray(small_bag()[0])
    for _ in range(draw(st.integers(1, 3))):
        kind = draw(st.sampled_from(["cut", "flip", "length", "zero-run", "type"]))
        at = draw(st.integers(0, max(0, len(data) - 1)))
        if kind == "cut":
            del data[at:]
        elif kind == "flip" and data:
            data[at] ^= 1 << draw(st.integers(0, 7))
        elif kind == "length" and len(data) > at + 8:
            data[at : at + 8] = draw(
                st.sampled_from([b"\xff" * 8, b"\x00" * 8, b"\xff\xff\xff\x7f\x00\x00\x00\x00"])
            )
        elif kind == "zero-run":
            data[at : at + draw(st.integers(1, 64))] = b"\x00" * 8
        elif kind == "type":
            found = data.find(b"PredictedObjects")
            if found >= 0:
                data[found : found + 16] = b"TrackedObjects\x00\x00"
    return bytes(data)


MAPPING_PATHS = [
    ("ego",),
    ("ego", "length"),
    ("ego", "width"),
    ("channels",),
    ("channels", "lav"),
    ("channels", "lav", "odometry"),
    ("channels", "tfuse", "objects"),
    ("signals",),
    ("signals", "speed"),
    ("max_age",),
    ("max_delay",),
    ("time",),
    ("plan_time",),
    ("coverage",),
    ("meta",),
    ("junk",),
]
RAW_MAPPING_EDITS = [
    "ego: {length: 4.5, width: 1.8}\n",
    "x: &a [1]\ny: *a\n",
    "t: !!set {}\n",
    "  width: [1.8\n",
    "\t: tab\n",
    "max_age: 0\n",
    "max_age: " + "9" * 401 + "\n",
]


@st.composite
def mutated_mappings(draw) -> str:
    """The small bag's topic mapping with one to three edits: a key set to a hostile value or
    removed, or raw YAML (duplicate keys, aliases, tags, syntax errors) appended."""
    tree = yaml.safe_load(small_bag()[1])
    raw = ""
    for _ in range(draw(st.integers(1, 3))):
        path = draw(st.sampled_from(MAPPING_PATHS))
        kind = draw(st.sampled_from(["set", "set", "delete", "raw"]))
        if kind == "raw":
            raw += draw(st.sampled_from(RAW_MAPPING_EDITS))
            continue
        parent = tree
        for step in path[:-1]:
            parent = parent.get(step) if isinstance(parent, dict) else None
        if not isinstance(parent, dict):
            continue
        if kind == "delete":
            parent.pop(path[-1], None)
        else:
            parent[path[-1]] = draw(st.sampled_from(HOSTILE_VALUES))
    text = yaml.safe_dump(tree, sort_keys=False, allow_unicode=True, width=10_000)
    return text + raw


@st.composite
def mutated_uses(draw) -> tuple[str, dict[str, str]]:
    """A case that `uses` modules (files beside it): (case text, file name -> text). The
    modules may be missing, cyclic, hostile names, not YAML, or define a node twice."""
    from tests.evaluator.streams import SMALL_CASE

    name = draw(
        st.sampled_from(
            [
                "rules.gsn.yaml",
                "a\\0b.yaml",
                "x" * 300 + ".yaml",
                "traffic-rules",
                "../outside.yaml",
                "self.yaml",
                "",
                ".",
            ]
        )
    )
    module = draw(
        st.sampled_from(
            [
                "module: {name: rules}\n"
                "Sn9: {text: extra, spi: {signal: els, threshold: '>= 0.5'}}\n",
                "module: {name: rules, uses: [case.yaml]}\n",
                "module: {name: rules}\nSn1: {text: twice}\n",
                "module: {name: rules}\nmonitor: {channels: [a, b]}\n",
                ": not yaml [\n",
                "",
                "module: {name: rules}\nSn9: null\n",
                "module: {name: rules}\nG7: {text: " + "{" * 80 + "}" * 80 + "}\n",
            ]
        )
    )
    case = SMALL_CASE.replace("brief: One SPI and one hazard}", f'brief: x, uses: ["{name}"]}}')
    return case, {"rules.gsn.yaml": module, "self.yaml": case}


ODD_FILES = [
    "attributes: {environment.weather: [clear, rain]}\n",
    "attributes: {road.speed_limit: {min: 0, max: " + "9" * 401 + "}}\n",
    "attributes: {}\n",
    "attributes: {x: []}\n",
    "attributes: {x: {min: 5, max: 1}}\n",
    "attributes: {" + "a" * 300 + ": [1]}\n",
    'attributes: {w: ["a\\0b"]}\n',
    "[1, 2]\n",
    "attributes: {w: [clear]}\ncombinations: [[1, 2, 3]]\n",
    ": [\n",
    "",
    "attributes: {w: " + "[" * 70 + "]" * 70 + "}\n",
]


def json_paths(value: object, prefix: tuple = ()) -> list[tuple]:
    """Every path into a decoded JSON value (keys and list indices), pre-order."""
    out = [prefix]
    if isinstance(value, dict):
        for k, v in value.items():
            out += json_paths(v, (*prefix, k))
    elif isinstance(value, list):
        for i, v in enumerate(value[:3]):
            out += json_paths(v, (*prefix, i))
    return out


@st.composite
def result_mutation(draw, result: dict) -> None:
    """Set one to three values of a result.json (or summary.json) to hostile values, in place."""
    paths = [p for p in json_paths(result) if p]
    for _ in range(draw(st.integers(1, 3))):
        path = draw(st.sampled_from(paths))
        _set_path(
            result,
            path,
            draw(st.sampled_from([*HOSTILE_VALUES, "Infinity", "-Infinity", float("inf")])),
        )
