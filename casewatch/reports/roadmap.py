"""Road-network geometry for the violation map of `casewatch compare`.

Reads a SUMO network (`.net.xml`: every lane's `shape` and `width`, with xml.etree; sumolib is
an optional extra) or an OpenDRIVE map (`.xodr`: each road's planView reference line, sampled,
and its lanes' widths from the first laneSection) into plain polylines in world metres, fits
one world -> SVG transform for the map (y flipped, equal scale on both axes), and measures how
far map markers lie from the lanes.

The markers are the ego's own positions, so they must lie on a drivable lane. A marker
farther than half its nearest lane's width + `ROAD_MARGIN_M` from every lane centre line is
"off road": reported (count and list), never moved. When some are off road, `frame_hint`
tries the coordinate mistakes that put markers beside the road (CARLA's left-handed y, a SUMO
`netOffset` applied twice or not at all) and says which one would fit.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import shapely

from casewatch.errors import CasewatchError

#: Tolerance beyond a lane's half width before a marker counts as off the road [m].
ROAD_MARGIN_M = 0.5
#: SUMO's default lane width [m] (`netconvert --default.lanewidth`).
SUMO_DEFAULT_WIDTH = 3.2
#: Sampling step along OpenDRIVE reference lines [m].
XODR_STEP_M = 1.0
#: SUMO vehicle classes that make a lane no road for a car (sidewalks, bike lanes, rails).
_NOT_ROAD = {
    "pedestrian",
    "bicycle",
    "tram",
    "rail_urban",
    "rail",
    "rail_electric",
    "rail_fast",
    "ship",
    "subway",
    "cable_car",
}
#: OpenDRIVE lane types a car drives on (a lane without type counts as driving).
XODR_DRIVABLE = {
    "driving",
    "entry",
    "exit",
    "onRamp",
    "offRamp",
    "connectingRamp",
    "bidirectional",
    "stop",
    "parking",
}


class NetworkError(CasewatchError, ValueError):
    """A network file that cannot be drawn; the message names the file and what is wrong."""


@dataclass(frozen=True)
class Lane:
    """A drivable lane's centre line (world metres, n x 2) and its width."""

    id: str
    centre: np.ndarray
    width: float


@dataclass(frozen=True)
class RoadNetwork:
    """What the map draws and the off-road check measures against."""

    kind: str  # "sumo" or "opendrive"
    path: str
    lanes: list[Lane]  # drivable lanes: the off-road check
    other_lanes: list[Lane] = field(default_factory=list)  # sidewalks, rails: drawn pale only
    reference_lines: list[np.ndarray] = field(default_factory=list)  # OpenDRIVE roads
    edges: list[np.ndarray] = field(default_factory=list)  # OpenDRIVE outer road edges
    net_offset: tuple[float, float] | None = None  # SUMO `location netOffset`

    def bounds(self) -> tuple[float, float, float, float] | None:
        parts = [ln.centre for ln in (*self.lanes, *self.other_lanes)]
        parts += self.reference_lines + self.edges
        if not parts:
            return None
        xy = np.concatenate(parts)
        pad = max((ln.width for ln in self.lanes), default=0.0) / 2
        return (
            float(xy[:, 0].min()) - pad,
            float(xy[:, 1].min()) - pad,
            float(xy[:, 0].max()) + pad,
            float(xy[:, 1].max()) + pad,
        )


def _parse_xml(path: Path, root_tag: str, what: str) -> ET.Element:
    try:
        root = ET.parse(path).getroot()
    except FileNotFoundError:
        raise NetworkError(f"{path}: no such file") from None
    except OSError as exc:
        raise NetworkError(f"{path}: cannot read: {exc.strerror or exc}") from None
    except ET.ParseError as exc:
        line, col = exc.position
        raise NetworkError(f"{path}:{line}:{col}: not well-formed XML ({exc.msg})") from None
    if root.tag != root_tag:
        raise NetworkError(
            f"{path}: root element is <{root.tag}>, expected <{root_tag}> (is this {what}?)"
        )
    return root


def _float(
    element: ET.Element, name: str, path: Path, where: str, default: float | None = None
) -> float:
    text = element.get(name)
    if text is None:
        if default is not None:
            return default
        raise NetworkError(f"{path}: {where}: attribute '{name}' missing")
    try:
        value = float(text)
    except ValueError:
        raise NetworkError(
            f"{path}: {where}: attribute '{name}' is {text!r}, not a number"
        ) from None
    if not math.isfinite(value):
        raise NetworkError(f"{path}: {where}: attribute '{name}' is {text!r}, not finite")
    return value


def _shape(text: str, path: Path, where: str) -> np.ndarray:
    """A SUMO `shape` ("x,y x,y ..." with an optional z) as n x 2."""
    try:
        xy = np.array([[float(v) for v in p.split(",")[:2]] for p in text.split()], dtype=float)
    except ValueError:
        xy = np.empty((0, 3))
    if xy.ndim != 2 or xy.shape[1] != 2 or len(xy) < 2 or not np.isfinite(xy).all():
        raise NetworkError(
            f"{path}: {where}: shape {text[:60]!r} is not a list of at least two x,y points"
        )
    return xy


def read_sumo_net(path: Path | str) -> RoadNetwork:
    """Every lane of a SUMO `.net.xml` (internal junction lanes included: junctions are road)."""
    path = Path(path)
    root = _parse_xml(path, "net", "a SUMO .net.xml")
    lanes: list[Lane] = []
    other: list[Lane] = []
    for edge in root.iter("edge"):
        if edge.get("function") in ("walkingarea", "crossing"):
            continue
        for lane in edge.iter("lane"):
            where = f"lane {lane.get('id', '?')!r}"
            if lane.get("shape") is None:
                raise NetworkError(f"{path}: {where}: attribute 'shape' missing")
            centre = _shape(lane.get("shape", ""), path, where)
            width = _float(lane, "width", path, where, SUMO_DEFAULT_WIDTH)
            allow = set((lane.get("allow") or "").split())
            road = lane.get("disallow") != "all" and not (allow and allow <= _NOT_ROAD)
            (lanes if road else other).append(Lane(lane.get("id", "?"), centre, width))
    if not lanes:
        raise NetworkError(f"{path}: no drivable <lane> with a shape (an empty network?)")
    offset = None
    location = root.find("location")
    if location is not None and location.get("netOffset"):
        try:
            dx, dy = (float(v) for v in location.get("netOffset", "").split(","))
            offset = (dx, dy)
        except ValueError:
            raise NetworkError(
                f"{path}: <location> netOffset {location.get('netOffset')!r} is not x,y"
            ) from None
    return RoadNetwork("sumo", str(path), lanes, other, net_offset=offset)


# -- OpenDRIVE ------------------------------------------------------------------------------


def _steps(length: float) -> np.ndarray:
    return np.linspace(0.0, length, max(2, math.ceil(length / XODR_STEP_M) + 1))


def _integrate(s: np.ndarray, heading: np.ndarray, x0: float, y0: float) -> np.ndarray:
    """Positions along a curve from its heading at the samples (trapezoids on cos and sin)."""
    ds = np.diff(s)
    cx, sy = np.cos(heading), np.sin(heading)
    x = x0 + np.concatenate(([0.0], np.cumsum(ds * (cx[1:] + cx[:-1]) / 2)))
    y = y0 + np.concatenate(([0.0], np.cumsum(ds * (sy[1:] + sy[:-1]) / 2)))
    return np.column_stack((x, y))


def geometry_points(
    kind: str, x0: float, y0: float, hdg: float, length: float, params: dict[str, float]
) -> tuple[np.ndarray, np.ndarray]:
    """Samples (n x 2) and headings (n) of one planView geometry (OpenDRIVE 1.6, 7.x)."""
    if kind == "line":
        s = _steps(length)
        xy = np.column_stack((x0 + s * math.cos(hdg), y0 + s * math.sin(hdg)))
        return xy, np.full(len(s), hdg)
    if kind == "arc":
        k = params["curvature"]
        s = np.linspace(
            0.0,
            length,
            max(2, math.ceil(length / XODR_STEP_M) + 1, math.ceil(abs(k) * length / 0.05) + 1),
        )
        if abs(k) < 1e-12:
            return geometry_points("line", x0, y0, hdg, length, {})
        h = hdg + k * s  # exact circle: centre at the left normal, radius 1/k
        xy = np.column_stack(
            (x0 + (np.sin(h) - math.sin(hdg)) / k, y0 - (np.cos(h) - math.cos(hdg)) / k)
        )
        return xy, h
    if kind == "spiral":  # curvature linear in s: heading is quadratic, positions integrated
        s = np.linspace(0.0, length, max(2, math.ceil(length / 0.1) + 1))
        k0, k1 = params["curvStart"], params["curvEnd"]
        h = hdg + k0 * s + (k1 - k0) * s**2 / (2 * length)
        every = max(1, round(XODR_STEP_M / 0.1))
        xy = _integrate(s, h, x0, y0)
        keep = np.unique(np.r_[np.arange(0, len(s), every), len(s) - 1])
        return xy[keep], h[keep]
    if kind in ("poly3", "paramPoly3"):  # local (u, v) polynomials, rotated by hdg
        p = np.linspace(0.0, 1.0, max(2, math.ceil(length / 0.1) + 1))
        if kind == "poly3":  # v(u), u along hdg; the arc length reaches `length` by u=length
            a, b, c, d = (params[n] for n in ("a", "b", "c", "d"))
            u: np.ndarray = p * length
            v = a + b * u + c * u**2 + d * u**3
            arc = np.r_[0.0, np.cumsum(np.hypot(np.diff(u), np.diff(v)))]
            u = np.interp(np.linspace(0, length, len(p)), arc, u)
            v = a + b * u + c * u**2 + d * u**3
        else:
            scale = length if params.get("pRange") == "arcLength" else 1.0
            q = p * scale
            u = params["aU"] + params["bU"] * q + params["cU"] * q**2 + params["dU"] * q**3
            v = params["aV"] + params["bV"] * q + params["cV"] * q**2 + params["dV"] * q**3
        cos, sin = math.cos(hdg), math.sin(hdg)
        xy = np.column_stack((x0 + u * cos - v * sin, y0 + u * sin + v * cos))
        step = np.diff(xy, axis=0)
        h = np.arctan2(step[:, 1], step[:, 0])
        h = np.r_[h, h[-1]]
        every = max(1, round(XODR_STEP_M / 0.1))
        keep = np.unique(np.r_[np.arange(0, len(p), every), len(p) - 1])
        return xy[keep], h[keep]
    raise KeyError(kind)


_PARAMS = {
    "line": (),
    "arc": ("curvature",),
    "spiral": ("curvStart", "curvEnd"),
    "poly3": ("a", "b", "c", "d"),
    "paramPoly3": ("aU", "bU", "cU", "dU", "aV", "bV", "cV", "dV"),
}


def _offset(xy: np.ndarray, heading: np.ndarray, t: float) -> np.ndarray:
    """The curve shifted `t` metres to its left (OpenDRIVE's positive t)."""
    return xy + t * np.column_stack((-np.sin(heading), np.cos(heading)))


def _lane_widths(side: ET.Element | None, path: Path, road: str) -> list[tuple[int, float, str]]:
    """(id, width at the section start, type) of one side's lanes, innermost first."""
    if side is None:
        return []
    rows = []
    for lane in side.iter("lane"):
        where = f"road {road!r} lane {lane.get('id', '?')!r}"
        lane_id = int(_float(lane, "id", path, where))
        width = lane.find("width")
        w = 0.0 if width is None else _float(width, "a", path, where + " width")
        rows.append((lane_id, w, lane.get("type") or "driving"))
    return sorted(rows, key=lambda r: abs(r[0]))


def read_opendrive(path: Path | str) -> RoadNetwork:
    """Reference lines, outer edges and drivable lane centres of an OpenDRIVE `.xodr`.

    Lane widths are those at the start of each road's first laneSection (the `a` of its first
    `<width>`), held along the road, and a constant `laneOffset` is applied: enough for the
    map and the off-road check of ordinary maps, not a full lane model.
    """
    path = Path(path)
    root = _parse_xml(path, "OpenDRIVE", "an OpenDRIVE .xodr")
    references, edges, lanes = [], [], []
    for road in root.iter("road"):
        name = road.get("id", "?")
        plan = road.find("planView")
        if plan is None:
            raise NetworkError(f"{path}: road {name!r}: no <planView>")
        xy_parts, h_parts = [], []
        for i, geometry in enumerate(plan.findall("geometry"), 1):
            where = f"road {name!r} geometry {i}"
            x0, y0, hdg, length = (
                _float(geometry, a, path, where) for a in ("x", "y", "hdg", "length")
            )
            if length < 0:
                raise NetworkError(f"{path}: {where}: negative length {length}")
            shape = next(iter(geometry), None)
            if shape is None or shape.tag not in _PARAMS:
                found = "nothing" if shape is None else f"<{shape.tag}>"
                raise NetworkError(
                    f"{path}: {where}: {found} where line, arc, spiral, poly3 "
                    "or paramPoly3 was expected"
                )
            params = {
                a: _float(
                    shape,
                    a,
                    path,
                    f"{where} <{shape.tag}>",
                    0.0 if shape.tag in ("poly3", "paramPoly3") else None,
                )
                for a in _PARAMS[shape.tag]
            }
            if shape.tag == "paramPoly3":
                params["pRange"] = shape.get("pRange", "normalized")  # type: ignore[assignment,arg-type]
            if shape.tag == "spiral" and length == 0:
                continue
            xy, h = geometry_points(shape.tag, x0, y0, hdg, length, params)
            xy_parts.append(xy)
            h_parts.append(h)
        if not xy_parts:
            raise NetworkError(f"{path}: road {name!r}: <planView> without <geometry>")
        xy, h = np.concatenate(xy_parts), np.concatenate(h_parts)
        references.append(xy)
        section = road.find("lanes/laneSection")
        offset_el = road.find("lanes/laneOffset")
        base = (
            0.0
            if offset_el is None
            else _float(offset_el, "a", path, f"road {name!r} laneOffset", 0.0)
        )
        for side, sign in (("left", 1.0), ("right", -1.0)):
            rows = _lane_widths(None if section is None else section.find(side), path, name)
            inner = 0.0
            for lane_id, w, kind in rows:
                if w > 0 and kind in XODR_DRIVABLE:
                    lanes.append(
                        Lane(f"{name}:{lane_id}", _offset(xy, h, base + sign * (inner + w / 2)), w)
                    )
                inner += w
            if inner > 0:
                edges.append(_offset(xy, h, base + sign * inner))
    if not references:
        raise NetworkError(f"{path}: no <road> (an empty map?)")
    return RoadNetwork("opendrive", str(path), lanes, [], references, edges)


# -- the off-road check ---------------------------------------------------------------------


def _lines(polylines: list[np.ndarray]) -> np.ndarray:
    """LineStrings of polylines of any lengths, built in one call."""
    index = np.repeat(np.arange(len(polylines)), [len(p) for p in polylines])
    return shapely.linestrings(np.concatenate(polylines), indices=index)


def lane_distances(points: np.ndarray, network: RoadNetwork) -> tuple[np.ndarray, np.ndarray]:
    """Per point (n x 2): distance to the nearest drivable lane centre line, and whether it
    lies within half a lane's width + ROAD_MARGIN_M of some lane (on the road)."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    if not len(points) or not network.lanes:
        return np.full(len(points), np.nan), np.zeros(len(points), dtype=bool)
    lines = _lines([ln.centre for ln in network.lanes])
    reach = np.array([ln.width / 2 + ROAD_MARGIN_M for ln in network.lanes])
    tree = shapely.STRtree(lines)
    geoms = shapely.points(points)
    _, nearest = tree.query_nearest(geoms, return_distance=True, all_matches=False)
    near = np.asarray(nearest, dtype=float)
    hits = tree.query(geoms, predicate="dwithin", distance=float(reach.max()))
    inside = shapely.distance(geoms[hits[0]], lines[hits[1]]) <= reach[hits[1]]
    on_road = np.zeros(len(points), dtype=bool)
    on_road[hits[0][inside]] = True
    return near, on_road


def check_markers(markers: list[dict], network: RoadNetwork) -> dict:
    """Fill each marker's `network_distance` and `off_road`; the summary for compare.json."""
    points = np.array([(m["x"], m["y"]) for m in markers], dtype=float).reshape(-1, 2)
    near, on_road = lane_distances(points, network)
    for m, d, ok in zip(markers, near, on_road, strict=True):
        m["network_distance"] = round(float(d), 3)
        m["off_road"] = not bool(ok)
    off = [i for i, m in enumerate(markers) if m["off_road"]]
    return {
        "path": network.path,
        "kind": network.kind,
        "lanes": len(network.lanes),
        "margin_m": ROAD_MARGIN_M,
        "checked": len(markers),
        "off_road": len(off),
        "off_road_markers": off,
        "max_distance": round(float(near.max()), 3) if len(near) else None,
        "net_offset": list(network.net_offset) if network.net_offset else None,
        "hint": frame_hint(points, network) if off else None,
    }


def frame_hint(points: np.ndarray, network: RoadNetwork) -> str | None:
    """Which usual coordinate mistake would put (strictly) more markers on the road, if any."""
    flip = np.array([1.0, -1.0])
    candidates = [("y negated (CARLA's left-handed frame vs OpenDRIVE's)", points * flip)]
    if network.net_offset:
        offset = np.asarray(network.net_offset, dtype=float)
        candidates += [
            ("plus the net's netOffset (positions in the original map frame)", points + offset),
            ("minus the net's netOffset (offset applied twice)", points - offset),
        ]
    base = int(lane_distances(points, network)[1].sum())
    best = max(
        ((int(lane_distances(p, network)[1].sum()), why) for why, p in candidates), default=(0, "")
    )
    if best[0] > base:
        return (
            f"{best[0]} of {len(points)} markers would be on the road with {best[1]}: "
            "the positions and the network may not share one frame"
        )
    return None


# -- world -> SVG -----------------------------------------------------------------------------


@dataclass(frozen=True)
class MapTransform:
    """World metres -> SVG pixels: one scale for both axes, y flipped (world y points up)."""

    scale: float  # pixels per metre
    min_x: float
    max_y: float
    offset_x: float  # pixels left of the drawing (margin, plus centring)
    offset_y: float
    width: float
    height: float

    def apply(self, xy: np.ndarray) -> np.ndarray:
        xy = np.asarray(xy, dtype=float).reshape(-1, 2)
        return np.column_stack(
            (
                self.offset_x + (xy[:, 0] - self.min_x) * self.scale,
                self.offset_y + (self.max_y - xy[:, 1]) * self.scale,
            )
        )


def fit_transform(
    bounds: tuple[float, float, float, float],
    width: float = 900.0,
    max_height: float = 640.0,
    margin: float = 16.0,
    min_extent: float = 20.0,
) -> MapTransform:
    """The transform showing `bounds` (min_x, min_y, max_x, max_y) in `width` pixels and at
    most `max_height`, keeping the aspect; extents below `min_extent` metres are widened
    (one straight road is not a 0-pixel-high map)."""
    x0, y0, x1, y1 = bounds
    cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
    dx, dy = max(x1 - x0, min_extent), max(y1 - y0, min_extent)
    x0, x1, y0, y1 = cx - dx / 2, cx + dx / 2, cy - dy / 2, cy + dy / 2
    scale = min((width - 2 * margin) / dx, (max_height - 2 * margin) / dy)
    height = dy * scale + 2 * margin
    return MapTransform(
        scale=scale,
        min_x=x0,
        max_y=y1,
        offset_x=(width - dx * scale) / 2,
        offset_y=margin,
        width=width,
        height=height,
    )
