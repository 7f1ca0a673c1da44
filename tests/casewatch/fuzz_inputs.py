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
    "1 > 0", "els >= 1_0", "els >= \u0661", "els >= 1e400", "once[0:1e300s] els > 0",
    "once[0:0.15] els > 0", "historically[0:1000000h] (els >= 0.6)", "eventually[0:1s] els > 0",
    "els__lav__tfuse >= 0.5", "ss__tfuse__lav < 0.2", "(" * 300 + "els" + ")" * 300 + " > 0",
    "not " * 300 + "els > 0", "els / 0 > 1", "els / (els - els) > 1", "abs(els) > 1",
    " and ".join(["els > 0"] * 200), "prev prev els > 0", "els since[0:1] ocs > 0",
    "\u00fcn\u00efc\u00f6d\u00e9 > 1", "els\x00 > 1", "", " ", "els >", "els == 0.5",
    "a__b > 0", "speed > 20", "ppcs__lav >= 0.8 implies ss >= 0.9",
]  # fmt: skip
THRESHOLDS = [">= 0.6", ">= 1_0", ">= \u0661", "=> 1", ">= 1e400", "> 1e308", "<= .5", 0.6,
              None, True, ">= nan", "<0"]  # fmt: skip
DURATIONS = ["1s", "0", "-1s", "1e300s", "1e-300s", "0.15s", "inf", 1e300, True, "300ms",
             ".5min", None, [1]]  # fmt: skip
PERIODS = ["0.1s", "0.05s", "0", "-0.1", "1e-12s", 1e300, "100ms", "0.3s", 0.1, "1h", "x"]
CHANNEL_SETS = [["lav", "tfuse"], ["chA", "Apollo7"], ["lav"], ["lav", "lav"],
                ["lav", "tf__use"], ["a_", "b"], ["lav", "tfuse", "third"], [], "lav", [1, 2],
                ["lav", "TFUSE"]]  # fmt: skip
METRIC_VALUES = [0, -1, 1e300, float("inf"), float("nan"), True, "x", 10**12, 0.5, 2, 10001,
                 "1e-1", None, [0.5]]  # fmt: skip
NODE_KEYS = ["text", "supportedBy", "inContextOf", "challenges", "undeveloped", "spi", "hazard",
             "url"]  # fmt: skip
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
    kind = draw(st.sampled_from([
        "delete-node", "delete-key", "rewire", "add-support", "formula", "threshold", "duration",
        "period", "channels", "metric", "node-scalar", "rename", "monitor-key",
    ]))  # fmt: skip
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
        node["spi"] = {"signal": draw(st.sampled_from(["els", "ppcs", "x"])),
                       "threshold": draw(st.sampled_from(THRESHOLDS))}  # fmt: skip
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
    ("t",), ("channels",), ("channels", "lav"), ("channels", "lav", "ego"),
    ("channels", "lav", "ego", "x"), ("channels", "tfuse", "ego", "yaw"),
    ("channels", "tfuse", "ego", "length"), ("channels", "lav", "plan"),
    ("channels", "lav", "plan", 0), ("channels", "lav", "objects"),
    ("channels", "lav", "objects", 0), ("channels", "lav", "objects", 0, "prediction"),
    ("channels", "lav", "objects", 0, "x"), ("channels", "lav", "objects", 0, "id"),
    ("channels", "tfuse", "objects", 0, "polygon"), ("signals",), ("signals", "speed_limit"),
]  # fmt: skip
HOSTILE = [None, True, "ten", 1e308, -1e308, 0, -5, 1e-7, 2**64, [], {}, [[0, 1]],
           [[0, 1, 2], [0, 1, 2]], [[-1, 0, 0]], [[0, 0], [0, 0], [0, 0]], "\u202e",
           [[[[[[[[[[[[1]]]]]]]]]]]], {"x": 1}]  # fmt: skip
RAW_LINES = ["", "{", "[" * 5000, "null", "42", '"x"', '{"t": NaN, "channels": {}}',
             '{"t": Infinity}', " " * 70_000 + "{}", '{"header": {"period": 0.1}}',
             '{"t": 1e999, "channels": {}}', "\u2028{}"]  # fmt: skip


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
    kind = draw(st.sampled_from([
        "drop", "duplicate", "swap", "field", "time", "dropout", "ghost-channel", "raw",
        "truncate-line", "header", "deep",
    ]))  # fmt: skip
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
