"""Frames back to the JSON Lines form (`docs/streams.md`): the inverse of `monitor.parse`.

`casewatch convert` writes bags as streams with it, so the rest of the toolchain and users'
own scripts work on what a bag held. Numbers are written as they are (orjson and json both
write the shortest text that reads back to the same float), so parsing an encoded frame gives
the same frame (`tests/test_encode.py`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from casewatch.monitor.frames import (
    FORMAT_NAME,
    FORMAT_VERSION,
    ChannelState,
    Frame,
    Header,
    Objects,
    unpadded,
)


def _footprint(half: Any, polygon: np.ndarray) -> dict[str, Any]:
    if half is not None and not np.isnan(half[0]):
        return {"length": 2.0 * float(half[0]), "width": 2.0 * float(half[1])}
    return {"polygon": unpadded(polygon).tolist()}


def _objects(objs: Objects) -> list[dict[str, Any]]:
    out = []
    for i in range(len(objs)):
        o: dict[str, Any] = {
            "id": objs.ids[i],
            "cls": objs.cls[i],
            "x": float(objs.pos[i, 0]),
            "y": float(objs.pos[i, 1]),
            "yaw": float(objs.yaw[i]),
            "vx": float(objs.vel[i, 0]),
            "vy": float(objs.vel[i, 1]),
            **_footprint(objs.half[i], objs.footprints[i]),
        }
        n = int(objs.pred_len[i])
        if n:
            o["prediction"] = objs.pred[i, :n].tolist()
        out.append(o)
    return out


def channel_to_dict(state: ChannelState) -> dict[str, Any]:
    e = state.ego
    ego = {
        "x": e.x,
        "y": e.y,
        "yaw": e.yaw,
        "vx": e.vx,
        "vy": e.vy,
        **_footprint(e.half, e.footprint),
    }
    return {"ego": ego, "plan": state.plan.tolist(), "objects": _objects(state.objects)}


def frame_to_dict(frame: Frame) -> dict[str, Any]:
    """One frame as the JSON object of one stream line."""
    out: dict[str, Any] = {
        "t": frame.t,
        "channels": {name: channel_to_dict(s) for name, s in frame.channels.items()},
    }
    if frame.signals:
        out["signals"] = dict(frame.signals)
    return out


def header_to_dict(header: Header) -> dict[str, Any]:
    """The header line (`{"header": {...}}`)."""
    body: dict[str, Any] = {
        "format": FORMAT_NAME,
        "version": FORMAT_VERSION,
        "channels": list(header.channels),
        "period": header.period,
        "meta": dict(header.meta),
    }
    if header.coverage:
        body["coverage"] = {
            c: {
                "fov_deg": cov.fov_deg,
                **({} if cov.range_m == float("inf") else {"range_m": cov.range_m}),
            }
            for c, cov in header.coverage.items()
        }
    return {"header": body}
