"""Layered layout of a GSN safety case for the report's diagram.

The argument reads top-down, so the layout is the classic layered (Sugiyama-style) one:

1. `supportedBy` edges define layers (longest path from the root, so every edge points down);
   edges that skip layers get a dummy slot in every layer they pass, so they cannot run
   through a node.
2. Nodes within a layer are ordered by barycentre sweeps (down and up), keeping the order with
   the fewest edge crossings.
3. Context, assumption and justification nodes do not take part in layering: they are stacked
   in a column to the right of the node that puts them in context, and counter nodes in a column
   to the left of the node they challenge. A node and its side columns form one block.
4. Horizontal positions minimise the squared distance of each block to the mean of its
   neighbours, subject to the order and a minimum gap (isotonic regression, pool adjacent
   violators), alternating downward and upward passes.

Edges are routed so that they stay in free space: a vertical stub below the parent inside its
own column, a diagonal through the empty band between layers, and a vertical stub into the
child; side edges run through the empty gap between a node and its side column.
"""

from __future__ import annotations

import itertools
import textwrap
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import networkx as nx

from casewatch.evaluator.result import CaseInfo, CaseNode

FONT_SIZE = 12.0
#: Conservative mean glyph width for the sans-serif stack in the stylesheet (DejaVu Sans is the
#: widest common fallback at about 0.6 em); over-estimating only costs whitespace.
CHAR_WIDTH = 0.62 * FONT_SIZE
LINE_HEIGHT = 15.0
PAD = 9.0
SKEW = 14.0  # horizontal slant of a strategy parallelogram
LAYER_GAP = 64.0
NODE_GAP = 22.0
SIDE_GAP = 30.0  # between a node and its side column (room for the connecting elbow)
STACK_GAP = 12.0
DUMMY_WIDTH = 8.0
MARGIN = 16.0
MARKER = 16.0  # room for the A/J letter and the undeveloped diamond

SHAPES: dict[str, str] = {
    "G": "goal",
    "CG": "goal",
    "S": "strategy",
    "Sn": "solution",
    "CSn": "solution",
    "C": "context",
    "A": "assumption",
    "J": "justification",
}
COUNTER_TYPES = frozenset({"CG", "CSn"})


@dataclass(frozen=True)
class NodeBox:
    """A placed node: its bounding box (which holds everything drawn for it) and its text."""

    id: str
    type: str
    shape: str  # goal, strategy, solution, context, assumption, justification
    counter: bool
    undeveloped: bool
    x: float  # bounding box, top-left
    y: float
    w: float
    h: float
    shape_w: float  # the GSN shape itself (the bounding box may add room for markers)
    shape_h: float
    lines: tuple[str, ...]  # wrapped text lines
    subtitle: str  # e.g. "els >= 0.6" for an SPI, "" otherwise
    title: str  # the full text (tooltip)

    @property
    def cx(self) -> float:
        return self.x + self.shape_w / 2

    @property
    def cy(self) -> float:
        return self.y + self.shape_h / 2


@dataclass(frozen=True)
class Edge:
    source: str
    target: str
    kind: str  # supported_by, in_context_of, challenges
    points: tuple[tuple[float, float], ...]


@dataclass(frozen=True)
class Diagram:
    width: float
    height: float
    nodes: tuple[NodeBox, ...]
    edges: tuple[Edge, ...]


@dataclass
class _Size:
    shape: str
    w: float
    h: float
    shape_w: float
    shape_h: float
    lines: list[str]


def _wrap(text: str, chars: int, max_lines: int) -> list[str]:
    lines = textwrap.wrap(" ".join(text.split()), width=chars, break_long_words=True) or [""]
    if len(lines) > max_lines:
        lines = lines[:max_lines]
        last = lines[-1]
        lines[-1] = (last[: chars - 1] if len(last) >= chars else last) + "…"
    return lines


def _text_box(texts: Sequence[str], n_lines: int) -> tuple[float, float]:
    """Width of the longest of `texts` and height of `n_lines` lines."""
    longest = max(len(text) for text in texts)
    return longest * CHAR_WIDTH, n_lines * LINE_HEIGHT


def _header(node: CaseNode) -> str:
    """The first text line of a node: its id, and the counter mark for counter nodes."""
    return f"{node.id} · counter" if node.type in COUNTER_TYPES else node.id


def _size(node: CaseNode, subtitle: str) -> _Size:
    """Size a node's shape around its wrapped text; the header line holds id and markers."""
    shape = SHAPES.get(node.type, "goal")
    # Lines besides the wrapped text: id (and counter mark), SPI subtitle, status label.
    header = 2 + (1 if subtitle else 0)
    if shape == "solution":
        lines = _wrap(node.text, 15, 3)
        tw, th = _text_box([*lines, _header(node), subtitle], len(lines) + header)
        diameter = max(96.0, (tw**2 + th**2) ** 0.5 + 2)
        w = h = diameter
        sw = sh = diameter
    elif shape in ("assumption", "justification"):
        lines = _wrap(node.text, 26, 4)
        tw, th = _text_box([*lines, node.id], len(lines) + header)
        sw, sh = tw * 1.3 + PAD, th * 1.35 + PAD
        w, h = sw + MARKER, sh + MARKER
    else:
        chars = 26 if shape != "context" else 30
        lines = _wrap(node.text, chars, 6)
        tw, th = _text_box([*lines, _header(node), subtitle], len(lines) + header)
        sw = max(120.0, tw + 2 * PAD) + (2 * SKEW if shape == "strategy" else 0)
        sh = th + 2 * PAD
        w, h = sw, sh
    if node.undeveloped:
        h += MARKER
    return _Size(shape=shape, w=w, h=h, shape_w=sw, shape_h=sh, lines=lines)


def _side_anchors(case: CaseInfo) -> tuple[dict[str, str], dict[str, str]]:
    """Side node -> anchor, for contexts and counters.

    A node is a side node when nothing supports-by it, it supports nothing, and some main node
    puts it in context (or it challenges one). Anything else takes part in layering.
    """
    ids = {n.id for n in case.nodes}
    supported = {c for n in case.nodes for c in n.supported_by if c in ids}
    context_of: dict[str, str] = {}
    counter_of: dict[str, str] = {}
    for node in case.nodes:
        for ctx in node.in_context_of:
            if ctx in ids and ctx not in context_of:
                context_of[ctx] = node.id
    for node in case.nodes:
        if node.id == case.root_id or node.id in supported or node.supported_by:
            context_of.pop(node.id, None)
            continue
        targets = [t for t in node.challenges if t in ids]
        if targets and node.id not in context_of:
            counter_of[node.id] = targets[0]
    # An anchor must itself be placed in a layer; chains of side nodes fall back to layering.
    side = set(context_of) | set(counter_of)
    context_of = {k: v for k, v in context_of.items() if v not in side}
    counter_of = {k: v for k, v in counter_of.items() if v not in side}
    return context_of, counter_of


def _acyclic(graph: nx.DiGraph) -> nx.DiGraph:
    """Drop back edges (a checked case has none; a hand-edited result.json might)."""
    graph = graph.copy()
    while True:
        try:
            cycle = nx.find_cycle(graph)
        except nx.NetworkXNoCycle:
            return graph
        graph.remove_edge(*cycle[-1][:2])


def _crossings(upper: list[str], lower: list[str], edges: list[tuple[str, str]]) -> int:
    pos_u = {n: i for i, n in enumerate(upper)}
    pos_l = {n: i for i, n in enumerate(lower)}
    pairs = [(pos_u[a], pos_l[b]) for a, b in edges if a in pos_u and b in pos_l]
    count = 0
    for i, (a1, b1) in enumerate(pairs):
        for a2, b2 in pairs[i + 1 :]:
            if (a1 - a2) * (b1 - b2) < 0:
                count += 1
    return count


def _total_crossings(layers: list[list[str]], graph: nx.DiGraph) -> int:
    return sum(
        _crossings(
            layers[k], layers[k + 1], [(u, v) for u in layers[k] for v in graph.successors(u)]
        )
        for k in range(len(layers) - 1)
    )


def _order(layers: list[list[str]], graph: nx.DiGraph, sweeps: int = 8) -> list[list[str]]:
    """Barycentre heuristic, keeping the best ordering seen."""
    best = [list(layer) for layer in layers]
    best_count = _total_crossings(best, graph)
    current = [list(layer) for layer in layers]
    for sweep in range(sweeps):
        down = sweep % 2 == 0
        indices = range(1, len(current)) if down else range(len(current) - 2, -1, -1)
        for k in indices:
            ref = current[k - 1] if down else current[k + 1]
            pos = {n: i for i, n in enumerate(ref)}
            keyed = []
            for i, node in enumerate(current[k]):
                neighbours = graph.predecessors(node) if down else graph.successors(node)
                ps = [pos[m] for m in neighbours if m in pos]
                keyed.append((sum(ps) / len(ps) if ps else float(i), i, node))
            current[k] = [node for _, _, node in sorted(keyed)]
        count = _total_crossings(current, graph)
        if count < best_count:
            best, best_count = [list(layer) for layer in current], count
    return best


def _isotonic_place(desired: list[float], min_sep: list[float]) -> list[float]:
    """Positions closest (least squares) to `desired`, in order, `min_sep[i]` apart.

    With offsets o_i = sum of separations before i, y_i = x_i - o_i must be non-decreasing:
    an isotonic regression of desired_i - o_i, solved by pooling adjacent violators.
    """
    offsets = [0.0]
    for sep in min_sep:
        offsets.append(offsets[-1] + sep)
    target = [d - o for d, o in zip(desired, offsets, strict=True)]
    blocks: list[list[float]] = []  # [mean, count]
    for value in target:
        blocks.append([value, 1.0])
        while len(blocks) > 1 and blocks[-2][0] > blocks[-1][0]:
            mean2, n2 = blocks.pop()
            mean1, n1 = blocks.pop()
            blocks.append([(mean1 * n1 + mean2 * n2) / (n1 + n2), n1 + n2])
    fitted: list[float] = []
    for mean, count in blocks:
        fitted.extend([mean] * int(count))
    return [y + o for y, o in zip(fitted, offsets, strict=True)]


@dataclass
class _Item:
    """One slot in a layer: a main node with its side columns, or a dummy edge point."""

    id: str
    left: float  # extent left of the centre x
    right: float
    height: float
    left_column: list[str] = field(default_factory=list)
    right_column: list[str] = field(default_factory=list)


def _layers(case: CaseInfo, side: set[str]) -> tuple[nx.DiGraph, dict[str, int], dict]:
    """Main graph with dummy slots, layer of every slot, and the slot chain of each edge."""
    nodes = {n.id for n in case.nodes}
    graph = nx.DiGraph()
    for node in case.nodes:
        if node.id not in side:
            graph.add_node(node.id)
    for node in case.nodes:
        for child in node.supported_by:
            if child in nodes and child not in side and node.id not in side:
                graph.add_edge(node.id, child)
    graph = _acyclic(graph)
    layer_of: dict[str, int] = {}
    for node_id in nx.topological_sort(graph):
        preds = list(graph.predecessors(node_id))
        layer_of[node_id] = max((layer_of[p] + 1 for p in preds), default=0)
    routed = nx.DiGraph()
    routed.add_nodes_from(graph.nodes)
    chains: dict[tuple[str, str], list[str]] = {}
    for u, v in graph.edges:
        chain = [u]
        for k in range(layer_of[u] + 1, layer_of[v]):
            dummy = f"\x00{u}\x00{v}\x00{k}"
            layer_of[dummy] = k
            chain.append(dummy)
        chain.append(v)
        for a, b in itertools.pairwise(chain):
            routed.add_edge(a, b)
        chains[(u, v)] = chain
    return routed, layer_of, chains


def _initial_order(case: CaseInfo, routed: nx.DiGraph, layer_of: dict[str, int]) -> list[list[str]]:
    """Depth-first from the root in YAML order, so the sweeps start from a natural order."""
    depth = max(layer_of.values(), default=0) + 1
    layers: list[list[str]] = [[] for _ in range(depth)]
    seen: set[str] = set()
    rank = {n.id: i for i, n in enumerate(case.nodes)}

    def visit(start: str) -> None:
        stack = [start]
        while stack:
            node_id = stack.pop()
            if node_id in seen:
                continue
            seen.add(node_id)
            layers[layer_of[node_id]].append(node_id)
            children = sorted(routed.successors(node_id), key=lambda c: rank.get(c, -1))
            stack.extend(reversed(children))

    starts = [case.root_id] if case.root_id in routed else []
    starts += sorted((n for n in routed if routed.in_degree(n) == 0), key=lambda c: rank.get(c, -1))
    for start in [*starts, *routed]:
        visit(start)
    return layers


def layout_case(case: CaseInfo, subtitles: Mapping[str, str] | None = None) -> Diagram:
    """Place every node of `case` and route every edge; see the module docstring."""
    subtitles = subtitles or {}
    nodes = {n.id: n for n in case.nodes}
    sizes = {n.id: _size(n, subtitles.get(n.id, "")) for n in case.nodes}
    context_of, counter_of = _side_anchors(case)
    routed, layer_of, chains = _layers(case, set(context_of) | set(counter_of))
    layers = _order(_initial_order(case, routed, layer_of), routed)

    # Blocks: a main node with its side columns (counters left, contexts right).
    items: dict[str, _Item] = {}
    side_of: dict[str, str] = {}  # side node -> "left" or "right" column of its anchor
    for layer in layers:
        for node_id in layer:
            if node_id.startswith("\x00"):
                items[node_id] = _Item(node_id, DUMMY_WIDTH / 2, DUMMY_WIDTH / 2, 0.0)
                continue
            size = sizes[node_id]
            left_column = [c for c in nodes if counter_of.get(c) == node_id]
            right_column = [c for c in nodes if context_of.get(c) == node_id]
            if not left_column and len(right_column) > 1:
                # Balance a long context column over both sides.
                half = (len(right_column) + 1) // 2
                right_column, left_column = right_column[:half], right_column[half:]
            side_of.update({c: "left" for c in left_column})
            side_of.update({c: "right" for c in right_column})
            left = size.shape_w / 2
            right = size.w - size.shape_w / 2
            if left_column:
                left += SIDE_GAP + max(sizes[c].w for c in left_column)
            if right_column:
                right += SIDE_GAP + max(sizes[c].w for c in right_column)
            stack_h = [
                sum(sizes[c].h for c in column) + STACK_GAP * (len(column) - 1)
                for column in (left_column, right_column)
                if column
            ]
            items[node_id] = _Item(
                node_id, left, right, max([size.h, *stack_h]), left_column, right_column
            )

    # Vertical: layers top-aligned.
    tops: list[float] = []
    bottoms: list[float] = []
    y = MARGIN
    for layer in layers:
        tops.append(y)
        bottoms.append(y + max((items[i].height for i in layer), default=0.0))
        y = bottoms[-1] + LAYER_GAP
    height = y - LAYER_GAP + MARGIN

    # Horizontal: pack, then alternate barycentric passes.
    x: dict[str, float] = {}
    for layer in layers:
        cursor = 0.0
        for node_id in layer:
            x[node_id] = cursor + items[node_id].left
            cursor = x[node_id] + items[node_id].right + NODE_GAP

    def place(layer: list[str], neighbours: Mapping[str, list[str]]) -> None:
        desired = []
        for node_id in layer:
            ns = [x[m] for m in neighbours.get(node_id, []) if m in x]
            desired.append(sum(ns) / len(ns) if ns else x[node_id])
        seps = [items[a].right + NODE_GAP + items[b].left for a, b in itertools.pairwise(layer)]
        for node_id, pos in zip(layer, _isotonic_place(desired, seps), strict=True):
            x[node_id] = pos

    preds = {n: list(routed.predecessors(n)) for n in routed}
    succs = {n: list(routed.successors(n)) for n in routed}
    both = {n: preds[n] + succs[n] for n in routed}
    for _ in range(4):
        for layer in layers[1:]:
            place(layer, preds)
        for layer in reversed(layers[:-1]):
            place(layer, succs)
    for layer in layers:
        place(layer, both)
    shift = MARGIN - min((x[n] - items[n].left for n in x), default=0.0)
    x = {n: v + shift for n, v in x.items()}
    width = max((x[n] + items[n].right for n in x), default=0.0) + MARGIN

    # Node boxes.
    boxes: dict[str, NodeBox] = {}

    def box(node_id: str, left: float, top: float) -> None:
        node, size = nodes[node_id], sizes[node_id]
        boxes[node_id] = NodeBox(
            id=node_id,
            type=node.type,
            shape=size.shape,
            counter=node.type in COUNTER_TYPES,
            undeveloped=node.undeveloped,
            x=left,
            y=top,
            w=size.w,
            h=size.h,
            shape_w=size.shape_w,
            shape_h=size.shape_h,
            lines=tuple(size.lines),
            subtitle=subtitles.get(node_id, ""),
            title=node.text,
        )

    for layer, top in zip(layers, tops, strict=True):
        for node_id in layer:
            if node_id.startswith("\x00"):
                continue
            size, item = sizes[node_id], items[node_id]
            shape_left = x[node_id] - size.shape_w / 2
            box(node_id, shape_left, top)
            stack_y = top
            for ctx in item.right_column:
                box(ctx, shape_left + size.w + SIDE_GAP, stack_y)
                stack_y += sizes[ctx].h + STACK_GAP
            stack_y = top
            for ctx in item.left_column:
                box(ctx, shape_left - SIDE_GAP - sizes[ctx].w, stack_y)
                stack_y += sizes[ctx].h + STACK_GAP

    # Edges.
    edges: list[Edge] = []
    for (u, v), chain in chains.items():
        bu, bv = boxes[u], boxes[v]
        points = [(bu.cx, bu.y + bu.shape_h), (bu.cx, bottoms[layer_of[u]] + 6)]
        for dummy in chain[1:-1]:
            k = layer_of[dummy]
            points += [(x[dummy], tops[k] - 6), (x[dummy], bottoms[k] + 6)]
        points += [(bv.cx, bv.y - 6), (bv.cx, bv.y)]
        edges.append(Edge(u, v, "supported_by", _dedupe(points)))

    def side_edge(source: str, target: str, kind: str, side_node: str) -> None:
        anchor = target if side_node == source else source
        sb, ab = boxes[side_node], boxes[anchor]
        points = _elbow(sb, ab) if side_of.get(side_node) == "left" else _elbow(ab, sb)
        left_id = side_node if side_of.get(side_node) == "left" else anchor
        if left_id != source:  # the polyline runs left to right; edges run source to target
            points = tuple(reversed(points))
        edges.append(Edge(source, target, kind, points))

    for node in case.nodes:
        for ctx in node.in_context_of:
            if ctx not in boxes or node.id not in boxes:
                continue
            if context_of.get(ctx) == node.id:
                side_edge(node.id, ctx, "in_context_of", ctx)
            else:
                edges.append(
                    Edge(
                        node.id,
                        ctx,
                        "in_context_of",
                        (_centre(boxes[node.id]), _centre(boxes[ctx])),
                    )
                )
        for target in node.challenges:
            if target not in boxes or node.id not in boxes:
                continue
            if counter_of.get(node.id) == target:
                side_edge(node.id, target, "challenges", node.id)
            else:
                edges.append(
                    Edge(
                        node.id,
                        target,
                        "challenges",
                        (_centre(boxes[node.id]), _centre(boxes[target])),
                    )
                )

    ordered = tuple(boxes[n.id] for n in case.nodes if n.id in boxes)
    return Diagram(round(width, 1), round(height, 1), ordered, tuple(edges))


def _centre(b: NodeBox) -> tuple[float, float]:
    return (b.cx, b.cy)


def _side_x(b: NodeBox, right: bool, y: float) -> float:
    """Where the horizontal line at `y` meets the node's shape on its left or right side."""
    if b.shape == "strategy":
        # the right side slants from (x + w, top) to (x + w - SKEW, bottom)
        frac = (y - b.y) / b.shape_h
        return b.x + b.shape_w - SKEW * frac if right else b.x + SKEW * (1 - frac)
    if b.shape in ("solution", "assumption", "justification"):
        rx, ry = b.shape_w / 2, b.shape_h / 2
        dy = min(1.0, abs(y - b.cy) / ry)
        dx = rx * (1 - dy * dy) ** 0.5
        return b.cx + dx if right else b.cx - dx
    return b.x + b.shape_w if right else b.x


def _elbow(a: NodeBox, b: NodeBox) -> tuple[tuple[float, float], ...]:
    """From the right side of `a` to the left side of `b`, through the empty gap between them."""
    ya, yb = a.cy, b.cy
    x_start = _side_x(a, True, ya)
    x_end = _side_x(b, False, yb)
    if abs(ya - yb) < 1.0:
        return ((x_start, ya), (x_end, ya))
    gap_x = a.x + a.w + SIDE_GAP / 2
    return ((x_start, ya), (gap_x, ya), (gap_x, yb), (x_end, yb))


def _dedupe(points: list[tuple[float, float]]) -> tuple[tuple[float, float], ...]:
    out: list[tuple[float, float]] = []
    for p in points:
        if not out or (abs(out[-1][0] - p[0]) > 1e-9 or abs(out[-1][1] - p[1]) > 1e-9):
            out.append(p)
    return tuple(out)
