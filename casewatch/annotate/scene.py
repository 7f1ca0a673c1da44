"""A JSON Lines drive as Foxglove scene entities: each channel's ego, objects, plan and
predictions, one `foxglove.SceneUpdate` per channel per frame on `/casewatch/scene/CHANNEL`.

A bag already holds the stack's own messages (copied as they are); a JSON Lines drive has no
recording Foxglove can show, so this draws what casewatch read, frame by frame, in the world
frame `map`. Entities keep their ids from frame to frame (the ego, `object-ID`, `plan`,
`prediction-ID`) and live two periods, so one that is no longer reported disappears.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np
from foxglove_schemas_protobuf.CubePrimitive_pb2 import CubePrimitive
from foxglove_schemas_protobuf.LinePrimitive_pb2 import LinePrimitive
from foxglove_schemas_protobuf.SceneEntity_pb2 import SceneEntity
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate

from casewatch.annotate import foxglove as fx
from casewatch.monitor.frames import ChannelState, Frame

SCENE_TOPIC = "/casewatch/scene/{channel}"

#: One colour per channel, in the case's channel order (ego box, plan).
CHANNEL_COLOURS = ("#1565c0", "#6a1b9a", "#00838f", "#2e7d32", "#ad1457", "#4e342e")
OBJECT_COLOUR = "#607d8b"
PREDICTION_COLOUR = "#90a4ae"
#: Height of the boxes drawn for footprints (the streams are 2-D), m.
BOX_HEIGHT = 1.6


def _footprint_world(footprint: np.ndarray, x: float, y: float, yaw: float) -> np.ndarray:
    """A body-frame polygon (V, 2) turned by `yaw` and moved to (x, y)."""
    c, s = np.cos(yaw), np.sin(yaw)
    rot = np.array([[c, -s], [s, c]])
    return footprint @ rot.T + np.array([x, y])


def _shape(
    hx: float, hy: float, footprint: np.ndarray, x: float, y: float, yaw: float, hue: str
) -> dict[str, list]:
    """A box as a cube, any other footprint as a closed outline."""
    if np.isfinite(hx) and np.isfinite(hy):
        cube = CubePrimitive(
            pose=fx.pose(x, y, BOX_HEIGHT / 2, yaw),
            size=fx.size(2 * hx, 2 * hy, BOX_HEIGHT),
            color=fx.color(hue, 0.75),
        )
        return {"cubes": [cube]}
    outline = LinePrimitive(
        type=LinePrimitive.LINE_LOOP,
        pose=fx.pose(0.0, 0.0),
        thickness=0.15,
        points=fx.points(_footprint_world(footprint, x, y, yaw)),
        color=fx.color(hue),
    )
    return {"lines": [outline]}


def _line(xy: np.ndarray, hue: str, thickness: float, alpha: float = 1.0) -> LinePrimitive:
    return LinePrimitive(
        type=LinePrimitive.LINE_STRIP,
        pose=fx.pose(0.0, 0.0),
        thickness=thickness,
        points=fx.points(xy, z=0.05),
        color=fx.color(hue, alpha),
    )


def channel_entities(state: ChannelState, ns: int, lifetime: float, hue: str) -> list[SceneEntity]:
    """The ego, its plan, and every object with its prediction, as scene entities."""

    def entity(entity_id: str, **parts: Any) -> SceneEntity:
        return SceneEntity(
            timestamp=fx.timestamp(ns),
            frame_id=fx.WORLD_FRAME,
            id=entity_id,
            lifetime=fx.duration(lifetime),
            **parts,
        )

    ego = state.ego
    hx, hy = ego.half if ego.half is not None else (np.nan, np.nan)
    out = [entity("ego", **_shape(hx, hy, ego.footprint, ego.x, ego.y, ego.yaw, hue))]
    if len(state.plan) >= 2:
        out.append(entity("plan", lines=[_line(state.plan[:, 1:3], hue, 0.3)]))
    objects = state.objects
    for k, object_id in enumerate(objects.ids):
        x, y = objects.pos[k]
        hx, hy = objects.half[k]
        parts = _shape(hx, hy, objects.footprints[k], x, y, objects.yaw[k], OBJECT_COLOUR)
        out.append(
            entity(
                f"object-{object_id}",
                metadata=fx.metadata(id=object_id, cls=objects.cls[k]),
                **parts,
            )
        )
        n = int(objects.pred_len[k])
        if n >= 2:
            xy = objects.pred[k, :n, 1:3]
            out.append(
                entity(f"prediction-{object_id}", lines=[_line(xy, PREDICTION_COLOUR, 0.15, 0.8)])
            )
    return out


def scene_messages(
    frames: Iterator[Frame], channels: list[str], period: float, t0_ns: int = 0
) -> Iterator[tuple[str, int, SceneUpdate]]:
    """(topic, log time, SceneUpdate) per channel present in each frame."""
    topics = {c: SCENE_TOPIC.format(channel=c) for c in channels}
    hues = {c: CHANNEL_COLOURS[i % len(CHANNEL_COLOURS)] for i, c in enumerate(channels)}
    for frame in frames:
        ns = t0_ns + round(frame.t * 1e9)
        for channel, state in frame.channels.items():
            entities = channel_entities(state, ns, 2 * period, hues[channel])
            yield topics[channel], ns, SceneUpdate(entities=entities)
